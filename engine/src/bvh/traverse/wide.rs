//! The ordered walk over the 4-wide tree that meshes are traced with.

use std::mem::MaybeUninit;

use super::{Flow, NodeTest, STACK_SIZE};
use crate::bvh::wide::{Bvh4, Node4};

/// Stack entries name an inner node by its index and a leaf by this bit
/// with its node's index and slot, so leaves are visited in key order with
/// the rest.
pub(super) const LEAF_REF: u32 = 1 << 31;

#[inline(always)]
pub(super) fn child_ref(n: &Node4, node: usize, slot: usize) -> u32 {
    if n.count[slot] != 0 {
        LEAF_REF | (node as u32) << 2 | slot as u32
    } else {
        n.child[slot]
    }
}

impl Bvh4 {
    /// Visits the leaves `test` reaches, nearer keys first, skipping boxes
    /// whose key exceeds the bound by the time they are reached.
    /// `leaf(first, count, bound)` gets leaf slots `first..first + count`,
    /// may lower `bound` and breaks to end the walk.
    #[inline(always)]
    pub fn walk<T: NodeTest>(
        &self,
        test: &T,
        mut bound: f32,
        mut leaf: impl FnMut(u32, u32, &mut f32) -> Flow,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        // Each level pushes at most three more entries than it pops.
        // Uninitialised: zeroing it would cost more than a shallow walk.
        let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); 3 * STACK_SIZE];
        let mut top = 0usize;
        let mut node = 0usize;
        loop {
            let (keys, mut mask) = test.test4(&self.nodes[node], bound);
            // Children kept, sorted farthest first and pushed, so that the
            // nearest, leaf or not, is handled next.
            let mut kept = [(0u32, 0.0f32); 4];
            let mut k = 0;
            while mask != 0 {
                let s = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                // Empty slots whatever the test says: a test with NaN in its
                // planes (a frustum from a source at 3e38 m) kept their
                // empty boxes, and the slot's marker read as a leaf out of
                // bounds.
                if self.nodes[node].child[s] == u32::MAX {
                    continue;
                }
                kept[k] = (child_ref(&self.nodes[node], node, s), keys[s]);
                k += 1;
            }
            if T::ORDERED {
                for i in 1..k {
                    let mut j = i;
                    while j > 0 && kept[j - 1].1 < kept[j].1 {
                        kept.swap(j - 1, j);
                        j -= 1;
                    }
                }
            }
            for &entry in &kept[..k] {
                stack[top] = MaybeUninit::new(entry);
                top += 1;
            }
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                // SAFETY: entries below the old `top` were written above.
                let (index, key) = unsafe { stack[top].assume_init() };
                if key > bound {
                    continue;
                }
                if index & LEAF_REF == 0 {
                    node = index as usize;
                    break;
                }
                let (n, s) = ((index & !LEAF_REF) >> 2, index & 3);
                let n = &self.nodes[n as usize];
                if leaf(n.child[s as usize], n.count[s as usize], &mut bound).is_break() {
                    return;
                }
            }
        }
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
