//! `GET /v1/scenes/{id}/stream`: the WebSocket's frames. The client sends
//! [`StreamUpdate`]s (JSON text); the server answers with [`StreamFrame`]s
//! (JSON text), each impulse response followed by a binary frame of
//! interleaved little-endian f32 samples.

use frusta_engine::acoustics::SimulationOptions;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::collisions::{CollisionRequest, CollisionResponse};
use crate::impulse_responses::{PairResponse, Point};
use crate::objects::EditReport;
pub use crate::objects::ObjectMove;
use crate::problem::Problem;

/// One message from the client; omitted fields keep their last value.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct StreamUpdate {
    /// Echoed in the answers that include this update, for latency.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seq: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sources: Option<Vec<Point>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub listeners: Option<Vec<Point>>,
    /// Simulation options, as in the impulse-response route.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Object>)]
    pub options: Option<SimulationOptions>,
    /// Levels of detail, as the impulse-response route's `lod_error_m`.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0.0)]
    pub lod_error_m: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub objects: Option<Vec<ObjectMove>>,
    /// Subscribes to collision results, replacing an earlier subscription:
    /// answered after every update and every edit of the scene, a
    /// continuous query over this update's object moves. Its `moves` must
    /// be empty (moves go in `objects`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub collisions: Option<CollisionRequest>,
}

/// A text frame from the server.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum StreamFrame {
    /// One source-listener pair; its samples follow as a binary frame.
    /// Boxed: it is several times the size of the other frames.
    ImpulseResponse(Box<StreamAnswer>),
    /// Object moves sent before any source and listener, applied.
    ObjectsUpdated(ObjectsUpdated),
    /// The collision subscription's answer for this update.
    Collisions(StreamCollisions),
    /// An update that was refused, or a job that failed; the stream stays
    /// open. Nested, not flattened: the problem has a `type` of its own.
    Error { problem: Problem },
}

/// An impulse response on a stream: the HTTP route's fields plus what the
/// stream adds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct StreamAnswer {
    /// The `seq` of the newest update this answer includes.
    pub seq: Option<u64>,
    pub revision: u64,
    pub compute_ms: f64,
    /// What each object move of this update did to the hierarchy.
    pub objects: Vec<EditReport>,
    #[serde(flatten)]
    pub pair: PairResponse,
}

/// Collisions on a stream: the collision route's answer plus what the
/// stream adds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct StreamCollisions {
    /// The `seq` of the newest update this answer includes.
    pub seq: Option<u64>,
    /// What each object move of this update did to the hierarchy.
    pub objects: Vec<EditReport>,
    #[serde(flatten)]
    pub collisions: CollisionResponse,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ObjectsUpdated {
    pub seq: Option<u64>,
    pub revision: u64,
    pub objects: Vec<EditReport>,
}
