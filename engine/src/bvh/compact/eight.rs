//! The compact layout's 8-wide tree, which rays walk where the CPU has
//! AVX: the plain [`Bvh8`]'s topology with its child boxes on the 8-bit
//! grid of [`super::node`].
//!
//! 96 bytes a node where the plain 8-wide node takes 256: an origin and a
//! power-of-two step per axis (15 bytes) and a byte per child plane (48),
//! all a ray's box test reads, in the first 64; then a link per slot, a
//! child node or a leaf's first triangle (in the compact order) with its
//! count in the top four bits. Links stay per slot rather than by base
//! index as in the 4-wide node: the plain 8-wide tree groups leaves that
//! the compact triangle order (laid out for the 4-wide tree) does not keep
//! side by side. Trees with a leaf of more than 15 triangles, or 2^28
//! triangles or nodes, have none (rays walk the 4-wide tree).

use rayon::prelude::*;

use super::node::{decode, encode_grid, step};
use super::tree::{exact_boxes, CompactBvh4};
use crate::bvh::traverse::Slot;
use crate::bvh::wide::Bvh8;
use crate::geometry::Aabb;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct CompactNode8 {
    /// The grid's origin: the minimum of the slots' boxes.
    pub(crate) origin: [f32; 3],
    /// Per axis, the grid step `2^e` stored as the biased exponent `e + 127`.
    pub(crate) exponent: [u8; 3],
    /// Unused: the grid bytes start at byte 16.
    _pad: u8,
    /// Grid coordinates of the slots' minima (x, y, z) and maxima (x, y, z).
    pub(crate) q: [[u8; 8]; 6],
    /// Per slot: `count << 28 | first` for a leaf, the child node's index
    /// for an inner slot, `u32::MAX` for an empty one.
    pub(crate) link: [u32; 8],
}

const _: () = assert!(std::mem::size_of::<CompactNode8>() == 96);
const _: () = assert!(std::mem::offset_of!(CompactNode8, q) == 16);

/// Where a link's leaf count starts.
pub(crate) const COUNT_SHIFT: u32 = 28;
/// The largest leaf, first triangle and child node a link can name.
const MAX_COUNT: u32 = (1 << (32 - COUNT_SHIFT)) - 1;
const MAX_INDEX: u32 = (1 << COUNT_SHIFT) - 2;

impl CompactNode8 {
    const EMPTY: Self = Self {
        origin: [0.0; 3],
        exponent: [1; 3],
        _pad: 0,
        q: [
            [u8::MAX; 8],
            [u8::MAX; 8],
            [u8::MAX; 8],
            [0; 8],
            [0; 8],
            [0; 8],
        ],
        link: [u32::MAX; 8],
    };

    /// What slot `slot` holds.
    #[inline(always)]
    pub fn slot(&self, slot: usize) -> Slot {
        let link = self.link[slot];
        if link == u32::MAX {
            Slot::Empty
        } else if link >> COUNT_SHIFT != 0 {
            Slot::Leaf
        } else {
            Slot::Inner(link)
        }
    }

    /// Leaf slot `slot`'s first triangle and count.
    #[inline(always)]
    pub fn leaf(&self, slot: usize) -> (u32, u32) {
        let link = self.link[slot];
        (link & ((1 << COUNT_SHIFT) - 1), link >> COUNT_SHIFT)
    }

    /// Slot `slot`'s box as decoded; empty slots decode to empty boxes.
    pub fn slot_aabb(&self, slot: usize) -> Aabb {
        let plane = |row: usize, axis: usize| {
            decode(
                self.origin[axis],
                self.q[row][slot],
                step(self.exponent[axis]),
            )
        };
        Aabb::new(
            glam::Vec3A::new(plane(0, 0), plane(1, 1), plane(2, 2)),
            glam::Vec3A::new(plane(3, 0), plane(4, 1), plane(5, 2)),
        )
    }

    fn set_boxes(&mut self, slots: &[Option<Aabb>; 8]) {
        (self.origin, self.exponent, self.q) = encode_grid(slots);
    }
}

/// The compact 8-wide tree, nodes in the plain one's order (children
/// after their parent).
#[derive(Clone, Debug, Default)]
pub struct CompactBvh8 {
    pub(crate) nodes: Vec<CompactNode8>,
}

impl CompactBvh8 {
    /// The tree of `plain` over triangles reordered: plain slot `s` is
    /// compact slot `compact_slot[s]`, each leaf's triangles kept side by
    /// side and in order, as `four` lays them out (its exact slot boxes
    /// `four_boxes` give the leaves'). `None` where a link cannot name a
    /// leaf or node (see the module).
    pub(crate) fn from_plain(
        plain: &Bvh8,
        compact_slot: &[u32],
        four: &CompactBvh4,
        four_boxes: &[[Option<Aabb>; 4]],
    ) -> Option<Self> {
        let too_many = |n: usize| n as u64 > u64::from(MAX_INDEX);
        if too_many(compact_slot.len()) || too_many(plain.nodes().len()) {
            return None;
        }
        let mut nodes = Vec::with_capacity(plain.nodes().len());
        for n in plain.nodes() {
            let mut c = CompactNode8::EMPTY;
            for s in 0..8 {
                c.link[s] = match n.slot(s) {
                    Slot::Leaf if n.count[s] > MAX_COUNT => return None,
                    Slot::Leaf => n.count[s] << COUNT_SHIFT | compact_slot[n.child[s] as usize],
                    Slot::Inner(child) => child,
                    Slot::Empty => u32::MAX,
                };
            }
            nodes.push(c);
        }
        let mut tree = Self { nodes };
        tree.refit_from(four, four_boxes);
        Some(tree)
    }

