//! The ray's node test: a robust slab test, one box or four at a time.
//!
//! The slab test follows Ize, "Robust BVH Ray Traversal" (JCGT 2013): the
//! exit distance is enlarged by `1 + 2 * gamma(3)` so that rounding never
//! culls a box the ray touches. Each axis picks its near and far plane from
//! the direction's sign, so a zero direction component (an infinite inverse)
//! yields NaN only when the origin lies exactly on a plane; NaN lanes are
//! then ignored, which keeps exactly the rays that run inside a face.

use glam::{BVec4A, Vec4};

use super::NodeTest;
use crate::bvh::wide::Boxes4;
use crate::geometry::{Aabb, Ray};

/// `1 + 2 * gamma(3)` with `gamma(n) = n * u / (1 - n * u)`, `u = 2^-24`.
pub(super) const EXIT_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Per-ray constants of the slab test; the key is the entry distance and
/// the bound the ray's current `t_max`.
///
/// Origin and inverse direction are kept splatted per axis, so the
/// four-box test is six subtractions and multiplies on whole registers.
#[derive(Clone, Copy, Debug)]
pub struct RayTest {
    pub(super) origin: [Vec4; 3],
    pub(super) inv_dir: [Vec4; 3],
    /// Per axis, whether the direction is negative (then the near plane is
    /// the box maximum); a negative zero counts as negative.
    negative: [bool; 3],
    /// Per axis, the near and far planes' indices in
    /// [`Boxes4::planes`], chosen once per ray (as Embree does). Where
    /// the ray is built in the same function, LLVM sees that each index is
    /// one of two and may load both planes and pick one by a branch per
    /// node instead; that branch predicts for all of a ray's nodes, and
    /// hiding the index from it (`black_box`) made coherent rays 10-20%
    /// slower.
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
    pub(super) t_min: f32,
}

impl RayTest {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv = ray.dir.recip();
        // Bit operations, not branches: a random direction's signs do not
        // predict (about a mispredict per incoherent ray).
        let neg = |d: f32| d.is_sign_negative() & !d.is_nan();
        let negative = [neg(ray.dir.x), neg(ray.dir.y), neg(ray.dir.z)];
        Self {
            origin: [0, 1, 2].map(|a| Vec4::splat(ray.origin[a])),
            inv_dir: [0, 1, 2].map(|a| Vec4::splat(inv[a])),
            negative,
            near: [0, 1, 2].map(|a| a + 3 * usize::from(negative[a])),
            far: [0, 1, 2].map(|a| a + 3 * usize::from(!negative[a])),
            t_min: ray.t_min,
        }
    }
}

/// Lane-wise `if x > acc { x } else { acc }`: NaN lanes of `x` keep `acc`.
/// On x86-64 this is exactly `maxps(x, acc)`, one instruction.
#[inline(always)]
fn max_keep(x: Vec4, acc: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::_mm_max_ps;
        // SAFETY: SSE is part of the x86-64 baseline.
        Vec4::from(unsafe { _mm_max_ps(x.into(), acc.into()) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    Vec4::select(x.cmpgt(acc), x, acc)
}

/// Lane-wise `if x < acc { x } else { acc }`: NaN lanes of `x` keep `acc`.
#[inline(always)]
fn min_keep(x: Vec4, acc: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::_mm_min_ps;
        // SAFETY: SSE is part of the x86-64 baseline.
        Vec4::from(unsafe { _mm_min_ps(x.into(), acc.into()) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    Vec4::select(x.cmplt(acc), x, acc)
}

impl NodeTest for RayTest {
    #[inline(always)]
    fn test(&self, b: &Aabb, bound: f32) -> Option<f32> {
        let mut enter = self.t_min;
        let mut exit = bound;
        for axis in 0..3 {
            let (near, far) = if self.negative[axis] {
                (b.max[axis], b.min[axis])
            } else {
                (b.min[axis], b.max[axis])
            };
            let (o, inv) = (self.origin[axis].x, self.inv_dir[axis].x);
            let tn = (near - o) * inv;
            let tf = (far - o) * inv * EXIT_SCALE;
            // A comparison with NaN is false, so NaN lanes keep the bound.
            if tn > enter {
                enter = tn;
            }
            if tf < exit {
                exit = tf;
            }
        }
        (enter <= exit).then_some(enter)
    }

    #[inline(always)]
    fn test4(&self, n: &Boxes4, bound: f32) -> (Vec4, u32) {
        let mut enter = Vec4::splat(self.t_min);
        let mut exit = Vec4::splat(bound);
        let planes = n.planes();
        for axis in 0..3 {
            let (near, far) = (planes[self.near[axis]], planes[self.far[axis]]);
            let tn = (near - self.origin[axis]) * self.inv_dir[axis];
            let tf = (far - self.origin[axis]) * self.inv_dir[axis] * EXIT_SCALE;
            enter = max_keep(tn, enter);
            exit = min_keep(tf, exit);
        }
        let hits: BVec4A = enter.cmple(exit);
        (enter, hits.bitmask())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec3A};

    fn unit_box() -> Aabb {
        Aabb::new(Vec3A::ZERO, Vec3A::ONE)
    }

    /// The one-box and four-box forms agree on every case below.
    fn entry(ray: Ray, t_max: f32) -> Option<f32> {
        let test = RayTest::new(&ray);
        let one = test.test(&unit_box(), t_max);
        let mut node = crate::bvh::wide::EMPTY_NODE;
        node.set_slot_aabb(2, unit_box());
        let (keys, mask) = test.test4(&node.boxes, t_max);
        assert_eq!(mask & !4, 0, "empty slots are never hit");
        assert_eq!(one, (mask == 4).then_some(keys[2]), "{ray:?}");
        one
    }

    #[test]
    fn axis_parallel_rays_on_a_face_plane_enter_the_box() {
        // Along +x, lying in the planes y = 0 and z = 1.
        for (o, d) in [
            (Vec3::new(-1.0, 0.0, 1.0), Vec3::X),
            (Vec3::new(2.0, 1.0, 0.0), -Vec3::X),
            (Vec3::new(0.5, 0.0, -3.0), Vec3::Z),
            (Vec3::new(1.0, 1.0, 5.0), Vec3::new(0.0, -0.0, -1.0)),
        ] {
            assert!(entry(Ray::new(o, d), f32::INFINITY).is_some(), "{o} {d}");
        }
    }

    #[test]
    fn misses_and_ranges() {
        let ray = Ray::new(Vec3::new(-1.0, 2.0, 0.5), Vec3::X);
        assert_eq!(entry(ray, f32::INFINITY), None);
        let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        assert_eq!(entry(ray, f32::INFINITY), Some(1.0));
        assert_eq!(entry(ray, 0.5), None);
        assert_eq!(entry(ray.with_range(3.0, 9.0), 9.0), None);
        // Starting inside: entry is t_min.
        let ray = Ray::new(Vec3::splat(0.5), Vec3::new(1.0, -2.0, 0.3));
        assert_eq!(entry(ray, f32::INFINITY), Some(0.0));
    }

    #[test]
    fn grazing_diagonal_ray_through_a_corner_enters() {
        let ray = Ray::new(Vec3::new(-1.0, -1.0, 0.5), Vec3::new(1.0, 1.0, 0.0));
        assert!(entry(ray, f32::INFINITY).is_some());
        let ray = Ray::new(Vec3::new(-1.0, 1.0, 0.5), Vec3::new(1.0, 1.0, 0.0));
        assert!(entry(ray, f32::INFINITY).is_none());
    }
}
