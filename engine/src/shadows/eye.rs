//! Where a hard shadow's light is seen from: a point (a point light), or
//! a direction (a directional light, the sun), and the shadow ray every
//! method traces towards it.

use glam::{DVec3, Vec3};

use super::selective::{shadow_ray, SHADOW_T_MIN};
use super::SpotLight;
use crate::bvh::SceneBvh;
use crate::geometry::Ray;

/// The light of a hard shadow as the light map and the shadow rays see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Eye {
    /// A point light's position, and a spot light's cone.
    Point { light: Vec3, cone: Option<Cone> },
    /// A directional light: the unit direction its light travels, and the
    /// length its shadow rays are scaled by (the world's diagonal), of
    /// which [`SHADOW_T_MIN`] is left out at the receiver's end.
    Parallel { direction: Vec3, reach: f32 },
}

/// The cone a spot light shines into: directions from its apex within
/// an angle of its axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Cone {
    /// Unit axis.
    pub axis: DVec3,
    /// Cosine of the half angle.
    pub cos_half: f64,
}

impl Eye {
    /// A point light at `light`, shining every way.
    pub fn point(light: Vec3) -> Self {
        Self::Point { light, cone: None }
    }

    /// A spot light (checked).
    pub fn spot(l: &SpotLight) -> Self {
        let axis = l.direction.as_dvec3();
        Self::Point {
            light: l.position,
            cone: Some(Cone {
                axis: axis / axis.length(),
                cos_half: f64::from(l.half_angle_deg).to_radians().cos(),
            }),
        }
    }

    /// Whether light from the eye arrives at `x` at all: everywhere but
    /// outside a spot light's cone. Decided in f64 from the same values by
    /// every method.
    pub fn shines_on(&self, x: DVec3) -> bool {
        match *self {
            Eye::Point {
                light,
                cone: Some(cone),
            } => {
                let out = x - light.as_dvec3();
                cone.axis.dot(out) >= cone.cos_half * out.length()
            }
            _ => true,
        }
    }

    /// A directional light travelling along `direction` (a unit vector)
    /// over `world`.
    pub fn parallel(direction: Vec3, world: &SceneBvh) -> Self {
        let b = world.bounds();
        let diagonal = (b.max - b.min).length();
        Self::Parallel {
            direction,
            reach: if diagonal.is_finite() && diagonal > 0.0 {
                diagonal
            } else {
                1.0
            },
        }
    }

    /// The shadow ray from `point`: to a point light (without its ends'
    /// [`SHADOW_T_MIN`]), or against a directional light's direction for
    /// ever (without `SHADOW_T_MIN` of its reach). The light is visible
    /// from `point` when it hits nothing.
    pub fn shadow_ray(&self, point: Vec3) -> Ray {
        match *self {
            Eye::Point { light, .. } => shadow_ray(point, light),
            Eye::Parallel { direction, reach } => {
                Ray::new(point, -direction * reach).with_range(SHADOW_T_MIN, f32::INFINITY)
            }
        }
    }

    /// From `x` towards the light: to the point, or the reach against the
    /// direction.
    pub fn towards_light(&self, x: DVec3) -> DVec3 {
        match *self {
            Eye::Point { light, .. } => light.as_dvec3() - x,
            Eye::Parallel { direction, reach } => -direction.as_dvec3() * f64::from(reach),
        }
    }

    /// The depths, along the light's rays, that the shadow ray of a
    /// receiver at depth `z` spans: depth falls linearly from `z` at the
    /// receiver to 0 at a point light, and without end towards a
    /// directional one.
    pub fn traced_depths(&self, z: f64) -> (f64, f64) {
        let t_min = f64::from(SHADOW_T_MIN);
        match *self {
            Eye::Point { .. } => (z * t_min, z * (1.0 - t_min)),
            Eye::Parallel { reach, .. } => (f64::NEG_INFINITY, z - t_min * f64::from(reach)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parallel_shadow_ray_leaves_its_reach_times_t_min_and_never_ends() {
        let eye = Eye::Parallel {
            direction: Vec3::new(0.0, 0.0, -1.0),
            reach: 50.0,
        };
        let r = eye.shadow_ray(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(r.dir, glam::Vec3A::new(0.0, 0.0, 50.0));
        assert_eq!((r.t_min, r.t_max), (SHADOW_T_MIN, f32::INFINITY));
        let (lo, hi) = eye.traced_depths(10.0);
        assert_eq!(lo, f64::NEG_INFINITY);
        assert!((hi - (10.0 - 50.0 * f64::from(SHADOW_T_MIN))).abs() < 1e-12);
    }
}
