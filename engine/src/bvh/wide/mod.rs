//! The 4-wide BVH that meshes are traced with, collapsed from a binary
//! build (see [`super::build`]), and the 8-wide one rays walk where the
//! CPU has AVX ([`Bvh8`]).
//!
//! A binary tree tests one box per step; a 4-wide tree tests four with one
//! SIMD instruction per slab and has about a third of the nodes, so
//! incoherent rays take far fewer dependent loads. The binary tree stays the
//! build intermediate and the top level of scenes, where nodes are few.

mod collapse;
mod eight;
pub(crate) mod refit;

pub use eight::{Bvh8, Node8};

use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec4;

use super::Bvh;
use crate::geometry::Aabb;

/// Four child boxes in structure-of-arrays form, their links and counts.
///
/// 128 bytes, two cache lines: six `Vec4` hold the minima and maxima of the
/// four boxes per axis, so the slab test for all four children is six
/// subtractions and multiplies on whole registers. A slot is a leaf when
/// its count is non-zero (`child` is then its first leaf slot), an inner
/// node when its count is zero, and empty when its box is empty (never hit).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Node4 {
    pub(crate) boxes: Boxes4,
    /// First leaf slot (leaf) or child node (inner); `u32::MAX` when empty.
    pub child: [u32; 4],
    /// Primitives in a leaf slot; 0 for inner and empty slots.
    pub count: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<Node4>() == 128);

/// Four boxes in structure-of-arrays form: per axis, the four minima and
/// the four maxima. What every node test of a 4-wide walk reads, whether
/// the tree stores them so or decodes them (see [`super::compact`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Boxes4 {
    pub(crate) lo: [Vec4; 3],
    pub(crate) hi: [Vec4; 3],
}

impl Boxes4 {
    pub(crate) const EMPTY: Self = Self {
        lo: [Vec4::INFINITY; 3],
        hi: [Vec4::NEG_INFINITY; 3],
    };

    /// The six planes as one array, minima per axis then maxima: a ray
    /// picks its near and far plane of each axis by an index fixed per ray
    /// (as Embree does), not by a branch per node.
    #[inline(always)]
    pub(crate) fn planes(&self) -> &[Vec4; 6] {
        // SAFETY: `repr(C)` lays two `[Vec4; 3]` out as six `Vec4`, with
        // no padding and the same alignment.
        unsafe { &*(self as *const Self).cast::<[Vec4; 6]>() }
    }

    pub fn slot_aabb(&self, slot: usize) -> Aabb {
        // Through array views: glam indexes a `Vec4` by a jump table, a
        // branch per access that a refit's passes do not predict.
        let plane = |rows: &[Vec4; 3], axis: usize| -> f32 {
            let row: &[f32; 4] = rows[axis].as_ref();
            row[slot]
        };
        Aabb::new(
            glam::Vec3A::new(plane(&self.lo, 0), plane(&self.lo, 1), plane(&self.lo, 2)),
            glam::Vec3A::new(plane(&self.hi, 0), plane(&self.hi, 1), plane(&self.hi, 2)),
        )
    }

    pub(crate) fn set_slot_aabb(&mut self, slot: usize, b: Aabb) {
        // Through arrays, as `slot_aabb`.
        let (min, max) = (b.min.to_array(), b.max.to_array());
        for axis in 0..3 {
            let (lo, hi): (&mut [f32; 4], &mut [f32; 4]) =
                (self.lo[axis].as_mut(), self.hi[axis].as_mut());
            lo[slot] = min[axis];
            hi[slot] = max[axis];
        }
    }

    /// Half the surface area of each slot, as [`Aabb::half_area`] computes
    /// it (the same operations in the same order, so the same bits; empty
    /// slots 0), four at a time.
    pub(crate) fn half_areas(&self) -> [f32; 4] {
        let [x, y, z] = std::array::from_fn(|a| (self.hi[a] - self.lo[a]).max(Vec4::ZERO));
        (x * y + y * z + z * x).to_array()
    }

    /// The union of the four slots, plane by plane.
    pub fn union(&self) -> Aabb {
        Aabb::new(
            glam::Vec3A::from_array(self.lo.map(Vec4::min_element)),
            glam::Vec3A::from_array(self.hi.map(Vec4::max_element)),
        )
    }
}

pub(crate) const EMPTY_NODE: Node4 = Node4 {
    boxes: Boxes4::EMPTY,
    child: [u32::MAX; 4],
    count: [0; 4],
};

impl Node4 {
    pub fn slot_aabb(&self, slot: usize) -> Aabb {
        self.boxes.slot_aabb(slot)
    }

    pub(crate) fn set_slot_aabb(&mut self, slot: usize, b: Aabb) {
        self.boxes.set_slot_aabb(slot, b)
    }

    /// The union of the four slots: this node's own box.
    pub fn aabb(&self) -> Aabb {
        self.boxes.union()
    }

    pub fn is_leaf_slot(&self, slot: usize) -> bool {
        self.count[slot] != 0
    }

