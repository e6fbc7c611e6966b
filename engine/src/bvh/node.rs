//! The BVH node.
//!
//! A node is 32 bytes, two per 64-byte cache line, as in tinybvh and in
//! Lauterbach's 32-byte AABB layout: the box as two `Vec4` whose fourth lanes
//! carry the link and the primitive count. Each half loads with one aligned
//! SSE load and turns into a `Vec3A` for free, so the slab test touches no
//! scalar fields. The rebuild heuristic's build-time ratio lives in a
//! separate array, since only refit reads it.

use glam::{Vec3A, Vec4};

use crate::geometry::Aabb;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Node {
    /// `xyz`: box minimum; `w`: bits of the first child (inner) or the first
    /// leaf slot (leaf).
    min_first: Vec4,
    /// `xyz`: box maximum; `w`: bits of the primitive count, 0 for inner nodes.
    max_count: Vec4,
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);

impl Default for Node {
    fn default() -> Self {
        Self::leaf(Aabb::EMPTY, 0, 0)
    }
}

impl Node {
    #[inline]
    pub fn leaf(bounds: Aabb, first: u32, count: u32) -> Self {
        Self {
            min_first: bounds.min.extend(f32::from_bits(first)),
            max_count: bounds.max.extend(f32::from_bits(count)),
        }
    }

    /// An inner node whose children are `first` and `first + 1`.
    #[inline]
    pub fn inner(bounds: Aabb, first: u32) -> Self {
        Self::leaf(bounds, first, 0)
    }

    #[inline(always)]
    pub fn min(&self) -> Vec3A {
        Vec3A::from_vec4(self.min_first)
    }

    #[inline(always)]
    pub fn max(&self) -> Vec3A {
        Vec3A::from_vec4(self.max_count)
    }

    #[inline(always)]
    pub fn aabb(&self) -> Aabb {
        Aabb::new(self.min(), self.max())
    }

    /// First child (inner node) or first leaf slot (leaf).
    #[inline(always)]
    pub fn first(&self) -> u32 {
        self.min_first.w.to_bits()
    }

    /// Primitives in a leaf; 0 for an inner node.
    #[inline(always)]
    pub fn count(&self) -> u32 {
        self.max_count.w.to_bits()
    }

    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count() != 0
    }

    #[inline]
    pub fn set_aabb(&mut self, b: Aabb) {
        let (first, count) = (self.first(), self.count());
        *self = Self::leaf(b, first, count);
    }

    #[inline]
    pub(crate) fn set_first(&mut self, first: u32) {
        self.min_first.w = f32::from_bits(first);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_round_trip_through_float_lanes() {
        // Counts and links whose bit patterns are NaNs or denormals must survive.
        for v in [0u32, 1, 0x7fc0_0001, 0xffff_ffff, 0x0000_0001] {
            let n = Node::leaf(Aabb::new(Vec3A::ZERO, Vec3A::ONE), v, v);
            assert_eq!((n.first(), n.count()), (v, v));
            let mut m = n;
            m.set_aabb(Aabb::new(Vec3A::NEG_ONE, Vec3A::ONE));
            assert_eq!((m.first(), m.count()), (v, v));
        }
    }
}
