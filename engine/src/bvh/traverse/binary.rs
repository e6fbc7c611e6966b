//! The ordered walk over the binary tree: the top level of scenes, where
//! nodes are few and each leaf is a whole object.

use std::mem::MaybeUninit;

use super::{Flow, NodeTest, STACK_SIZE};
use crate::bvh::Bvh;

impl Bvh {
    /// Visits the leaves `test` reaches, nearest key first, skipping boxes
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
        let nodes = &self.nodes[..];
        let Some(root) = nodes.first() else {
            return;
        };
        if test.test(&root.aabb(), bound).is_none() {
            return;
        }
        // Uninitialised: zeroing it would cost more than a shallow walk.
        let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); STACK_SIZE];
        let mut top = 0;
        let mut node = root;
        loop {
            if node.is_leaf() {
                if leaf(node.first(), node.count(), &mut bound).is_break() {
                    return;
                }
            } else {
                let first = node.first() as usize;
                let (a, b) = (&nodes[first], &nodes[first + 1]);
                match (test.test(&a.aabb(), bound), test.test(&b.aabb(), bound)) {
                    (Some(ka), Some(kb)) => {
                        let (near, far, k_far) = if !T::ORDERED || ka <= kb {
                            (a, first + 1, kb)
                        } else {
                            (b, first, ka)
                        };
                        stack[top] = MaybeUninit::new((far as u32, k_far));
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
            // Pop the nearest pending box whose key is still within bound.
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                // SAFETY: entries below the old `top` were written above.
                let (index, key) = unsafe { stack[top].assume_init() };
                if key <= bound {
                    node = &nodes[index as usize];
                    break;
                }
            }
        }
    }
}
