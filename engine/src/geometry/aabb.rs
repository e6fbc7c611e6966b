use glam::{Mat3A, Vec3, Vec3A};

use super::RigidTransform;

/// An axis-aligned bounding box. The empty box has `min = +inf`, `max = -inf`
/// so that growing it by any point gives that point's box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3A,
    pub max: Vec3A,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3A, max: Vec3A) -> Self {
        Self { min, max }
    }

    /// The box of a triangle.
    #[inline]
    pub fn of_triangle(a: Vec3A, b: Vec3A, c: Vec3A) -> Self {
        Self {
            min: a.min(b).min(c),
            max: a.max(b).max(c),
        }
    }

    /// The box of a set of points.
    pub fn of_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points
            .into_iter()
            .fold(Self::EMPTY, |b, p| b.grow(p.into()))
    }

    #[inline]
    pub fn grow(self, p: Vec3A) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    #[inline]
    pub fn extent(&self) -> Vec3A {
        (self.max - self.min).max(Vec3A::ZERO)
    }

    #[inline]
    pub fn center(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    /// Surface area; zero for an empty box.
    #[inline]
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Half the surface area: what the SAH compares, one multiply cheaper.
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    pub fn contains_point(&self, p: Vec3A) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    pub fn contains(&self, o: &Aabb) -> bool {
        o.min.cmpge(self.min).all() && o.max.cmple(self.max).all()
    }

    /// Whether the boxes overlap or touch.
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && self.max.cmpge(o.min).all()
    }

    /// The box of this box moved by `t`: it surely contains the moved
    /// contents (see [`BoxMotion`]). An empty box stays empty.
    pub fn transformed(&self, t: &RigidTransform) -> Aabb {
        BoxMotion::new(t).apply(self)
    }
}

/// A rigid motion as boxes see it: the rotation as a matrix and its
/// absolute values, for moving many boxes by one motion. A moved box's
/// centre is the moved centre and its half extent the absolute matrix
/// times the half extent (Arvo 1990): three matrix products a box, where
/// rotating its eight corners by the quaternion took eight (that had been
/// a seventh of a rigid pair walk).
#[derive(Clone, Copy, Debug)]
pub struct BoxMotion {
    rotation: Mat3A,
    abs: Mat3A,
    translation: Vec3A,
}

/// The moved box's widening per unit of its magnitude, in `f32` epsilons.
/// Its rounding (the matrix's entries, the centre and half extent, the
/// products and sums) stays within about 7; the rest is margin.
const MOVED_BOX_PAD: f32 = 16.0;

impl BoxMotion {
    pub fn new(t: &RigidTransform) -> Self {
        // The matrix in f64, then rounded: each entry within half an ulp
        // of the quaternion's own rotation.
        let rotation = Mat3A::from(glam::DMat3::from_quat(t.rotation.as_dquat()).as_mat3());
        Self {
            rotation,
            abs: Mat3A::from_cols(
                rotation.x_axis.abs(),
                rotation.y_axis.abs(),
                rotation.z_axis.abs(),
            ),
            translation: t.translation.into(),
        }
    }

    /// The box of `b`'s contents moved, widened by [`MOVED_BOX_PAD`]
    /// epsilons of its magnitude so that it contains them whatever the
    /// rounding.
    #[inline]
    pub fn apply(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return Aabb::EMPTY;
        }
        let (centre, half) = ((b.min + b.max) * 0.5, (b.max - b.min) * 0.5);
        let moved = self.rotation * centre + self.translation;
        let reach = self.abs * half;
        let magnitude = self.abs * centre.abs() + reach + self.translation.abs();
        let half = reach + magnitude * (MOVED_BOX_PAD * f32::EPSILON);
        Aabb::new(moved - half, moved + half)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_box_grows_to_a_point() {
        let b = Aabb::EMPTY.grow(Vec3A::new(1.0, 2.0, 3.0));
        assert_eq!(b.min, b.max);
        assert_eq!(b.surface_area(), 0.0);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
    }

    /// Boxes moved by random motions hold every moved point of the box,
    /// moved in f64 by the motion's own quaternion (the box's corners and
    /// points between), and are no bigger than the f64 box of the moved
    /// corners by more than the widening: at scales from 1e-3 to 1e4 and
    /// shifts up to 1e4.
    #[test]
    fn moved_boxes_hold_their_moved_contents_and_stay_tight() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let mut next = || rng.random_range(-1.0f32..1.0);
        let mut outside = 0;
        for case in 0..4000 {
            let scale = [1e-3, 1.0, 1e2, 1e4][case % 4];
            let axis = Vec3::new(next(), next(), next() + 1e-3).normalize();
            let t = RigidTransform::new(
                glam::Quat::from_axis_angle(axis, 3.2 * next()),
                Vec3::new(next(), next(), next()) * [0.0, 1.0, 1e4][case % 3],
            )
            .unwrap();
            let lo = Vec3A::new(next(), next(), next()) * scale;
            let b = Aabb::new(lo, lo + Vec3A::new(next(), next(), next()).abs() * scale);
            let moved = BoxMotion::new(&t).apply(&b);
            let rot = t.rotation.as_dquat();
            let shift = t.translation.as_dvec3();
            let (mut dlo, mut dhi) = (glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY);
            for i in 0..27 {
                let w = glam::DVec3::new((i % 3) as f64, (i / 3 % 3) as f64, (i / 9) as f64) * 0.5;
                let p = b.min.as_dvec3() + (b.max - b.min).as_dvec3() * w;
                let q = rot * p + shift;
                (dlo, dhi) = (dlo.min(q), dhi.max(q));
                let inside =
                    q.cmpge(moved.min.as_dvec3()).all() && q.cmple(moved.max.as_dvec3()).all();
                outside += usize::from(!inside);
            }
            let size = (dhi.abs().max(dlo.abs())).max_element() + shift.abs().max_element();
            let slack = (moved.min.as_dvec3() - dlo)
                .abs()
                .max((moved.max.as_dvec3() - dhi).abs());
            assert!(
                slack.max_element() <= 64.0 * f64::from(f32::EPSILON) * size,
                "{b:?} moved to {moved:?}, f64 box {dlo} {dhi}"
            );
        }
        assert_eq!(outside, 0, "moved points outside their moved box");
        assert!(BoxMotion::new(&RigidTransform::IDENTITY)
            .apply(&Aabb::EMPTY)
            .is_empty());
    }

    #[test]
    fn unit_cube_area() {
        let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
        assert_eq!(b.surface_area(), 6.0);
        assert_eq!(b.half_area(), 3.0);
        assert!(b.contains_point(Vec3A::splat(0.5)));
        assert!(b.contains_point(Vec3A::ONE));
        assert!(!b.contains_point(Vec3A::splat(1.1)));
    }
}
