//! The box query's node test: which boxes overlap a given box. Points
//! (a box of zero or small size), proximity queries (a box grown by the
//! distance) and broad phases all use it.

use glam::{BVec4A, Vec4};

use super::NodeTest;
use crate::bvh::wide::Boxes4;
use crate::geometry::Aabb;

/// Keeps the boxes that overlap or touch `query`; every key is 0, so the
/// walk is unordered and sees every overlap.
#[derive(Clone, Copy, Debug)]
pub struct OverlapTest {
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    query: Aabb,
}

impl OverlapTest {
    pub fn new(query: Aabb) -> Self {
        Self {
            lo: [0, 1, 2].map(|a| Vec4::splat(query.min[a])),
            hi: [0, 1, 2].map(|a| Vec4::splat(query.max[a])),
            query,
        }
    }
}

impl NodeTest for OverlapTest {
    const ORDERED: bool = false;

    #[inline]
    fn test(&self, b: &Aabb, _bound: f32) -> Option<f32> {
        let q = &self.query;
        (b.min.cmple(q.max).all() && b.max.cmpge(q.min).all()).then_some(0.0)
    }

    #[inline]
    fn test4(&self, n: &Boxes4, _bound: f32) -> (Vec4, u32) {
        let mut keep = BVec4A::splat(true);
        for axis in 0..3 {
            keep &= n.lo[axis].cmple(self.hi[axis]) & n.hi[axis].cmpge(self.lo[axis]);
        }
        (Vec4::ZERO, keep.bitmask())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::wide::EMPTY_NODE;
    use glam::Vec3A;

    #[test]
    fn touching_counts_and_empty_slots_never_do() {
        let test = OverlapTest::new(Aabb::new(Vec3A::ZERO, Vec3A::ONE));
        let boxes = [
            Aabb::new(Vec3A::ONE, Vec3A::splat(2.0)),
            Aabb::new(Vec3A::new(1.5, 0.0, 0.0), Vec3A::splat(2.0)),
            Aabb::new(Vec3A::splat(0.25), Vec3A::splat(0.5)),
        ];
        let mut node = EMPTY_NODE;
        for (s, b) in boxes.iter().enumerate() {
            node.set_slot_aabb(s, *b);
        }
        assert_eq!(test.test4(&node.boxes, 0.0).1, 0b101);
        for s in 0..4 {
            let kept = test.test(&node.slot_aabb(s), 0.0).is_some();
            assert_eq!(kept, s == 0 || s == 2);
        }
    }
}
