//! `POST /v1/scenes/{id}/shadows`: how much of a light each pixel of a
//! camera's view receives (hard shadows of a point, spot or directional
//! light, soft shadows of an area light), as a grey PNG or as JSON; and
//! `POST /v1/scenes/{id}/visibility`: how much of a light each of a list
//! of points (seats, listeners) sees.

use frusta_engine::shadows::{
    AreaLight, AreaShape, Camera, DirectionalLight, Light, Method, PointLight, PointVisibility,
    ShadowImage, ShadowOptions, ShadowStats, SpotLight,
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
    /// `auto` (the default: `selective` where its light map is estimated
    /// to pay, else `full`), `selective` (exact, rays only where the light
    /// map, or for an area light each pixel's hull, cannot prove a pixel),
    /// `full` (a ray per pixel and sample) or `shadow-map` (the plain
    /// shadow map: fast and wrong near edges).
    #[serde(default)]
    pub method: ShadowMethod,
    /// Side of each cube face of the light map, texels (default 256).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 16, maximum = 512)]
    pub shadow_map_size: Option<u32>,
    /// Area lights: each receiver draws `samples x samples` stratified
    /// samples of the light (default 4: 16 samples); at most 2^24 rays in
    /// all (receivers x samples^2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 1, maximum = 8)]
    pub samples: Option<u32>,
    /// Area lights: the samples' seed (default 0); the same seed gives the
    /// same image.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
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

/// A light at `position`: a point (the default, hard shadows), a `spot`
/// (a point shining into the cone of `half_angle_deg` around `direction`),
/// or with an area `shape` an area light centred there (soft shadows); or
/// a `directional` light (the sun: hard shadows), which has a `direction`
/// and no position.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Every light but a directional one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vector3>)]
    pub position: Option<[f32; 3]>,
    #[serde(default)]
    pub shape: LightShape,
    /// Directional: the direction its light travels, from the light into
    /// the scene; spot: its cone's axis (any length but zero).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vector3>)]
    pub direction: Option<[f32; 3]>,
    /// Spot: the angle between its axis and its cone's edge, degrees, in
    /// `(0, 180]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_angle_deg: Option<f32>,
    /// Rectangle: the half edges, `position + a u + b v` for `a, b` in
    /// `[-1, 1]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vector3>)]
    pub u: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vector3>)]
    pub v: Option<[f32; 3]>,
    /// Disk: the side it faces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vector3>)]
    pub normal: Option<[f32; 3]>,
    /// Disk and sphere, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f32>,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "kebab-case")]
pub enum LightShape {
    #[default]
    Point,
    Spot,
    Directional,
    Rectangle,
    Disk,
    Sphere,
}

