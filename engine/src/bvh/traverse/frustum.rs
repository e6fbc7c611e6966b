//! The frustum's node test: a convex set of half-spaces, keyed by depth.
//!
//! The test is conservative (a box is dropped only when it lies wholly
//! outside one plane), which is all its users need: exact work happens per
//! triangle. The key is the smallest depth over the box along a depth
//! gradient, so the walk goes nearest first and a bound on depth (once
//! nothing farther can matter) skips the rest.

use glam::{BVec4A, Vec3A, Vec4};

use super::NodeTest;
use crate::bvh::wide::Boxes4;
use crate::geometry::{Aabb, RigidTransform};

/// At most this many bounding planes (four sides and a near plane).
pub const MAX_PLANES: usize = 5;

/// Inward half-spaces `normals[i] · p >= offsets[i] - slack` and the depth
/// `depth_normal · p - depth_offset`, in single precision.
#[derive(Clone, Copy, Debug)]
pub struct FrustumTest {
    normals: [Vec3A; MAX_PLANES],
    offsets: [f32; MAX_PLANES],
    planes: usize,
    depth_normal: Vec3A,
    depth_offset: f32,
    slack: f32,
}

impl FrustumTest {
    /// The half-spaces `normal · p >= offset - slack` (at most
    /// [`MAX_PLANES`]; more are ignored) with depth `depth.0 · p - depth.1`.
    pub fn new(planes: &[(Vec3A, f32)], depth: (Vec3A, f32), slack: f32) -> Self {
        let mut normals = [Vec3A::ZERO; MAX_PLANES];
        let mut offsets = [0.0; MAX_PLANES];
        let count = planes.len().min(MAX_PLANES);
        for (i, &(n, d)) in planes[..count].iter().enumerate() {
            normals[i] = n;
            offsets[i] = d;
        }
        Self {
            normals,
            offsets,
            planes: count,
            depth_normal: depth.0,
            depth_offset: depth.1,
            slack,
        }
    }

    /// The same test in an object's frame, given the world-to-object
    /// transform.
    pub fn in_frame(&self, to_object: &RigidTransform) -> Self {
        // A point p' of the object frame is to_world(p') in the world.
        let shift = Vec3A::from(to_object.inverse().translation);
        let mut out = *self;
        for i in 0..self.planes {
            out.normals[i] = to_object.transform_vector(self.normals[i]);
            out.offsets[i] = self.offsets[i] - self.normals[i].dot(shift);
        }
        out.depth_normal = to_object.transform_vector(self.depth_normal);
        out.depth_offset = self.depth_offset - self.depth_normal.dot(shift);
        out
    }

    /// Whether `b` may overlap the half-spaces.
    #[inline]
    pub fn overlaps(&self, b: &Aabb) -> bool {
        (0..self.planes).all(|i| {
            let n = self.normals[i];
            let far = Vec3A::select(n.cmpgt(Vec3A::ZERO), b.max, b.min);
            n.dot(far) >= self.offsets[i] - self.slack
        })
    }

    /// The smallest depth over box `b` (a lower bound, in f32).
    #[inline]
    fn near_depth(&self, b: &Aabb) -> f32 {
        let n = self.depth_normal;
        let near = Vec3A::select(n.cmpgt(Vec3A::ZERO), b.min, b.max);
        n.dot(near) - self.depth_offset
    }
}

/// `n · p` over the four slots, `p` the corner that `pick_hi` (per axis)
/// takes from the maxima, else from the minima.
#[inline(always)]
fn dot4(node: &Boxes4, n: Vec3A, pick_hi: impl Fn(f32) -> bool) -> Vec4 {
    let mut dot = Vec4::ZERO;
    for axis in 0..3 {
        let corner = if pick_hi(n[axis]) {
            node.hi[axis]
        } else {
            node.lo[axis]
        };
        dot += corner * n[axis];
    }
    dot
}

