//! `PATCH /v1/scenes/{id}/objects/{object}`: moving and deforming objects,
//! and what each edit did to the hierarchy.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::schemas::{Quaternion, Vector3};

/// Omitted parts stay as they are.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectPatch {
    /// Quaternion `[x, y, z, w]` (normalised by the server).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Quaternion>)]
    pub rotation: Option<[f32; 4]>,
    /// `[x, y, z]` in metres.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vector3>)]
    pub translation: Option<[f32; 3]>,
    /// Every vertex's new position in the object's frame, in the mesh's
    /// vertex order (the count cannot change).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vec<Vector3>>, min_items = 1)]
    pub vertices: Option<Vec<[f32; 3]>>,
}

/// An object edit sent with another request (a stream update, a
/// collision query): applied and stored as a `PATCH` is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectMove {
    /// Name or index.
    pub object: String,
    #[serde(flatten)]
    pub patch: ObjectPatch,
}

/// What an object edit did, for the answer and the metrics.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct EditReport {
    pub revision: u64,
    pub action: EditAction,
    /// Bounding-volume degradation after a refit (Lauterbach 4.1.5).
    pub degradation: Option<f32>,
    pub elapsed_ms: f64,
}

/// How the hierarchy followed an edit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum EditAction {
    /// Only the top level changed (a rigid move).
    Transform,
    /// The object's tree was refitted to new vertices.
    Refit,
    /// The object's tree was built again.
    Rebuild,
}

impl EditAction {
    /// The name on the wire, also a metrics label.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Transform => "transform",
            Self::Refit => "refit",
            Self::Rebuild => "rebuild",
        }
    }
}
