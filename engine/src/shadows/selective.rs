//! What every method shares: the shadow ray, where a point falls on the
//! light map, the proofs, and resolving a set of points by a method.

use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::eye::Eye;
use super::light_map::{locate, LightMap, Texel, RAY_ERROR};
use super::occluders::{Occluders, Topology};
use super::{Method, ShadowOptions};
use crate::bvh::SceneBvh;
use crate::geometry::Ray;

/// The ends of a shadow ray left out, as a fraction of its length: the
/// receiver's own surface at one end, the light's fixture at the other.
pub const SHADOW_T_MIN: f32 = 1e-4;

/// The shadow ray from `point` to `light`: the segment between them without
/// its ends' [`SHADOW_T_MIN`]. The light is visible from `point` when it
/// hits nothing.
pub fn shadow_ray(point: Vec3, light: Vec3) -> Ray {
    Ray::segment(point, light).with_range(SHADOW_T_MIN, 1.0 - SHADOW_T_MIN)
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

/// What the light map proves about one point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Proof {
    Lit,
    Shadowed,
    /// Potentially incorrect: trace it.
    Unknown,
}

/// A point whose view of the light is asked: on a surface (its unit
/// normal and part), or anywhere (a listener, a seat).
#[derive(Clone, Copy, Debug)]
pub(super) struct Target {
    pub point: Vec3,
    pub surface: Option<(Vec3, u32)>,
    /// The normal of the side a surface is seen from, which alone
    /// receives light (zero in the air, where every side does).
    pub front: Vec3,
}

impl Target {
    /// A point in the air.
    pub fn air(point: Vec3) -> Self {
        Self {
            point,
            surface: None,
            front: Vec3::ZERO,
        }
    }

    /// Whether light from `x` can reach the target: in the air always, on
    /// a surface when `x` lies strictly on the side it is seen from.
    pub fn faces(&self, x: Vec3) -> bool {
        self.receives(x.as_dvec3() - self.point.as_dvec3())
    }

    /// Whether light arriving from `to_light` (a vector from the target)
    /// can reach it.
    fn receives(&self, to_light: DVec3) -> bool {
        self.front == Vec3::ZERO || self.front.as_dvec3().dot(to_light) > 0.0
    }

    /// Whether the light of `eye` can reach the target: it shines on it,
    /// from the side it is seen from.
    pub fn faces_eye(&self, eye: &Eye) -> bool {
        let x = self.point.as_dvec3();
        eye.shines_on(x) && self.receives(eye.towards_light(x))
    }
}

