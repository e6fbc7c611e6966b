//! `POST /v1/scenes/{id}/occlusion`: point-to-point visibility.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::schemas::Vector3;

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct OcclusionRequest {
    pub pairs: Vec<PointPair>,
}

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PointPair {
    #[schema(value_type = Vector3)]
    pub from: [f32; 3],
    #[schema(value_type = Vector3)]
    pub to: [f32; 3],
}

#[derive(Clone, Debug, Serialize, Deserialize, ToSchema)]
pub struct OcclusionResponse {
    /// Per pair: whether nothing lies strictly between the two points.
    pub visible: Vec<bool>,
}
