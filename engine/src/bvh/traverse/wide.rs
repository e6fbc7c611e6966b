//! The ordered walk over a 4-wide tree: the plain one meshes are traced
//! with ([`Bvh4`]) and the compact one
//! ([`CompactBvh4`](crate::bvh::compact::CompactBvh4)), through
//! [`WideTree`], so both share one walk and every node test.

use std::mem::MaybeUninit;

use super::{Flow, NodeTest, STACK_SIZE};
use crate::bvh::wide::{Boxes4, Bvh4};

/// Stack entries name an inner node by its index and a leaf by this bit
/// with its node's index and slot, so leaves are visited in key order with
/// the rest.
pub(super) const LEAF_REF: u32 = 1 << 31;

/// What a slot of a wide node holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    Empty,
    Inner(u32),
    Leaf,
}

/// A 4-wide tree as the walk sees it: slot boxes, and what each slot holds.
pub trait WideTree {
    /// What the leaf callback gets for a leaf slot.
    type Leaf: Copy;

    fn node_count(&self) -> usize;
    /// The slot boxes of node `node`: stored, or decoded conservatively.
    fn boxes(&self, node: usize) -> Boxes4;
    fn slot(&self, node: usize, slot: usize) -> Slot;
    /// The leaf in `slot` of `node`, a slot [`slot`](Self::slot) calls a leaf.
    fn leaf(&self, node: usize, slot: usize) -> Self::Leaf;
    /// Asks the cache for node `node`, which the walk will visit soon.
    fn prefetch(&self, node: usize);
}

/// Asks the cache for the line holding `x`.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing and cannot fault.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch(x as *const T as *const i8, _MM_HINT_T0);
    }
}

impl WideTree for Bvh4 {
    /// First leaf slot and count.
    type Leaf = (u32, u32);

    #[inline(always)]
    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    #[inline(always)]
    fn boxes(&self, node: usize) -> Boxes4 {
        self.nodes[node].boxes
    }

    #[inline(always)]
    fn slot(&self, node: usize, slot: usize) -> Slot {
        let n = &self.nodes[node];
        if n.count[slot] != 0 {
            Slot::Leaf
        } else if n.child[slot] == u32::MAX {
            Slot::Empty
        } else {
            Slot::Inner(n.child[slot])
        }
    }

    #[inline(always)]
    fn leaf(&self, node: usize, slot: usize) -> (u32, u32) {
        let n = &self.nodes[node];
        (n.child[slot], n.count[slot])
    }

    /// Nothing: asking for the two lines of every kept child cost the
    /// plain tree about 15% of its incoherent ray rate on a 2M hall.
    #[inline(always)]
    fn prefetch(&self, _node: usize) {}
}

/// Visits the leaves of `tree` that `test` reaches, nearer keys first,
/// skipping boxes whose key exceeds the bound by the time they are reached.
/// `leaf(leaf, bound)` may lower `bound` and breaks to end the walk.
#[inline(always)]
pub fn walk<W: WideTree, T: NodeTest>(
    tree: &W,
    test: &T,
    bound: f32,
    leaf: impl FnMut(W::Leaf, &mut f32) -> Flow,
) {
    walk_pruned(tree, test, bound, |_, _, _| true, leaf);
}

/// [`walk`], asking `open(node, key, bound)` before it enters each inner
/// node below the root: `false` keeps the walk out of that subtree (a
/// level of detail answered for it instead; `open` may lower `bound`).
#[inline(always)]
pub fn walk_pruned<W: WideTree, T: NodeTest>(
    tree: &W,
    test: &T,
    bound: f32,
    open: impl FnMut(usize, f32, &mut f32) -> bool,
    mut leaf: impl FnMut(W::Leaf, &mut f32) -> Flow,
) {
    // Each level pushes at most three more entries than it pops.
    walk_nodes::<_, { 3 * STACK_SIZE }>(&Four { tree, test }, bound, open, |node, slot, bound| {
        leaf(tree.leaf(node, slot), bound)
    });
}

/// A wide tree and a node test, as the walk's core sees them, whatever
/// the width: four slots a node ([`WideTree`]) or eight
/// ([`Bvh8`](crate::bvh::wide::Bvh8)).
pub(crate) trait WideWalk {
    /// Slots per node, as a power of two: a leaf's stack entry holds its
    /// node and slot in the bits below [`LEAF_REF`].
    const SLOT_BITS: u32;
    /// Whether kept slots are visited in key order (see [`NodeTest::ORDERED`]).
    const ORDERED: bool;
    type Keys: Copy + std::ops::Index<usize, Output = f32>;

    fn node_count(&self) -> usize;
    /// The keys of node `node`'s slot boxes and a mask of those kept under
    /// `bound` (empty slots may be among them: see [`walk_nodes`]).
    fn test(&self, node: usize, bound: f32) -> (Self::Keys, u32);
    /// The stack entry of `slot` of `node`: its child node's index, or
    /// [`LEAF_REF`] with the node and slot for a leaf; `None` when empty.
    fn entry(&self, node: usize, slot: usize) -> Option<u32>;
    fn prefetch(&self, node: usize);
}

/// A 4-wide tree walked with `test`.
struct Four<'a, W, T> {
    tree: &'a W,
    test: &'a T,
}