impl NodeTest for FrustumTest {
    #[inline]
    fn test(&self, b: &Aabb, bound: f32) -> Option<f32> {
        let depth = self.near_depth(b);
        (self.overlaps(b) && depth <= bound).then_some(depth)
    }

    #[inline]
    fn test4(&self, node: &Boxes4, bound: f32) -> (Vec4, u32) {
        let mut keep = BVec4A::splat(true);
        for i in 0..self.planes {
            let far = dot4(node, self.normals[i], |c| c > 0.0);
            keep &= far.cmpge(Vec4::splat(self.offsets[i] - self.slack));
        }
        let depth = dot4(node, self.depth_normal, |c| c <= 0.0) - Vec4::splat(self.depth_offset);
        keep &= depth.cmple(Vec4::splat(bound));
        (depth, keep.bitmask())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::wide::EMPTY_NODE;
    use glam::{Quat, Vec3};

    /// The quarter space x >= 0, y >= 0 with depth x + y.
    fn quadrant() -> FrustumTest {
        FrustumTest::new(
            &[(Vec3A::X, 0.0), (Vec3A::Y, 0.0)],
            (Vec3A::new(1.0, 1.0, 0.0), 0.0),
            0.0,
        )
    }

    fn cube(at: Vec3) -> Aabb {
        Aabb::new(Vec3A::from(at), Vec3A::from(at) + Vec3A::ONE)
    }

    #[test]
    fn boxes_outside_one_plane_or_beyond_the_bound_are_pruned() {
        let q = quadrant();
        assert_eq!(q.test(&cube(Vec3::new(1.0, 2.0, 0.0)), 10.0), Some(3.0));
        assert_eq!(q.test(&cube(Vec3::new(1.0, 2.0, 0.0)), 2.5), None);
        // Touching the plane x = 0 from outside counts as overlapping.
        assert_eq!(q.test(&cube(Vec3::new(-1.0, 2.0, 0.0)), 10.0), Some(1.0));
        assert_eq!(q.test(&cube(Vec3::new(-1.5, 2.0, 0.0)), 10.0), None);
        assert_eq!(q.test(&Aabb::EMPTY, f32::INFINITY), None);
    }

    #[test]
    fn four_slots_agree_with_one_box_tests() {
        let q = quadrant();
        let boxes = [
            cube(Vec3::new(1.0, 2.0, 0.0)),
            cube(Vec3::new(-1.5, 2.0, 0.0)),
            cube(Vec3::new(4.0, 4.0, -3.0)),
        ];
        let mut node = EMPTY_NODE;
        for (s, b) in boxes.iter().enumerate() {
            node.set_slot_aabb(s, *b);
        }
        for bound in [2.5, 5.0, f32::INFINITY] {
            let (keys, mask) = q.test4(&node.boxes, bound);
            for s in 0..4 {
                let one = q.test(&node.slot_aabb(s), bound);
                assert_eq!(one, (mask >> s & 1 == 1).then_some(keys[s]), "{s} {bound}");
            }
        }
    }

    #[test]
    fn in_frame_matches_moving_the_box_instead() {
        let to_world = RigidTransform::new(
            Quat::from_axis_angle(Vec3::Z, std::f32::consts::FRAC_PI_2),
            Vec3::new(5.0, 0.0, 0.0),
        )
        .unwrap();
        let local = quadrant().in_frame(&to_world.inverse());
        // The object-frame box at (1..2, -3..-2) sits at x 7..8, y 1..2 in
        // the world after the quarter turn and shift.
        let b = Aabb::new(Vec3A::new(1.0, -3.0, 0.0), Vec3A::new(2.0, -2.0, 1.0));
        let depth = local.test(&b, f32::INFINITY).unwrap();
        assert!((depth - 8.0).abs() < 1e-5, "{depth}");
        let outside = Aabb::new(Vec3A::new(1.0, 6.0, 0.0), Vec3A::new(2.0, 7.0, 1.0));
        assert_eq!(local.test(&outside, f32::INFINITY), None);
    }
}