impl LightSpec {
    /// The engine's light, or what is missing or out of place.
    pub fn engine(&self) -> Result<Light, String> {
        let need = |v: Option<[f32; 3]>, what: &str| {
            v.map(Vec3::from_array)
                .ok_or(format!("a {:?} light needs `{what}`", self.shape))
        };
        let radius = || {
            self.radius
                .ok_or(format!("a {:?} light needs `radius`", self.shape))
        };
        let used: &[(&str, bool)] = &[
            ("position", self.position.is_some()),
            ("direction", self.direction.is_some()),
            ("half_angle_deg", self.half_angle_deg.is_some()),
            ("u", self.u.is_some()),
            ("v", self.v.is_some()),
            ("normal", self.normal.is_some()),
            ("radius", self.radius.is_some()),
        ];
        let allowed: &[&str] = match self.shape {
            LightShape::Point => &["position"],
            LightShape::Spot => &["position", "direction", "half_angle_deg"],
            LightShape::Directional => &["direction"],
            LightShape::Rectangle => &["position", "u", "v"],
            LightShape::Disk => &["position", "normal", "radius"],
            LightShape::Sphere => &["position", "radius"],
        };
        if let Some((field, _)) = used.iter().find(|(f, set)| *set && !allowed.contains(f)) {
            return Err(format!(
                "`{field}` does not apply to a {:?} light",
                self.shape
            ));
        }
        let centre = || need(self.position, "position");
        let area = |shape| -> Result<Light, String> {
            Ok(Light::Area(AreaLight {
                centre: centre()?,
                shape,
            }))
        };
        Ok(match self.shape {
            LightShape::Point => Light::Point(PointLight {
                position: centre()?,
            }),
            LightShape::Spot => Light::Spot(SpotLight {
                position: centre()?,
                direction: need(self.direction, "direction")?,
                half_angle_deg: self
                    .half_angle_deg
                    .ok_or("a Spot light needs `half_angle_deg`")?,
            }),
            LightShape::Directional => Light::Directional(DirectionalLight {
                direction: need(self.direction, "direction")?,
            }),
            LightShape::Rectangle => area(AreaShape::Rectangle {
                u: need(self.u, "u")?,
                v: need(self.v, "v")?,
            })?,
            LightShape::Disk => area(AreaShape::Disk {
                normal: need(self.normal, "normal")?,
                radius: radius()?,
            })?,
            LightShape::Sphere => area(AreaShape::Sphere { radius: radius()? })?,
        })
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ShadowMethod {
    #[default]
    Auto,
    Selective,
    Full,
    ShadowMap,
}

impl ShadowRequest {
    /// The engine's camera, light and options, or what is wrong with the
    /// light.
    pub fn engine(&self) -> Result<(Camera, Light, ShadowOptions), String> {
        let c = &self.camera;
        let camera = Camera {
            position: Vec3::from_array(c.position),
            look_at: Vec3::from_array(c.look_at),
            up: Vec3::from_array(c.up),
            fov_y_deg: c.fov_y_deg,
            width: c.width,
            height: c.height,
        };
        let light = self.light.engine()?;
        let options = options(self.method, self.shadow_map_size, self.samples, self.seed);
        Ok((camera, light, options))
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct VisibilityRequest {
    pub light: LightSpec,
    #[schema(value_type = Vec<Vector3>, max_items = 100000)]
    pub points: Vec<[f32; 3]>,
    /// As for shadow images; `selective` traces only the points the light
    /// map cannot prove, `auto` (the default) traces them all where the
    /// map would cost more than their rays.
    #[serde(default)]
    pub method: ShadowMethod,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 16, maximum = 512)]
    pub shadow_map_size: Option<u32>,
    /// As for shadow images.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 1, maximum = 8)]
    pub samples: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct VisibilityResponse {
    pub revision: u64,
    /// Per point: whether it sees all of the light (a point light: whether
    /// nothing lies between them).
    pub visible: Vec<bool>,
    /// Per point: the fraction of the light's samples it sees (0 or 1 for
    /// a point light).
    pub fraction: Vec<f32>,
    /// `receivers` counts the points, `pip_pixels` those traced.
    pub stats: ShadowStatsOut,
}

impl VisibilityRequest {
    /// The engine's light, points and options, or what is wrong with the
    /// light.
    pub fn engine(&self) -> Result<(Light, Vec<Vec3>, ShadowOptions), String> {
        let light = self.light.engine()?;
        let points = self.points.iter().map(|p| Vec3::from_array(*p)).collect();
        let options = options(self.method, self.shadow_map_size, self.samples, self.seed);
        Ok((light, points, options))
    }
}

fn options(
    method: ShadowMethod,
    shadow_map_size: Option<u32>,
    samples: Option<u32>,
    seed: Option<u64>,
) -> ShadowOptions {
    let default = ShadowOptions::default();
    ShadowOptions {
        method: match method {
            ShadowMethod::Auto => Method::Auto,
            ShadowMethod::Selective => Method::Selective,
            ShadowMethod::Full => Method::Full,
            ShadowMethod::ShadowMap => Method::ShadowMap,
        },
        shadow_map_size: shadow_map_size.unwrap_or(default.shadow_map_size),
        samples: samples.unwrap_or(default.samples),
        seed: seed.unwrap_or(default.seed),
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
            visible: answer.fraction.iter().map(|&f| f == 1.0).collect(),
            fraction: answer.fraction.clone(),
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
    /// pixel sees (or the pixel sees nothing), 0 where it is shadowed,
    /// and for an area light the fraction of it seen in between.
    pub visibility: Vec<u8>,
    pub stats: ShadowStatsOut,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ShadowStatsOut {
    /// Pixels that see a surface.
    pub receivers: u64,
    /// Receivers the proofs (light map, or an area light's hulls) left
    /// open, which were traced.
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
