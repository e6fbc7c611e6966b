//! Hard shadows of a point light: the shadow ray every method agrees on,
//! the proof of a pixel from the light map, and the three methods.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::camera::{Camera, GBuffer, Receiver};
use super::light_map::{locate, LightMap, Texel, RAY_ERROR};
use super::occluders::{Occluders, Topology};
use super::{Method, PointLight, ShadowOptions};
use crate::bvh::SceneBvh;
use crate::geometry::Ray;
use crate::Result;

/// The ends of a shadow ray left out, as a fraction of its length: the
/// receiver's own surface at one end, the light's fixture at the other.
pub const SHADOW_T_MIN: f32 = 1e-4;

/// The shadow ray from `point` to `light`: the segment between them without
/// its ends' [`SHADOW_T_MIN`]. The light is visible from `point` when it
/// hits nothing.
pub fn shadow_ray(point: Vec3, light: Vec3) -> Ray {
    Ray::segment(point, light).with_range(SHADOW_T_MIN, 1.0 - SHADOW_T_MIN)
}

/// A shadow image: per pixel the fraction of the light its surface sees
/// (for hard shadows 0 or 1; pixels that see no surface are 1).
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowImage {
    pub width: u32,
    pub height: u32,
    pub visibility: Vec<f32>,
    pub stats: ShadowStats,
}

/// What a shadow query did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadowStats {
    /// Pixels that see a surface.
    pub receivers: u64,
    /// Pixels the light map could not prove, and shadow rays traced.
    pub pip_pixels: u64,
    pub rays: u64,
    pub gbuffer_ms: f64,
    pub light_map_ms: f64,
    pub classify_ms: f64,
    pub trace_ms: f64,
    pub total_ms: f64,
}

impl ShadowStats {
    /// Share of the receivers that were traced.
    pub fn pip_fraction(&self) -> f64 {
        if self.receivers == 0 {
            0.0
        } else {
            self.pip_pixels as f64 / self.receivers as f64
        }
    }
}

/// What the light map proves about one receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Proof {
    Lit,
    Shadowed,
    /// Potentially incorrect: trace it.
    Unknown,
}

/// Hard shadows of `light` seen through `camera` (a [`ShadowScene`] made
/// for this call: keep one to answer many).
pub fn hard_shadows(
    world: &SceneBvh,
    camera: &Camera,
    light: &PointLight,
    options: &ShadowOptions,
) -> Result<ShadowImage> {
    ShadowScene::new(world).hard_shadows(world, camera, light, options)
}

/// What shadow queries need of a world beyond its trees: its triangles in
/// world space and how they join (welded edges, connected parts). It
/// depends only on the geometry, so one serves every camera and light
/// until an object moves or deforms.
pub struct ShadowScene {
    occluders: Occluders,
    topology: Topology,
    /// Time it took to make, in milliseconds.
    pub build_ms: f64,
}

impl ShadowScene {
    pub fn new(world: &SceneBvh) -> Self {
        let start = Instant::now();
        let occluders = Occluders::of(world);
        let topology = Topology::of(world, &occluders);
        Self {
            occluders,
            topology,
            build_ms: ms(start),
        }
    }

    /// The surface each pixel of `camera` sees (the G-buffer every method
    /// shares).
    pub fn gbuffer(&self, camera: &Camera) -> Result<GBuffer> {
        camera.check()?;
        Ok(GBuffer::render(camera, &self.occluders))
    }

    /// Hard shadows of `light` seen through `camera`; `world` must be the
    /// one this was made from.
    ///
    /// Every method shares the G-buffer; they differ only in how each
    /// receiver's visibility is decided, so their images are comparable
    /// pixel for pixel, and [`Method::Selective`] equals [`Method::Full`]
    /// on every one.
    pub fn hard_shadows(
        &self,
        world: &SceneBvh,
        camera: &Camera,
        light: &PointLight,
        options: &ShadowOptions,
    ) -> Result<ShadowImage> {
        hard_shadows_of(self, world, camera, light, options)
    }
}