    pub fn is_inner_slot(&self, slot: usize) -> bool {
        self.count[slot] == 0 && self.child[slot] != u32::MAX
    }

    /// Leaf slots as `(first, count)`.
    pub fn leaves(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (0..4)
            .filter(|&s| self.is_leaf_slot(s))
            .map(|s| (self.child[s], self.count[s]))
    }

    /// Inner children.
    pub fn inner_children(&self) -> impl Iterator<Item = usize> + '_ {
        (0..4)
            .filter(|&s| self.is_inner_slot(s))
            .map(|s| self.child[s] as usize)
    }
}

/// A 4-wide BVH; leaf slots index the same primitive order as the binary
/// tree it was collapsed from. Children come after their parent.
#[derive(Clone, Debug, Default)]
pub struct Bvh4 {
    pub(crate) nodes: Vec<Node4>,
    /// Area ratios at build time: per node, its own ratio then one per slot
    /// (see [`super::quality`]).
    pub(crate) build_ratios: Vec<[f32; 5]>,
    /// Distinct for every build and kept by refits and clones: what lets a
    /// BVTT front (see [`super::traverse::front`]) tell that the tree it
    /// was made on has been rebuilt.
    pub(crate) topology: u64,
    /// Distinct for every build and every refit: what lets boxes fitted on
    /// the tree's topology (an OBB tree) tell that it has moved since.
    pub(crate) pose: u64,
}

/// A process-wide serial number: for topologies and poses.
pub(crate) fn next_id() -> u64 {
    static IDS: AtomicU64 = AtomicU64::new(1);
    IDS.fetch_add(1, Ordering::Relaxed)
}

impl Bvh4 {
    /// Collapses a binary tree into the 4-wide tree over the same leaves
    /// with the least node area (see [`collapse`]).
    pub fn from_binary(bin: &Bvh) -> Self {
        let nodes = collapse::collapse_tree(&bin.nodes);
        let mut wide = Self {
            nodes,
            build_ratios: Vec::new(),
            topology: next_id(),
            pose: next_id(),
        };
        wide.build_ratios = vec![[1.0; 5]; wide.nodes.len()];
        wide
    }

    pub fn nodes(&self) -> &[Node4] {
        &self.nodes
    }

    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map(Node4::aabb).unwrap_or(Aabb::EMPTY)
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node4>() + self.build_ratios.capacity() * 20
    }

    /// Depth of the deepest wide node (the root has depth 0).
    pub fn depth(&self) -> usize {
        let mut depth = vec![0usize; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            for c in n.inner_children() {
                depth[c] = depth[i] + 1;
            }
        }
        depth.into_iter().max().unwrap_or(0)
    }

    /// SAH cost of the wide tree relative to a ray that hits the root,
    /// unit cost per node visited and per primitive tested:
    /// `(sum(A(node)) + sum(A(leaf) * n(leaf))) / A(root)`.
    pub fn sah_cost(&self) -> f32 {
        let root = self.bounds().half_area();
        if root.is_nan() || root <= 0.0 {
            return 0.0;
        }
        let total: f64 = self
            .nodes
            .iter()
            .map(|n| {
                let leaves: f64 = (0..4)
                    .filter(|&s| n.is_leaf_slot(s))
                    .map(|s| n.slot_aabb(s).half_area() as f64 * n.count[s] as f64)
                    .sum();
                n.aabb().half_area() as f64 + leaves
            })
            .sum();
        (total / root as f64) as f32
    }
}

/// A wide node as the collapse fills it and the refit updates it.
trait WideNode: Copy + Send {
    const WIDTH: usize;
    const EMPTY: Self;
    /// Sets slot `slot`: its box, and its first leaf slot and count (a
    /// leaf) or its child node and 0 (inner).
    fn set_slot(&mut self, slot: usize, aabb: Aabb, child: u32, count: u32);
    fn set_slot_aabb(&mut self, slot: usize, aabb: Aabb);
    /// The union of the slots' boxes.
    fn aabb(&self) -> Aabb;
    /// A leaf slot's first leaf slot and count.
    fn leaf(&self, slot: usize) -> Option<(u32, u32)>;
    /// An inner slot's child node.
    fn inner(&self, slot: usize) -> Option<usize>;
}

impl WideNode for Node4 {
    const WIDTH: usize = 4;
    const EMPTY: Self = EMPTY_NODE;

    fn set_slot(&mut self, slot: usize, aabb: Aabb, child: u32, count: u32) {
        self.set_slot_aabb(slot, aabb);
        self.child[slot] = child;
        self.count[slot] = count;
    }

    fn set_slot_aabb(&mut self, slot: usize, aabb: Aabb) {
        self.boxes.set_slot_aabb(slot, aabb)
    }

    fn aabb(&self) -> Aabb {
        Node4::aabb(self)
    }

    fn leaf(&self, slot: usize) -> Option<(u32, u32)> {
        self.is_leaf_slot(slot)
            .then(|| (self.child[slot], self.count[slot]))
    }

    fn inner(&self, slot: usize) -> Option<usize> {
        self.is_inner_slot(slot).then(|| self.child[slot] as usize)
    }
}