impl<W: WideTree, T: NodeTest> WideWalk for Four<'_, W, T> {
    const SLOT_BITS: u32 = 2;
    const ORDERED: bool = T::ORDERED;
    type Keys = [f32; 4];

    #[inline(always)]
    fn node_count(&self) -> usize {
        self.tree.node_count()
    }

    #[inline(always)]
    fn test(&self, node: usize, bound: f32) -> ([f32; 4], u32) {
        let (keys, mask) = self.test.test4(&self.tree.boxes(node), bound);
        // As an array: glam indexes a `Vec4` through a jump table, an
        // indirect branch per kept slot that rarely predicts (a tenth of a
        // tail ray's time in a hall).
        (keys.to_array(), mask)
    }

    #[inline(always)]
    fn entry(&self, node: usize, slot: usize) -> Option<u32> {
        match self.tree.slot(node, slot) {
            Slot::Empty => None,
            Slot::Inner(child) => Some(child),
            Slot::Leaf => Some(LEAF_REF | (node as u32) << Self::SLOT_BITS | slot as u32),
        }
    }

    #[inline(always)]
    fn prefetch(&self, node: usize) {
        self.tree.prefetch(node)
    }
}

/// The walk's core: visits the leaf slots `walk` keeps, nearer keys first,
/// as `leaf(node, slot, bound)` (see [`walk_pruned`]). `STACK` entries
/// hold the deferred slots: a node's slots less one per level of
/// [`STACK_SIZE`], sized per width so that a 4-wide walk keeps its frame
/// small.
#[inline(always)]
pub(crate) fn walk_nodes<W: WideWalk, const STACK: usize>(
    walk: &W,
    mut bound: f32,
    mut open: impl FnMut(usize, f32, &mut f32) -> bool,
    mut leaf: impl FnMut(usize, usize, &mut f32) -> Flow,
) {
    if walk.node_count() == 0 {
        return;
    }
    // Uninitialised: zeroing it would cost more than a shallow walk.
    let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); STACK];
    let mut top = 0usize;
    let mut node = 0usize;
    let slot_mask = (1u32 << W::SLOT_BITS) - 1;
    loop {
        let base = top;
        let (keys, mut mask) = walk.test(node, bound);
        // The nearest kept child is handled next, the others pushed
        // farthest first. Most nodes keep at most one child: no sort then.
        let mut next = None;
        while mask != 0 {
            let s = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            // Empty slots whatever the test says: a test with NaN in its
            // planes (a frustum from a source at 3e38 m) kept their empty
            // boxes, and the slot's marker read as a leaf out of bounds.
            let Some(entry) = walk.entry(node, s) else {
                continue;
            };
            let entry = (entry, keys[s]);
            let Some(held) = next else {
                next = Some(entry);
                continue;
            };
            // Of the two, the nearer stays held; the other joins the
            // entries pushed for this node, kept sorted farthest first.
            let (near, far) = if !W::ORDERED || held.1 <= entry.1 {
                (held, entry)
            } else {
                (entry, held)
            };
            next = Some(near);
            if far.0 & LEAF_REF == 0 {
                walk.prefetch(far.0 as usize);
            }
            let mut j = top;
            if W::ORDERED {
                // SAFETY: entries below `top` were written.
                while j > base && unsafe { stack[j - 1].assume_init() }.1 < far.1 {
                    stack[j] = stack[j - 1];
                    j -= 1;
                }
            }
            stack[j] = MaybeUninit::new(far);
            top += 1;
        }
        loop {
            let (index, key) = match next.take() {
                Some(entry) => entry,
                None => {
                    if top == 0 {
                        return;
                    }
                    top -= 1;
                    // SAFETY: entries below `top` were written above.
                    unsafe { stack[top].assume_init() }
                }
            };
            // A test need not prune by the bound itself, and a leaf may
            // have lowered it since the entry was pushed.
            if key > bound {
                continue;
            }
            if index & LEAF_REF == 0 {
                if !open(index as usize, key, &mut bound) {
                    continue;
                }
                node = index as usize;
                break;
            }
            let (n, s) = ((index & !LEAF_REF) >> W::SLOT_BITS, index & slot_mask);
            if leaf(n as usize, s as usize, &mut bound).is_break() {
                return;
            }
        }
    }
}

impl Bvh4 {
    /// Visits the leaves `test` reaches, nearer keys first (see [`walk`]).
    /// `leaf(first, count, bound)` gets leaf slots `first..first + count`,
    /// may lower `bound` and breaks to end the walk.
    #[inline(always)]
    pub fn walk<T: NodeTest>(
        &self,
        test: &T,
        bound: f32,
        mut leaf: impl FnMut(u32, u32, &mut f32) -> Flow,
    ) {
        walk(self, test, bound, |(first, count), b| leaf(first, count, b));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{BuildOptions, MeshBvh};
    use crate::geometry::{shapes, Aabb};

    /// Keeps every box, empty or not, as a test with NaN planes does.
    struct Everything;

    impl NodeTest for Everything {
        fn test(&self, _: &Aabb, _: f32) -> Option<f32> {
            Some(0.0)
        }
    }

    #[test]
    fn empty_slots_are_skipped_whatever_the_test_keeps() {
        // Three triangles: the root has empty slots.
        let mesh = shapes::cube(1.0, 1);
        let mesh = crate::geometry::TriangleMesh::new(
            mesh.positions().to_vec(),
            mesh.triangles()[..3].to_vec(),
        )
        .unwrap();
        let bvh = MeshBvh::build(&mesh, &BuildOptions::default());
        assert!(bvh
            .wide()
            .nodes()
            .iter()
            .any(|n| n.child.contains(&u32::MAX)));
        let mut seen = 0;
        bvh.wide().walk(&Everything, f32::INFINITY, |_, count, _| {
            seen += count;
            Flow::Continue(())
        });
        assert_eq!(seen, 3);
    }
}
