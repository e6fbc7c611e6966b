//! Shadow queries by selective ray tracing (Lauterbach's dissertation,
//! section 6.3), on CPU cores.
//!
//! A shadow query sees the scene through a [`Camera`]: the visible surface
//! point of every pixel (the [`GBuffer`], rasterised) receives light from a
//! [`PointLight`] when the segment between them is clear, or from a
//! [`DirectionalLight`] when the ray against its direction is. Three methods
//! answer it:
//! - [`Method::Full`] traces one shadow ray per pixel: the reference;
//! - [`Method::ShadowMap`] reads a plain depth map from the light: fast, and
//!   wrong near shadow edges and for thin geometry;
//! - [`Method::Selective`] classifies each pixel from a conservative light
//!   map ([`light_map`]) as surely lit, surely shadowed, or potentially
//!   incorrect (PIP), and traces only the PIP. The classification is a
//!   proof, not a heuristic: a pixel is called lit or shadowed only when no
//!   ray the reference could trace would say otherwise, so selective and
//!   full agree on every pixel.
//!
//! An [`AreaLight`] (rectangle, disk, sphere) casts soft shadows: each
//! receiver sees the fraction of `S x S` stratified samples of the light
//! it has a clear segment to, drawn from a stream named by the receiver
//! and the seed, so every method draws the same samples. Selective proves
//! receivers lit or in the umbra from the triangles that may meet the hull
//! between the receiver and the light ([`ShadowScene::soft_shadows`]) and
//! traces the samples of the rest. A surface receives light only on the
//! side it is seen from.
//!
//! ```
//! use frusta_engine::bvh::{BuildOptions, SceneBvh};
//! use frusta_engine::geometry::shapes::cube;
//! use frusta_engine::scene::{Material, RawMesh, Scene};
//! use frusta_engine::shadows::{hard_shadows, Camera, Method, PointLight, ShadowOptions};
//! use glam::Vec3;
//!
//! let cube = cube(1.0, 1);
//! let raw = RawMesh { positions: cube.positions().to_vec(), triangles: cube.triangles().to_vec(), ..RawMesh::default() };
//! let scene = Scene::single_object("box", raw, Material::uniform("m", 0.1).unwrap()).unwrap();
//! let world = SceneBvh::build(&scene, &BuildOptions::default());
//! let camera = Camera::looking_at(Vec3::new(0.0, -4.0, 0.5), Vec3::ZERO, 64, 48);
//! let light = PointLight { position: Vec3::new(0.5, -3.0, 3.0) };
//! let selective = hard_shadows(&world, &camera, &light, &ShadowOptions::default()).unwrap();
//! let full = hard_shadows(&world, &camera, &light, &ShadowOptions { method: Method::Full, ..Default::default() }).unwrap();
//! assert_eq!(selective.visibility, full.visibility);
//! ```

mod area;
mod camera;
mod eye;
pub mod light_map;
mod occluders;
mod penumbra;
mod raster;
mod scene;
mod selective;
mod soft;

pub use area::{AreaLight, AreaShape};
pub use camera::{Camera, GBuffer, Receiver, MAX_IMAGE_PIXELS};
pub use scene::{hard_shadows, PointVisibility, ShadowImage, ShadowScene, MAX_POINTS};
pub use selective::{shadow_ray, ShadowStats, SHADOW_T_MIN};

use glam::Vec3;

use crate::{Error, Result};

/// A point light (omnidirectional).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
}

impl PointLight {
    pub fn check(&self) -> Result<()> {
        if !self.position.is_finite() || self.position.abs().max_element() > 1e15 {
            return Err(Error::InvalidPosition {
                what: "light".into(),
                value: format!("{:?}", self.position),
            });
        }
        Ok(())
    }
}

/// A directional light (the sun): parallel light from infinitely far
/// away, travelling along `direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// The direction the light travels (from the light into the scene);
    /// any length but zero.
    pub direction: Vec3,
}

impl DirectionalLight {
    /// The unit direction, if `direction` is one (finite, not zero).
    pub fn unit(&self) -> Option<Vec3> {
        unit_direction(self.direction)
    }

