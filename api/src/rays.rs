//! `POST /v1/scenes/{id}/rays`: batched ray queries. Directions are
//! normalised, so `t` and `max_distance` are distances in metres.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::schemas::Vector3;

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RaysRequest {
    pub rays: Vec<RayInput>,
    #[serde(default)]
    pub mode: Mode,
}

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RayInput {
    #[schema(value_type = Vector3)]
    pub origin: [f32; 3],
    /// Need not be unit length; not zero.
    #[schema(value_type = Vector3)]
    pub direction: [f32; 3],
    /// Along `direction` normalised, metres; omitted or null: unbounded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0.0)]
    pub max_distance: Option<f32>,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Nearest hit per ray, for reflections and distances.
    #[default]
    Closest,
    /// Whether anything blocks the ray, for visibility; cheaper.
    Any,
}

/// Serialises as `{"hits": [...]}` or `{"occluded": [...]}`.
#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum RaysResponse {
    Hits(Vec<Option<HitOutput>>),
    Occluded(Vec<bool>),
}

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct HitOutput {
    pub t: f32,
    pub object: u32,
    pub object_name: String,
    pub triangle: u32,
    #[schema(value_type = Vector3)]
    pub point: [f32; 3],
    #[schema(value_type = Vector3)]
    pub normal: [f32; 3],
    pub material: String,
}
