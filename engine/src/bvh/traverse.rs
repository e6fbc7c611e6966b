//! Ray traversal: a robust slab test and an ordered, stack-based walk.
//!
//! The slab test follows Ize, "Robust BVH Ray Traversal" (JCGT 2013): the
//! exit distance is enlarged by `1 + 2 * gamma(3)` so that rounding never
//! culls a box the ray touches. Each axis picks its near and far plane from
//! the direction's sign, so a zero direction component (an infinite inverse)
//! yields NaN only when the origin lies exactly on a plane; NaN lanes are
//! then ignored, which keeps exactly the rays that run inside a face.

use std::mem::MaybeUninit;

use glam::{BVec3A, Vec3A};

use super::{Bvh, Node};
use crate::geometry::Ray;

/// `1 + 2 * gamma(3)` with `gamma(n) = n * u / (1 - n * u)`, `u = 2^-24`.
pub(crate) const EXIT_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Enough for the deepest tree the builders make (see `FORCE_MEDIAN_DEPTH`).
pub const STACK_SIZE: usize = 96;

/// Per-ray constants of the slab test.
#[derive(Clone, Copy, Debug)]
pub struct RayBoxTest {
    origin: Vec3A,
    inv_dir: Vec3A,
    negative: BVec3A,
}

impl RayBoxTest {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        Self {
            origin: ray.origin,
            inv_dir: ray.dir.recip(),
            negative: ray.dir.cmplt(Vec3A::ZERO)
                | (ray.dir.cmpeq(Vec3A::ZERO) & Vec3A::ONE.copysign(ray.dir).cmplt(Vec3A::ZERO)),
        }
    }

    /// Entry distance of the ray into `node` within `[t_min, t_max]`, or
    /// `None` when it misses.
    #[inline(always)]
    pub fn entry(&self, node: &Node, t_min: f32, t_max: f32) -> Option<f32> {
        let (lo, hi) = (node.min(), node.max());
        let near = Vec3A::select(self.negative, hi, lo);
        let far = Vec3A::select(self.negative, lo, hi);
        let tn = (near - self.origin) * self.inv_dir;
        let tf = (far - self.origin) * self.inv_dir * EXIT_SCALE;
        // A comparison with NaN is false, so NaN lanes take the bound.
        let t_min = Vec3A::splat(t_min);
        let t_max = Vec3A::splat(t_max);
        let enter = Vec3A::select(tn.cmpgt(t_min), tn, t_min).max_element();
        let exit = Vec3A::select(tf.cmplt(t_max), tf, t_max).min_element();
        (enter <= exit).then_some(enter)
    }
}

impl Bvh {
    /// Visits the leaves the ray reaches, nearest box first, skipping boxes
    /// that start beyond the current `t_max`. `leaf(first, count, t_max)`
    /// tests leaf slots `first..first + count`, may shrink `t_max` (closest
    /// hit) and returns `true` to stop (any hit).
    #[inline(always)]
    pub fn traverse(
        &self,
        ray: &RayBoxTest,
        t_min: f32,
        mut t_max: f32,
        mut leaf: impl FnMut(u32, u32, &mut f32) -> bool,
    ) {
        let nodes = &self.nodes[..];
        let Some(root) = nodes.first() else {
            return;
        };
        if ray.entry(root, t_min, t_max).is_none() {
            return;
        }
        // Uninitialised: zeroing it would cost more than a shallow traversal.
        let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); STACK_SIZE];
        let mut top = 0;
        let mut node = root;
        loop {
            if node.is_leaf() {
                if leaf(node.first(), node.count(), &mut t_max) {
                    return;
                }
            } else {
                let first = node.first() as usize;
                let (a, b) = (&nodes[first], &nodes[first + 1]);
                let ta = ray.entry(a, t_min, t_max);
                let tb = ray.entry(b, t_min, t_max);
                match (ta, tb) {
                    (Some(ta), Some(tb)) => {
                        let (near, far, t_far) = if ta <= tb {
                            (a, first + 1, tb)
                        } else {
                            (b, first, ta)
                        };
                        stack[top] = MaybeUninit::new((far as u32, t_far));
                        top += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = a;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = b;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the nearest pending box that still starts before t_max.
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                // SAFETY: entries below the old `top` were written above.
                let (index, t_enter) = unsafe { stack[top].assume_init() };
                if t_enter <= t_max {
                    node = &nodes[index as usize];
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;
    use glam::Vec3;

    fn unit_node() -> Node {
        Node::leaf(Aabb::new(Vec3A::ZERO, Vec3A::ONE), 0, 1)
    }

    #[test]
    fn axis_parallel_rays_on_a_face_plane_enter_the_box() {
        let n = unit_node();
        // Along +x, lying in the planes y = 0 and z = 1.
        for (o, d) in [
            (Vec3::new(-1.0, 0.0, 1.0), Vec3::X),
            (Vec3::new(2.0, 1.0, 0.0), -Vec3::X),
            (Vec3::new(0.5, 0.0, -3.0), Vec3::Z),
            (Vec3::new(1.0, 1.0, 5.0), Vec3::new(0.0, -0.0, -1.0)),
        ] {
            let t = RayBoxTest::new(&Ray::new(o, d)).entry(&n, 0.0, f32::INFINITY);
            assert!(t.is_some(), "{o} {d}");
        }
    }

    #[test]
    fn misses_and_ranges() {
        let n = unit_node();
        let test = RayBoxTest::new(&Ray::new(Vec3::new(-1.0, 2.0, 0.5), Vec3::X));
        assert_eq!(test.entry(&n, 0.0, f32::INFINITY), None);
        let test = RayBoxTest::new(&Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X));
        assert_eq!(test.entry(&n, 0.0, f32::INFINITY), Some(1.0));
        assert_eq!(test.entry(&n, 0.0, 0.5), None);
        assert_eq!(test.entry(&n, 3.0, 9.0), None);
        // Starting inside: entry is t_min.
        let test = RayBoxTest::new(&Ray::new(Vec3::splat(0.5), Vec3::new(1.0, -2.0, 0.3)));
        assert_eq!(test.entry(&n, 0.0, f32::INFINITY), Some(0.0));
    }

    #[test]
    fn grazing_diagonal_ray_through_a_corner_enters() {
        let n = unit_node();
        let test = RayBoxTest::new(&Ray::new(
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(1.0, 1.0, 0.0),
        ));
        assert!(test.entry(&n, 0.0, f32::INFINITY).is_some());
        let test = RayBoxTest::new(&Ray::new(
            Vec3::new(-1.0, 1.0, 0.5),
            Vec3::new(1.0, 1.0, 0.0),
        ));
        assert!(test.entry(&n, 0.0, f32::INFINITY).is_none());
    }
}