pub(super) fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// The visibility (1 or 0; 1 where there is no target) of the light of
/// `eye` from targets `0..n` by `options.method`; the light map and its
/// proofs need `topology`, the plain shadow map does not.
#[allow(clippy::too_many_arguments)]
pub(super) fn resolve(
    occluders: &Occluders,
    topology: &Topology,
    world: &SceneBvh,
    eye: Eye,
    n: usize,
    target: impl Fn(usize) -> Option<Target> + Sync,
    options: &ShadowOptions,
    stats: &mut ShadowStats,
) -> Vec<f32> {
    let traced = |t: &Target| {
        if !t.faces_eye(&eye) || world.any_hit(&eye.shadow_ray(t.point)) {
            0.0
        } else {
            1.0
        }
    };
    stats.receivers = (0..n)
        .into_par_iter()
        .filter(|&i| target(i).is_some())
        .count() as u64;
    let method = match options.method {
        Method::Auto
            if light_map_pays(stats.receivers, occluders, &eye, options.shadow_map_size) =>
        {
            Method::Selective
        }
        Method::Auto => Method::Full,
        m => m,
    };
    if method == Method::Full {
        let t = Instant::now();
        let v = (0..n)
            .into_par_iter()
            .map(|i| target(i).as_ref().map_or(1.0, traced))
            .collect();
        stats.rays = stats.receivers;
        stats.pip_pixels = stats.receivers;
        stats.trace_ms = ms(t);
        return v;
    }
    let t = Instant::now();
    let plain = method == Method::ShadowMap;
    let size = options.shadow_map_size;
    // The cube faces a point light's targets fall on (a directional light
    // has one face).
    let needed = match eye {
        Eye::Point { light, .. } => (0..n)
            .into_par_iter()
            .filter_map(&target)
            .filter(|t| eye.shines_on(t.point.as_dvec3()))
            .fold(
                || [false; 6],
                |mut acc, t| {
                    acc[locate(t.point.as_dvec3() - light.as_dvec3(), size).0] = true;
                    acc
                },
            )
            .reduce(|| [false; 6], |a, b| std::array::from_fn(|i| a[i] | b[i])),
        Eye::Parallel { .. } => [true, false, false, false, false, false],
    };
    let topology = (!plain).then_some(topology);
    let map = LightMap::build(occluders, topology, &eye, size, needed);
    stats.light_map_ms = ms(t);
    let t = Instant::now();
    let proofs: Vec<Option<Proof>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let target = target(i)?;
            if !target.faces_eye(&eye) {
                return Some(Proof::Shadowed);
            }
            let spot = Spot::of(target.point, &map);
            Some(if plain {
                plain_test(&map, &spot)
            } else {
                prove(&map, &spot, &target)
            })
        })
        .collect();
    stats.classify_ms = ms(t);
    let t = Instant::now();
    let v = proofs
        .par_iter()
        .enumerate()
        .map(|(i, p)| match p {
            Some(Proof::Lit) | None => 1.0,
            Some(Proof::Shadowed) => 0.0,
            Some(Proof::Unknown) => target(i).as_ref().map_or(1.0, traced),
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

/// Whether a light map (six faces, or a directional light's one) is
/// estimated to cost less than the shadow rays it saves `receivers`. From
/// `frusta-bench shadows` on two cores: a map costs about 0.6 us per
/// triangle and 40 ns per texel, and saves about 60 ns per receiver over
/// its ray (a ray of 75 ns, a fifth of them still traced, 20 ns to
/// classify each).
fn light_map_pays(receivers: u64, occluders: &Occluders, eye: &Eye, size: u32) -> bool {
    let triangles: usize = occluders.objects.iter().map(|o| o.tris.len()).sum();
    let faces = match eye {
        Eye::Point { .. } => 6,
        Eye::Parallel { .. } => 1,
    };
    let texels = faces * size as u64 * size as u64;
    receivers > 15 * triangles as u64 + texels
}

/// Where a point falls on the light map: face, texel and depth (`None`
/// off a directional light's face).
struct Spot(Option<(usize, u32, u32, f64)>);

impl Spot {
    fn of(point: Vec3, map: &LightMap) -> Self {
        let last = map.size - 1;
        Self(map.locate(point.as_dvec3()).map(|(face, x, y, z)| {
            // Truncation is the floor from 0 up, and the cast takes NaN
            // to 0: no call to `floor`, which the x86-64 baseline lacks.
            let texel = |c: f64| (c.max(0.0) as u32).min(last);
            (face, texel(x), texel(y), z)
        }))
    }

    /// The texel and the point's depth.
    fn texel<'a>(&self, map: &'a LightMap) -> Option<(&'a Texel, f64)> {
        let (face, x, y, z) = self.0?;
        Some((map.faces[face].as_ref()?.at(x, y), z))
    }
}

/// What the light map proves about `target` at `spot` (see
/// [`super::light_map`]). The map holds inverse depths: `f * d > 1` says
/// the point of `f` is nearer than depth `d`.
fn prove(map: &LightMap, spot: &Spot, target: &Target) -> Proof {
    if map.unknown {
        return Proof::Unknown;
    }
    let Some((f, z)) = spot.texel(map) else {
        return Proof::Unknown;
    };
    let x = target.point.as_dvec3();
    let scale = map.scale.max(x.abs().max_element());
    let slack = 1e-5 * z.abs() + RAY_ERROR * scale;
    let (lo, hi) = map.eye.traced_depths(z);
    if f.cover_far as f64 * (hi - slack) > 1.0 && (f.cover_near as f64) * (lo + slack) < 1.0 {
        return Proof::Shadowed;
    }
    let beyond = |near: f32| (near as f64) * (z + slack) < 1.0;
    let lit = match target.surface {
        // Nothing at all in front of a point in the air.
        None => beyond(f.first),
        Some((normal, part)) => lit_on_surface(map, f, x, normal.as_dvec3(), part, beyond),
    };
    if lit {
        Proof::Lit
    } else {
        Proof::Unknown
    }
}

/// The sheet proof for a receiver on a surface: its part alone in front,
/// as one light-facing sheet, the receiver's triangle facing the light by
/// more than 1e-3 in cosine. Its own sheet, met by the traced ray within
/// its rounding of the receiver, falls before `SHADOW_T_MIN`: a
/// light-facing triangle with the light nearer its plane than that
/// rounding allows marks its texels grazing (`light_map::tiles`), and a
/// sheet with such a mark proves nothing.
fn lit_on_surface(
    map: &LightMap,
    f: &Texel,
    x: DVec3,
    normal: DVec3,
    part: u32,
    beyond: impl Fn(f32) -> bool,
) -> bool {
    let to_light = map.eye.towards_light(x);
    let towards = normal.dot(to_light);
    f.first_part == part
        && f.first_sheet
        && beyond(f.first_back)
        && beyond(f.second)
        && towards > 0.0
        && towards * towards > 1e-6 * to_light.length_squared()
}

/// The plain shadow map's answer, with a relative depth bias.
fn plain_test(map: &LightMap, spot: &Spot) -> Proof {
    match spot.texel(map) {
        Some((f, z)) if z * f.centre as f64 > 1.002 => Proof::Shadowed,
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