fn hard_shadows_of(
    scene: &ShadowScene,
    world: &SceneBvh,
    camera: &Camera,
    light: &PointLight,
    options: &ShadowOptions,
) -> Result<ShadowImage> {
    camera.check()?;
    light.check()?;
    options.check()?;
    let start = Instant::now();
    let mut stats = ShadowStats::default();
    let occluders = &scene.occluders;
    let gbuffer = GBuffer::render(camera, occluders);
    stats.gbuffer_ms = ms(start);
    stats.receivers = gbuffer.receivers.iter().flatten().count() as u64;
    let l = light.position;
    let traced = |r: &Receiver| {
        if world.any_hit(&shadow_ray(r.point, l)) {
            0.0
        } else {
            1.0
        }
    };
    let visibility: Vec<f32> = match options.method {
        Method::Full => {
            let t = Instant::now();
            let v = gbuffer
                .receivers
                .par_iter()
                .map(|r| r.as_ref().map_or(1.0, traced))
                .collect();
            stats.rays = stats.receivers;
            stats.pip_pixels = stats.receivers;
            stats.trace_ms = ms(t);
            v
        }
        Method::Selective | Method::ShadowMap => {
            let t = Instant::now();
            let plain = options.method == Method::ShadowMap;
            let size = options.shadow_map_size;
            let needed = gbuffer
                .receivers
                .par_iter()
                .flatten()
                .fold(
                    || [false; 6],
                    |mut acc, r| {
                        acc[Spot::of(r, l, size).face] = true;
                        acc
                    },
                )
                .reduce(|| [false; 6], |a, b| std::array::from_fn(|i| a[i] | b[i]));
            let topology = (!plain).then_some(&scene.topology);
            let map = LightMap::build(occluders, topology, l.as_dvec3(), size, needed);
            stats.light_map_ms = ms(t);
            let t = Instant::now();
            let proofs: Vec<Option<Proof>> = gbuffer
                .receivers
                .par_iter()
                .map(|r| {
                    let r = r.as_ref()?;
                    let spot = Spot::of(r, l, size);
                    Some(match topology {
                        None => plain_test(&map, &spot),
                        Some(t) => prove(
                            &map,
                            &spot,
                            r,
                            t.objects[r.object as usize].part[r.slot as usize],
                        ),
                    })
                })
                .collect();
            stats.classify_ms = ms(t);
            let t = Instant::now();
            let v: Vec<f32> = proofs
                .par_iter()
                .zip(&gbuffer.receivers)
                .map(|(p, r)| match (p, r) {
                    (Some(Proof::Lit), _) | (None, _) => 1.0,
                    (Some(Proof::Shadowed), _) => 0.0,
                    (Some(Proof::Unknown), Some(r)) => traced(r),
                    (Some(Proof::Unknown), None) => 1.0,
                })
                .collect();
            stats.pip_pixels = proofs
                .iter()
                .filter(|p| **p == Some(Proof::Unknown))
                .count() as u64;
            stats.rays = stats.pip_pixels;
            stats.trace_ms = ms(t);
            v
        }
    };
    stats.total_ms = ms(start);
    Ok(ShadowImage {
        width: camera.width,
        height: camera.height,
        visibility,
        stats,
    })
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// Where a receiver falls on the light map: face, texel and depth.
struct Spot {
    face: usize,
    x: u32,
    y: u32,
    z: f64,
}

impl Spot {
    fn of(r: &Receiver, light: Vec3, size: u32) -> Self {
        let (face, x, y, z) = locate(r.point.as_dvec3() - light.as_dvec3(), size);
        let last = size - 1;
        Self {
            face,
            x: (x.floor().max(0.0) as u32).min(last),
            y: (y.floor().max(0.0) as u32).min(last),
            z,
        }
    }

    fn texel<'a>(&self, map: &'a LightMap) -> Option<&'a Texel> {
        Some(map.faces[self.face].as_ref()?.at(self.x, self.y))
    }
}

/// What the light map proves about `r`, on `part`, at `spot` (see
/// [`super::light_map`]). The map holds inverse depths: `f * d > 1` says
/// the point of `f` is nearer than depth `d`.
fn prove(map: &LightMap, spot: &Spot, r: &Receiver, part: u32) -> Proof {
    if map.unknown {
        return Proof::Unknown;
    }
    let Some(f) = spot.texel(map) else {
        return Proof::Unknown;
    };
    let z = spot.z;
    let x = r.point.as_dvec3();
    let scale = map.scale.max(x.abs().max_element());
    let slack = 1e-5 * z + RAY_ERROR * scale;
    let t_min = SHADOW_T_MIN as f64;
    // Depth falls linearly from z at the receiver to 0 at the light: the
    // traced range [t_min, 1 - t_min] spans depths z t_min .. z (1 - t_min).
    if f.cover_far as f64 * (z * (1.0 - t_min) - slack) > 1.0
        && (f.cover_near as f64) * (z * t_min + slack) < 1.0
    {
        return Proof::Shadowed;
    }
    // The receiver's own sheet, met by the traced ray within its rounding
    // of the receiver, must fall before t_min: with cos the angle between
    // the normal and the light, RAY_ERROR scale / (distance cos) < t_min / 2,
    // and cos > 1e-3.
    let to_light = map.light - x;
    let towards = r.normal.as_dvec3().dot(to_light);
    let beyond = |near: f32| (near as f64) * (z + slack) < 1.0;
    if f.first_part == part
        && f.first_sheet
        && beyond(f.first_back)
        && beyond(f.second)
        && towards > 0.0
        && towards * towards > 1e-6 * to_light.length_squared()
        && RAY_ERROR * scale < 0.5 * t_min * towards
    {
        return Proof::Lit;
    }
    Proof::Unknown
}

/// The plain shadow map's answer, with a relative depth bias.
fn plain_test(map: &LightMap, spot: &Spot) -> Proof {
    match spot.texel(map) {
        Some(f) if spot.z * f.centre as f64 > 1.002 => Proof::Shadowed,
        _ => Proof::Lit,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shadow_ray_spans_the_segment_without_its_ends() {
        let r = shadow_ray(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0));
        assert_eq!(r.dir, glam::Vec3A::new(0.0, 0.0, 2.0));
        assert_eq!((r.t_min, r.t_max), (SHADOW_T_MIN, 1.0 - SHADOW_T_MIN));
    }
}
