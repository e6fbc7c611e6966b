//! `POST /v1/scenes/{id}/shadows`: which pixels of a camera's view a point
//! light reaches (hard shadows), as a grey PNG or as JSON; and
//! `POST /v1/scenes/{id}/visibility`: which of a list of points (seats,
//! listeners) see a point light.

use frusta_engine::shadows::{
    Camera, Method, PointLight, PointVisibility, ShadowImage, ShadowOptions, ShadowStats,
};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::schemas::Vector3;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ShadowRequest {
    pub camera: CameraSpec,
    pub light: LightSpec,
    /// `selective` (the default: exact, rays only where the light map
    /// cannot prove a pixel), `full` (a ray per pixel) or `shadow-map`
    /// (the plain shadow map: fast and wrong near edges).
    #[serde(default)]
    pub method: ShadowMethod,
    /// Side of each cube face of the light map, texels (default 256).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 16, maximum = 512)]
    pub shadow_map_size: Option<u32>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    #[schema(value_type = Vector3)]
    pub position: [f32; 3],
    #[schema(value_type = Vector3)]
    pub look_at: [f32; 3],
    /// Default `[0, 0, 1]`.
    #[serde(default = "up")]
    #[schema(value_type = Vector3)]
    pub up: [f32; 3],
    /// Vertical field of view, degrees (default 60).
    #[serde(default = "fov")]
    #[schema(exclusive_minimum = 0.5, exclusive_maximum = 179.0)]
    pub fov_y_deg: f32,
    #[schema(minimum = 1, maximum = 1024)]
    pub width: u32,
    #[schema(minimum = 1, maximum = 1024)]
    pub height: u32,
}

fn up() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}

fn fov() -> f32 {
    60.0
}

/// A point light.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    #[schema(value_type = Vector3)]
    pub position: [f32; 3],
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ShadowMethod {
    #[default]
    Selective,
    Full,
    ShadowMap,
}

impl ShadowRequest {
    /// The engine's camera, light and options.
    pub fn engine(&self) -> (Camera, PointLight, ShadowOptions) {
        let c = &self.camera;
        let camera = Camera {
            position: Vec3::from_array(c.position),
            look_at: Vec3::from_array(c.look_at),
            up: Vec3::from_array(c.up),
            fov_y_deg: c.fov_y_deg,
            width: c.width,
            height: c.height,
        };
        let light = PointLight {
            position: Vec3::from_array(self.light.position),
        };
        let options = options(self.method, self.shadow_map_size);
        (camera, light, options)
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct VisibilityRequest {
    pub light: LightSpec,
    #[schema(value_type = Vec<Vector3>, max_items = 100000)]
    pub points: Vec<[f32; 3]>,
    /// As for shadow images; `selective` traces only the points the light
    /// map cannot prove.
    #[serde(default)]
    pub method: ShadowMethod,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 16, maximum = 512)]
    pub shadow_map_size: Option<u32>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct VisibilityResponse {
    pub revision: u64,
    /// Per point: whether nothing lies between it and the light.
    pub visible: Vec<bool>,
    /// `receivers` counts the points, `pip_pixels` those traced.
    pub stats: ShadowStatsOut,
}

impl VisibilityRequest {
    /// The engine's light, points and options.
    pub fn engine(&self) -> (PointLight, Vec<Vec3>, ShadowOptions) {
        let light = PointLight {
            position: Vec3::from_array(self.light.position),
        };
        let points = self.points.iter().map(|p| Vec3::from_array(*p)).collect();
        (light, points, options(self.method, self.shadow_map_size))
    }
}

fn options(method: ShadowMethod, shadow_map_size: Option<u32>) -> ShadowOptions {
    ShadowOptions {
        method: match method {
            ShadowMethod::Selective => Method::Selective,
            ShadowMethod::Full => Method::Full,
            ShadowMethod::ShadowMap => Method::ShadowMap,
        },
        shadow_map_size: shadow_map_size.unwrap_or(ShadowOptions::default().shadow_map_size),
    }
}

impl From<&ShadowStats> for ShadowStatsOut {
    fn from(s: &ShadowStats) -> Self {
        Self {
            receivers: s.receivers,
            pip_pixels: s.pip_pixels,
            rays: s.rays,
            gbuffer_ms: s.gbuffer_ms,
            light_map_ms: s.light_map_ms,
            classify_ms: s.classify_ms,
            trace_ms: s.trace_ms,
            total_ms: s.total_ms,
        }
    }
}

impl VisibilityResponse {
    pub fn new(revision: u64, answer: &PointVisibility) -> Self {
        Self {
            revision,
            visible: answer.visible.clone(),
            stats: (&answer.stats).into(),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ShadowResponse {
    /// The scene's revision the image is of.
    pub revision: u64,
    pub width: u32,
    pub height: u32,
    /// Row by row from the top: 255 where the light reaches the surface a
    /// pixel sees (or the pixel sees nothing), 0 where it is shadowed.
    pub visibility: Vec<u8>,
    pub stats: ShadowStatsOut,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ShadowStatsOut {
    /// Pixels that see a surface.
    pub receivers: u64,
    /// Pixels the light map could not prove, which were traced.
    pub pip_pixels: u64,
    pub rays: u64,
    pub gbuffer_ms: f64,
    pub light_map_ms: f64,
    pub classify_ms: f64,
    pub trace_ms: f64,
    pub total_ms: f64,
}

/// Visibility as 8-bit grey levels.
pub fn grey_levels(image: &ShadowImage) -> Vec<u8> {
    image
        .visibility
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect()
}

impl ShadowResponse {
    pub fn new(revision: u64, image: &ShadowImage) -> Self {
        Self {
            revision,
            width: image.width,
            height: image.height,
            visibility: grey_levels(image),
            stats: (&image.stats).into(),
        }
    }
}

/// The image as an 8-bit greyscale PNG.
pub fn png(image: &ShadowImage) -> Result<Vec<u8>, String> {
    png_of_levels(image.width, image.height, &grey_levels(image))
}

/// Grey levels, row by row from the top, as an 8-bit greyscale PNG.
pub fn png_of_levels(width: u32, height: u32, levels: &[u8]) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    let mut encoder = ::png::Encoder::new(&mut bytes, width, height);
    encoder.set_color(::png::ColorType::Grayscale);
    encoder.set_depth(::png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(levels).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    Ok(bytes)
}
