use glam::{Affine3A, Quat, Vec3, Vec3A};
use serde::{Deserialize, Serialize};

use super::MAX_COORDINATE;
use crate::{Error, Result};

/// A rigid motion: rotate, then translate. Rigid motions keep distances, so a
/// ray moved into an object's frame keeps its parameter `t`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidTransform {
    #[serde(default = "identity_rotation")]
    pub rotation: Quat,
    #[serde(default)]
    pub translation: Vec3,
}

fn identity_rotation() -> Quat {
    Quat::IDENTITY
}

impl Default for RigidTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl RigidTransform {
    pub const IDENTITY: Self = Self {
        rotation: Quat::IDENTITY,
        translation: Vec3::ZERO,
    };

    /// A rigid transform; the rotation is normalised. Errors on non-finite
    /// input, a zero quaternion, or a translation beyond [`MAX_COORDINATE`]
    /// on some axis, the bound mesh vertices keep (objects moved to ±3e38 m
    /// gave the world an infinite box, and the tail an infinite volume).
    pub fn new(rotation: Quat, translation: Vec3) -> Result<Self> {
        if !rotation.is_finite() || !translation.is_finite() {
            return Err(Error::InvalidTransform("non-finite component".into()));
        }
        if translation.abs().max_element() > MAX_COORDINATE {
            return Err(Error::InvalidTransform(format!(
                "translation beyond {MAX_COORDINATE:e} m"
            )));
        }
        // In f64: the f32 length of a quaternion with components past
        // about 1.8e19 overflows, and dividing by it gave zero.
        let q = glam::DQuat::from_xyzw(
            rotation.x.into(),
            rotation.y.into(),
            rotation.z.into(),
            rotation.w.into(),
        );
        let len = q.length();
        if len < 1e-6 {
            return Err(Error::InvalidTransform(
                "rotation quaternion has zero length".into(),
            ));
        }
        let unit = q / len;
        Ok(Self {
            rotation: Quat::from_xyzw(unit.x as f32, unit.y as f32, unit.z as f32, unit.w as f32),
            translation,
        })
    }

    /// Checks and normalises a transform that came from outside (e.g. JSON).
    pub fn validated(self) -> Result<Self> {
        Self::new(self.rotation, self.translation)
    }

    pub fn from_translation(t: Vec3) -> Self {
        Self {
            rotation: Quat::IDENTITY,
            translation: t,
        }
    }

    pub fn is_identity(&self) -> bool {
        self.rotation == Quat::IDENTITY && self.translation == Vec3::ZERO
    }

    pub fn to_affine(&self) -> Affine3A {
        Affine3A::from_rotation_translation(self.rotation, self.translation)
    }

    pub fn inverse(&self) -> Self {
        let r = self.rotation.conjugate();
        Self {
            rotation: r,
            translation: -(r * self.translation),
        }
    }

    /// The motion from the frame `b_to_world` places into the one
    /// `a_to_world` places, composed in f64 so that only its final rounding
    /// to f32 remains, and a bound on the error that rounding makes on a
    /// point within `reach` of `b`'s origin. Composed in f32 instead, the
    /// two world translations' rounding (a millimetre at 1e4 m) would move
    /// `b`'s boxes off the triangles they bound.
    pub fn relative(a_to_world: &Self, b_to_world: &Self, reach: f32) -> (Self, f32) {
        let (qa, qb) = (
            a_to_world.rotation.as_dquat(),
            b_to_world.rotation.as_dquat(),
        );
        let rotation = (qa.conjugate() * qb).normalize();
        let shift = b_to_world.translation.as_dvec3() - a_to_world.translation.as_dvec3();
        let translation = (qa.conjugate() * shift).as_vec3();
        let motion = Self {
            rotation: rotation.as_quat(),
            translation,
        };
        // A unit quaternion rounded to f32 turns a point by about two ulps
        // of its distance; the translation rounds by half an ulp.
        let slack = 8.0 * f32::EPSILON * (reach + translation.abs().max_element());
        (motion, slack)
    }

    /// This motion followed by `after`.
    pub fn then(&self, after: &RigidTransform) -> Self {
        Self {
            rotation: (after.rotation * self.rotation).normalize(),
            translation: after.rotation * self.translation + after.translation,
        }
    }

    #[inline]
    pub fn transform_point(&self, p: Vec3A) -> Vec3A {
        self.rotation * p + Vec3A::from(self.translation)
    }

    #[inline]
    pub fn transform_vector(&self, v: Vec3A) -> Vec3A {
        self.rotation * v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_undoes_the_motion() {
        let t = RigidTransform::new(
            Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
            Vec3::new(4.0, -5.0, 6.0),
        )
        .unwrap();
        let p = Vec3A::new(0.3, -2.0, 9.0);
        let back = t.inverse().transform_point(t.transform_point(p));
        assert!((back - p).length() < 1e-5);
    }

    #[test]
    fn then_applies_both_motions_in_order() {
        let a = RigidTransform::new(Quat::from_rotation_z(0.5), Vec3::new(1.0, 2.0, 3.0)).unwrap();
        let b =
            RigidTransform::new(Quat::from_rotation_x(-1.2), Vec3::new(-4.0, 0.0, 2.0)).unwrap();
        let p = Vec3A::new(0.7, -1.0, 5.0);
        let both = a.then(&b).transform_point(p);
        assert!((both - b.transform_point(a.transform_point(p))).length() < 1e-5);
        assert!((a.then(&a.inverse()).transform_point(p) - p).length() < 1e-5);
    }

    #[test]
    fn rejects_bad_rotations() {
        assert!(RigidTransform::new(Quat::from_xyzw(0.0, 0.0, 0.0, 0.0), Vec3::ZERO).is_err());
        assert!(RigidTransform::new(Quat::IDENTITY, Vec3::new(f32::NAN, 0.0, 0.0)).is_err());
    }

    #[test]
    fn rejects_translations_beyond_the_coordinate_bound() {
        let at = |x: f32| RigidTransform::new(Quat::IDENTITY, Vec3::new(0.0, x, 0.0));
        assert!(at(MAX_COORDINATE).is_ok());
        assert!(at(-MAX_COORDINATE).is_ok());
        for x in [2.0 * MAX_COORDINATE, -3e38, f32::MAX] {
            let e = at(x).unwrap_err().to_string();
            assert!(e.contains("translation"), "{e}");
        }
    }

    #[test]
    fn huge_and_tiny_quaternions_normalise() {
        // f32's length of these overflows (or underflows) and the old
        // division gave a zero quaternion that reloads as an error.
        for q in [
            Quat::from_xyzw(1e20, 0.0, 0.0, 0.0),
            Quat::from_xyzw(f32::MAX, f32::MAX, 0.0, 0.0),
        ] {
            let t = RigidTransform::new(q, Vec3::ZERO).unwrap();
            assert!(
                (t.rotation.length() - 1.0).abs() < 1e-6,
                "{q:?} -> {:?}",
                t.rotation
            );
            assert!(t.validated().is_ok());
        }
        let tiny = Quat::from_xyzw(0.0, 3e-6, 0.0, 0.0);
        let t = RigidTransform::new(tiny, Vec3::ZERO).unwrap();
        assert_eq!(t.rotation, Quat::from_xyzw(0.0, 1.0, 0.0, 0.0));
    }
}
