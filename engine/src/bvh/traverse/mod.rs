//! The traversal core: every walk over a hierarchy goes through here.
//!
//! A query is a [`NodeTest`]: given a box (or the four boxes of a wide node)
//! and the walk's current bound, it prunes the box or gives it an order key
//! (a ray's entry distance, a frustum's nearest depth). The walks
//! ([`Bvh::walk`](super::Bvh::walk) over the binary tree,
//! [`Bvh4::walk`](super::wide::Bvh4::walk) over the wide one) visit the
//! boxes the test keeps, nearest key first, skip any whose key has passed
//! the bound by the time it is reached, and hand leaves to a callback that
//! may tighten the bound (closest hit) or end the walk (any hit). Two trees
//! are walked together by [`pair`], the bounding-volume test tree of
//! collision queries.
//!
//! Node tests are written per query kind, as in Embree's node intersectors,
//! so each kind keeps its SIMD form: [`RayTest`] (the robust slab test),
//! [`FrustumTest`] (half-spaces with a depth key) and [`OverlapTest`]
//! (a box, for points, proximity and broad phases).

mod binary;
pub mod front;
mod frustum;
mod overlap;
pub mod pair;
mod ray;
pub(crate) mod ray8;
mod wide;

use std::ops::ControlFlow;

use glam::Vec4;

pub use frustum::FrustumTest;
pub use overlap::OverlapTest;
pub use ray::RayTest;
pub(crate) use wide::prefetch;
pub use wide::{walk, walk_pruned, Slot, WideTree};

use super::wide::Boxes4;
use crate::geometry::Aabb;

/// Enough for the deepest tree the builders make (see `FORCE_MEDIAN_DEPTH`).
pub const STACK_SIZE: usize = 96;

/// What a leaf callback tells the walk: go on, or stop here.
pub type Flow = ControlFlow<()>;

/// A query's test against the boxes of a hierarchy.
///
/// Keys order the walk (smaller first) and are compared with the bound the
/// leaf callbacks maintain: a box whose key exceeds the bound is skipped.
/// A test should prune empty boxes (minimum above maximum), which pad the
/// wide nodes' unused slots; the walks skip those slots anyway, since a
/// test whose planes or ray hold NaN can keep any box.
pub trait NodeTest {
    /// Whether the walk should visit kept boxes in key order. Queries that
    /// must see every overlap (all hits, broad phases) say `false` and save
    /// the sort.
    const ORDERED: bool = true;

    /// The key of box `b`, or `None` when the query cannot reach it with a
    /// key up to `bound`.
    fn test(&self, b: &Aabb, bound: f32) -> Option<f32>;

    /// [`test`](Self::test) for the four slot boxes of a wide node: their
    /// keys, and a bit mask of the slots kept.
    fn test4(&self, boxes: &Boxes4, bound: f32) -> (Vec4, u32) {
        let mut keys = Vec4::ZERO;
        let mut mask = 0;
        for slot in 0..4 {
            if let Some(k) = self.test(&boxes.slot_aabb(slot), bound) {
                keys[slot] = k;
                mask |= 1 << slot;
            }
        }
        (keys, mask)
    }
}
