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
    /// Closest hits on levels of detail: each object's subtrees whose
    /// error is below the bound (and the ray's cone footprint) are met as
    /// one plane fitted to their triangles. Omitted or null: exact
    /// geometry. Every hit then reports the error it took.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod: Option<LodInput>,
}

/// How coarse a ray query may see the geometry.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LodInput {
    /// Largest error a level of detail may carry, metres (about the size
    /// of the features it drops); 0 is exact geometry.
    #[serde(default = "default_max_error_m")]
    #[schema(minimum = 0.0, default = 0.01)]
    pub max_error_m: f32,
    /// The rays' cone: the tangent of its half-angle (a pixel's, or a
    /// ray's share of the sphere); omitted: no footprint limit, only
    /// `max_error_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0.0, maximum = 1.0)]
    pub cone_angle: Option<f32>,
    /// The cone's radius at the ray's origin, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0.0)]
    pub cone_spread_m: Option<f32>,
}

/// A conservative bound: a centimetre.
fn default_max_error_m() -> f32 {
    0.01
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
    /// With `lod`: the error of the level of detail met, metres (0 on a
    /// triangle; then `triangle` is the largest one it stands for).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod_error_m: Option<f32>,
}