    pub fn check(&self) -> Result<()> {
        check_direction(self.direction)
    }
}

/// A spot light: a point light shining only into a cone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotLight {
    pub position: Vec3,
    /// The cone's axis, the way it shines; any length but zero.
    pub direction: Vec3,
    /// The angle between the axis and the cone's edge, degrees, in
    /// `(0, 180]` (180: a point light).
    pub half_angle_deg: f32,
}

impl SpotLight {
    pub fn check(&self) -> Result<()> {
        PointLight {
            position: self.position,
        }
        .check()?;
        check_direction(self.direction)?;
        if !(self.half_angle_deg > 0.0 && self.half_angle_deg <= 180.0) {
            return Err(Error::InvalidOption {
                field: "light.half_angle_deg".into(),
                reason: format!("{} must lie in (0, 180]", self.half_angle_deg),
            });
        }
        Ok(())
    }
}

/// `direction` scaled to unit length, if it is a direction (finite, not
/// zero).
fn unit_direction(direction: Vec3) -> Option<Vec3> {
    // Scaled first, so that no length squared overflows or vanishes.
    let largest = direction.abs().max_element();
    let unit = (direction / largest).normalize_or_zero();
    (largest.is_finite() && unit != Vec3::ZERO).then_some(unit)
}

fn check_direction(direction: Vec3) -> Result<()> {
    match unit_direction(direction) {
        Some(_) => Ok(()),
        None => Err(Error::InvalidOption {
            field: "light.direction".into(),
            reason: format!("{direction:?} is not a direction"),
        }),
    }
}

/// Any light: a point, a spot or a direction casts hard shadows, an area
/// light soft ones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Point(PointLight),
    Spot(SpotLight),
    Directional(DirectionalLight),
    Area(AreaLight),
}

impl Light {
    pub fn check(&self) -> Result<()> {
        match self {
            Light::Point(l) => l.check(),
            Light::Spot(l) => l.check(),
            Light::Directional(l) => l.check(),
            Light::Area(l) => l.check(),
        }
    }
}

/// How a shadow query is answered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    /// Selective where its light map is estimated to cost less than the
    /// rays it saves, else full (few receivers, many triangles): exact
    /// either way. Area lights: selective.
    #[default]
    Auto,
    /// Rays only where the light map (area lights: each receiver's hull)
    /// cannot prove the answer.
    Selective,
    /// One ray per pixel: the reference.
    Full,
    /// The plain shadow map alone (depth at each texel's centre, with a
    /// slope-free bias): the baseline selective tracing corrects.
    ShadowMap,
}

/// Largest shadow-map side the engine accepts.
pub const MAX_SHADOW_MAP_SIZE: u32 = 4096;

/// Most samples per side of an area light.
pub const MAX_LIGHT_SAMPLES: u32 = 16;

/// Options of a shadow query.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowOptions {
    pub method: Method,
    /// Side of each shadow-map face in texels (point lights; for an area
    /// light, the plain map of its centre).
    pub shadow_map_size: u32,
    /// Area lights: each receiver draws `samples x samples` stratified
    /// samples of the light.
    pub samples: u32,
    /// Area lights: the seed of the samples' streams.
    pub seed: u64,
}

impl Default for ShadowOptions {
    fn default() -> Self {
        Self {
            method: Method::Auto,
            shadow_map_size: 256,
            samples: 4,
            seed: 0,
        }
    }
}

impl ShadowOptions {
    pub fn check(&self) -> Result<()> {
        if !(16..=MAX_SHADOW_MAP_SIZE).contains(&self.shadow_map_size) {
            return Err(Error::InvalidOption {
                field: "shadow_map_size".into(),
                reason: format!("must lie in 16..={MAX_SHADOW_MAP_SIZE}"),
            });
        }
        if !(1..=MAX_LIGHT_SAMPLES).contains(&self.samples) {
            return Err(Error::InvalidOption {
                field: "samples".into(),
                reason: format!("must lie in 1..={MAX_LIGHT_SAMPLES}"),
            });
        }
        Ok(())
    }
}