    pub fn nodes(&self) -> &[CompactNode8] {
        &self.nodes
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<CompactNode8>()
    }

    /// Recomputes and encodes every box, after `four` (of the same
    /// triangles) was refitted to the exact slot boxes `four_boxes`: the
    /// leaves are the same, so their boxes are copied from there.
    pub(crate) fn refit_from(&mut self, four: &CompactBvh4, four_boxes: &[[Option<Aabb>; 4]]) {
        // Each leaf of the 4-wide tree by its first triangle.
        let triangles = four
            .nodes()
            .iter()
            .flat_map(|n| (0..4).map(|s| n.leaf_first(s) + n.count(s)))
            .max()
            .unwrap_or(0);
        let mut by_first = vec![u32::MAX; triangles as usize];
        for (i, n) in four.nodes().iter().enumerate() {
            for s in (0..4).filter(|&s| n.slot(s) == Slot::Leaf) {
                by_first[n.leaf_first(s) as usize] = (4 * i + s) as u32;
            }
        }
        self.encode(|n, s| {
            if n.slot(s) != Slot::Leaf {
                return None;
            }
            let from = by_first[n.leaf(s).0 as usize] as usize;
            four_boxes[from / 4][from % 4]
        });
    }

    /// Encodes every node's boxes from its leaves' exact boxes,
    /// `leaf_box(node, s)` for its leaf slots.
    fn encode(&mut self, leaf_box: impl Fn(&CompactNode8, usize) -> Option<Aabb> + Sync) {
        let inner = |n: &CompactNode8, s| match n.slot(s) {
            Slot::Inner(child) => Some(child),
            _ => None,
        };
        let boxes: Vec<[Option<Aabb>; 8]> = exact_boxes(&self.nodes, inner, leaf_box);
        self.nodes
            .par_iter_mut()
            .with_min_len(1024)
            .zip(boxes.par_iter())
            .for_each(|(n, b)| n.set_boxes(b));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::ray_queries::LeafTriangles;
    use crate::bvh::traverse::ray8::avx_available;
    use crate::bvh::{BuildOptions, CompactBvh};
    use crate::geometry::{shapes, TriangleMesh};
    use glam::Vec3;

    /// Every triangle lies in the decoded box of each slot above it, every
    /// triangle is reached once, and empty slots decode empty.
    fn assert_boxes_hold_the_triangles_beneath(bvh: &CompactBvh) {
        let tree = bvh.eight().expect("built where the CPU has AVX");
        let holds = |outer: &Aabb, inner: Aabb| {
            outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all()
        };
        let mut reached = vec![0; bvh.triangle_count()];
        let mut stack = vec![(0u32, Vec::<Aabb>::new())];
        while let Some((node, above)) = stack.pop() {
            let n = &tree.nodes()[node as usize];
            for s in 0..8 {
                let mut boxes = above.clone();
                boxes.push(n.slot_aabb(s));
                match n.slot(s) {
                    Slot::Leaf => {
                        let (first, count) = n.leaf(s);
                        for t in first..first + count {
                            let [a, b, c] = bvh.corners(t);
                            let triangle = Aabb::of_triangle(a, b, c);
                            assert!(boxes.iter().all(|b| holds(b, triangle)));
                            reached[t as usize] += 1;
                        }
                    }
                    Slot::Inner(child) => stack.push((child, boxes)),
                    Slot::Empty => {
                        let b = n.slot_aabb(s);
                        assert!(b.min.cmpgt(b.max).any(), "{b:?}");
                    }
                }
            }
        }
        assert!(reached.iter().all(|&r| r == 1));
    }

    /// As built, and after a refit that moved every vertex.
    #[test]
    fn decoded_boxes_hold_the_triangles_beneath_after_builds_and_refits() {
        if !avx_available() {
            eprintln!("skipped: no AVX, so no 8-wide compact tree");
            return;
        }
        let mesh = shapes::icosphere(3.0, 5);
        let mut bvh = CompactBvh::build(&mesh, &BuildOptions::default());
        assert_boxes_hold_the_triangles_beneath(&bvh);
        let moved: Vec<Vec3> = mesh
            .positions()
            .iter()
            .map(|p| Vec3::new(p.x * 2.0 + p.z * p.z, p.y - 0.5 * p.x, p.z * 0.25))
            .collect();
        let moved = TriangleMesh::new(moved, mesh.triangles().to_vec()).unwrap();
        bvh.refit(&moved).unwrap();
        assert_boxes_hold_the_triangles_beneath(&bvh);
    }
}
