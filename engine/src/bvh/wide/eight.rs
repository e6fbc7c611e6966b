//! The 8-wide tree that rays walk on CPUs with AVX, beside the 4-wide one
//! every other query walks.
//!
//! An incoherent ray's walk is a chain of dependent loads, one per node:
//! eight children a node take about two thirds of the levels of four, and
//! AVX tests the eight boxes in one instruction per slab. In hall-10k's
//! stochastic tail (incoherent closest hits) this took a quarter off the
//! time. Without AVX the tree is not built and rays walk the 4-wide one.

use glam::Vec4;

use super::super::Node;
use super::{Bvh4, WideNode};
use crate::bvh::traverse::Slot;
use crate::geometry::Aabb;

/// Eight child boxes, their links and counts: 256 bytes, four cache lines.
/// The six planes (minima per axis, then maxima) are rows of eight, so
/// one AVX register holds a plane of every child; a ray picks each axis's
/// near and far row once. Slots are leaves, inner nodes or empty exactly
/// as in [`Node4`](super::Node4).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Node8 {
    pub(crate) planes: [[f32; 8]; 6],
    /// First leaf slot (leaf) or child node (inner); `u32::MAX` when empty.
    pub child: [u32; 8],
    /// Primitives in a leaf slot; 0 for inner and empty slots.
    pub count: [u32; 8],
}

const _: () = assert!(std::mem::size_of::<Node8>() == 256);

const EMPTY_NODE8: Node8 = Node8 {
    planes: [
        [f32::INFINITY; 8],
        [f32::INFINITY; 8],
        [f32::INFINITY; 8],
        [f32::NEG_INFINITY; 8],
        [f32::NEG_INFINITY; 8],
        [f32::NEG_INFINITY; 8],
    ],
    child: [u32::MAX; 8],
    count: [0; 8],
};

impl Node8 {
    pub fn slot_aabb(&self, slot: usize) -> Aabb {
        let p = &self.planes;
        Aabb::new(
            glam::Vec3A::new(p[0][slot], p[1][slot], p[2][slot]),
            glam::Vec3A::new(p[3][slot], p[4][slot], p[5][slot]),
        )
    }

    fn set_slot_aabb(&mut self, slot: usize, b: Aabb) {
        for axis in 0..3 {
            self.planes[axis][slot] = b.min[axis];
            self.planes[3 + axis][slot] = b.max[axis];
        }
    }

    /// The union of the eight slots, plane by plane: this node's own box.
    pub fn aabb(&self) -> Aabb {
        // Four lanes at a time, as the 4-wide node's union: a fold of
        // `f32::min` is eight dependent steps, each with its NaN check.
        let p = &self.planes;
        let halves = |row: &[f32; 8]| (Vec4::from_slice(&row[..4]), Vec4::from_slice(&row[4..]));
        let min = |row| {
            let (a, b) = halves(row);
            a.min(b).min_element()
        };
        let max = |row| {
            let (a, b) = halves(row);
            a.max(b).max_element()
        };
        Aabb::new(
            glam::Vec3A::new(min(&p[0]), min(&p[1]), min(&p[2])),
            glam::Vec3A::new(max(&p[3]), max(&p[4]), max(&p[5])),
        )
    }

    #[inline(always)]
    pub fn slot(&self, slot: usize) -> Slot {
        if self.count[slot] != 0 {
            Slot::Leaf
        } else if self.child[slot] == u32::MAX {
            Slot::Empty
        } else {
            Slot::Inner(self.child[slot])
        }
    }
}

/// An 8-wide BVH over the same leaf slots as the binary tree it was
/// collapsed from (and so as the 4-wide one). Children come after their
/// parent.
#[derive(Clone, Debug, Default)]
pub struct Bvh8 {
    pub(crate) nodes: Vec<Node8>,
    /// Per node, for each leaf slot, where the 4-wide tree over the same
    /// leaf slots holds that leaf (`4 · node + slot`; `u32::MAX` for other
    /// slots): a refit copies the leaf's box from there rather than
    /// reading its triangles a second time.
    leaf_sources: Vec<[u32; 8]>,
}

impl Bvh8 {
    /// Collapses a binary tree into the 8-wide tree over the same leaves
    /// with the least node area (see [`collapse`](super::collapse)).
    /// `four` is the 4-wide tree collapsed from the same binary tree, which
    /// [`refit_from`](Self::refit_from) copies leaf boxes from.
    pub fn from_binary(bin: &[Node], four: &Bvh4) -> Self {
        let mut nodes = super::collapse::collapse_tree(bin);
        nodes.shrink_to_fit();
        let leaf_sources = leaf_sources(&nodes, four);
        Self {
            nodes,
            leaf_sources,
        }
    }

    /// Whether every leaf can be named on the walk's stack: node and slot
    /// in the 31 bits below its leaf marker, so fewer than 2^28 nodes
    /// (about 270 million triangles); past that, rays walk the 4-wide tree.
    pub(crate) fn addressable(&self) -> bool {
        self.nodes.len() < 1 << 28
    }

    pub fn nodes(&self) -> &[Node8] {
        &self.nodes
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node8>()
            + self.leaf_sources.capacity() * std::mem::size_of::<[u32; 8]>()
    }

    /// Recomputes every box after `four` was refitted: leaf slots copied
    /// from it, inner ones as the union of their child's slots.
    pub(crate) fn refit_from(&mut self, four: &Bvh4) {
        let (nodes, sources) = (&mut self.nodes, &mut self.leaf_sources);
        super::refit::refit_leaves(nodes, sources, |n: &mut Node8, sources| {
            for (s, &from) in sources.iter().enumerate() {
                if from != u32::MAX {
                    let b = four.nodes[(from / 4) as usize].slot_aabb((from % 4) as usize);
                    n.set_slot_aabb(s, b);
                }
            }
        });
        super::refit::refit_inner(&mut self.nodes);
    }
}

/// Where `four`, collapsed from the same binary tree as `nodes`, holds each
/// leaf of `nodes` (see [`Bvh8::leaf_sources`]), found by its first slot.
fn leaf_sources(nodes: &[Node8], four: &Bvh4) -> Vec<[u32; 8]> {
    // Indexed by first slot: leaves start at distinct slots below the slot
    // count, which the last leaf's end gives.
    let slots = four
        .nodes
        .iter()
        .flat_map(|n| n.leaves())
        .map(|(first, count)| first + count)
        .max()
        .unwrap_or(0);
    let mut by_first = vec![u32::MAX; slots as usize];
    for (i, n) in four.nodes.iter().enumerate() {
        for s in 0..4 {
            if n.is_leaf_slot(s) {
                by_first[n.child[s] as usize] = (4 * i + s) as u32;
            }
        }
    }
    nodes
        .iter()
        .map(|n| {
            std::array::from_fn(|s| {
                n.leaf(s).map_or(u32::MAX, |(first, _)| {
                    let from = by_first[first as usize];
                    debug_assert_ne!(from, u32::MAX, "a leaf the 4-wide tree lacks");
                    from
                })
            })
        })
        .collect()
}

impl super::WideNode for Node8 {
    const WIDTH: usize = 8;
    const EMPTY: Self = EMPTY_NODE8;

    fn set_slot(&mut self, slot: usize, aabb: Aabb, child: u32, count: u32) {
        self.set_slot_aabb(slot, aabb);
        self.child[slot] = child;
        self.count[slot] = count;
    }

    fn set_slot_aabb(&mut self, slot: usize, aabb: Aabb) {
        Node8::set_slot_aabb(self, slot, aabb)
    }

    fn aabb(&self) -> Aabb {
        Node8::aabb(self)
    }

    fn leaf(&self, slot: usize) -> Option<(u32, u32)> {
        (self.slot(slot) == Slot::Leaf).then(|| (self.child[slot], self.count[slot]))
    }

    fn inner(&self, slot: usize) -> Option<usize> {
        match self.slot(slot) {
            Slot::Inner(child) => Some(child as usize),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::WideNode;
    use super::*;
    use glam::Vec3A;

    /// A node's box is the union of its slots' boxes, empty slots (the
    /// padding's infinite planes) and far-apart slots alike, whichever
    /// slot holds the extremes.
    #[test]
    fn a_node_box_is_the_union_of_its_slots() {
        let boxes = [
            Aabb::new(Vec3A::new(-3.0, 0.5, 2.0), Vec3A::new(-1.0, 4.0, 2.5)),
            Aabb::new(Vec3A::new(1e6, -2.0, -7.0), Vec3A::new(2e6, -1.0, 9.0)),
            Aabb::new(Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(0.0, 0.0, 0.0)),
        ];
        let expected = Aabb::new(Vec3A::new(-3.0, -2.0, -7.0), Vec3A::new(2e6, 4.0, 9.0));
        for (first, turn) in (0..6).flat_map(|f| (0..3).map(move |t| (f, t))) {
            let mut boxes = boxes;
            boxes.rotate_left(turn);
            let mut n8 = Node8::EMPTY;
            let mut n4 = super::super::EMPTY_NODE;
            for (k, b) in boxes.iter().enumerate() {
                n8.set_slot(first + k, *b, 0, 1);
                if first + k < 4 {
                    n4.set_slot(first + k, *b, 0, 1);
                }
            }
            assert_eq!(n8.aabb(), expected, "slots from {first}, turned {turn}");
            assert_eq!(n8.slot_aabb(first + 1), boxes[1]);
            if first == 1 {
                assert_eq!(n4.aabb(), expected);
                assert_eq!(n4.slot_aabb(2), boxes[1]);
            }
        }
        assert!(Node8::EMPTY.aabb().is_empty());
    }
}
