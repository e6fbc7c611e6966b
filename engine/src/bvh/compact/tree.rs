//! The compact 4-wide tree: the plain tree's topology in 64-byte nodes
//! (see [`super::node`]), laid out depth first with each node's inner
//! children side by side and its leaf slots' triangles side by side.

use rayon::prelude::*;

use super::node::{bfloat16, from_bfloat16, CompactNode4};
use crate::bvh::traverse::{Slot, WideTree};
use crate::bvh::wide::{self, Boxes4, Bvh4};
use crate::geometry::Aabb;

#[derive(Clone, Debug, Default)]
pub struct CompactBvh4 {
    pub(crate) nodes: Vec<CompactNode4>,
}

impl CompactBvh4 {
    /// The tree of `plain` and the order of its triangles: slot `i` of
    /// the compact tree holds slot `order[i]` of the plain one.
    ///
    /// Leaves must hold at most [`super::node::MAX_LEAF`] triangles (the
    /// build clamps `max_leaf_size`), and the tree have fewer than 2^29
    /// nodes (the walk's stack entries).
    pub(crate) fn from_plain(plain: &Bvh4) -> (Self, Vec<u32>) {
        assert!(plain.nodes.len() < 1 << 29, "a tree of at most 2^29 nodes");
        if plain.nodes.is_empty() {
            return (Self::default(), Vec::new());
        }
        let mut nodes = vec![CompactNode4::default()];
        let mut order = Vec::new();
        let mut stack = vec![(0usize, 0usize)];
        while let Some((from, to)) = stack.pop() {
            let p = &plain.nodes[from];
            let (child, first) = (nodes.len() as u32, order.len() as u32);
            let mut children = Vec::with_capacity(4);
            let mut boxes = [None; 4];
            let kinds = std::array::from_fn(|s| {
                let kind = plain.slot(from, s);
                match kind {
                    Slot::Leaf => order.extend(p.child[s]..p.child[s] + p.count[s]),
                    Slot::Inner(c) => {
                        children.push((c as usize, nodes.len()));
                        nodes.push(CompactNode4::default());
                    }
                    Slot::Empty => return kind,
                }
                boxes[s] = Some(p.slot_aabb(s));
                kind
            });
            let mut node = CompactNode4::new(child, first, kinds, p.count);
            node.set_boxes(&boxes);
            nodes[to] = node;
            stack.extend(children.into_iter().rev());
        }
        nodes.shrink_to_fit();
        (Self { nodes }, order)
    }

    pub fn nodes(&self) -> &[CompactNode4] {
        &self.nodes
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<CompactNode4>()
    }

    /// The slot boxes of every node, exactly (see [`exact_boxes`]).
    fn exact_boxes(
        &self,
        leaf_bounds: &(impl Fn(u32, u32) -> Aabb + Sync),
    ) -> Vec<[Option<Aabb>; 4]> {
        exact_boxes(
            &self.nodes,
            |n, s| match n.slot(s) {
                Slot::Inner(child) => Some(child),
                _ => None,
            },
            |n, s| (n.slot(s) == Slot::Leaf).then(|| leaf_bounds(n.leaf_first(s), n.count(s))),
        )
    }

    /// Recomputes and encodes every box (see [`exact_boxes`](Self::exact_boxes));
    /// returns the rebuild heuristic's degradation measured on the exact
    /// boxes (`leaf_area_sum` as for the plain tree), and those boxes.
    pub(crate) fn refit(
        &mut self,
        leaf_bounds: impl Fn(u32, u32) -> Aabb + Sync,
        leaf_area_sum: impl Fn(u32, u32) -> f32,
    ) -> (f32, Vec<[Option<Aabb>; 4]>) {
        let boxes = self.exact_boxes(&leaf_bounds);
        self.nodes
            .par_iter_mut()
            .with_min_len(1024)
            .zip(boxes.par_iter())
            .for_each(|(n, b)| n.set_boxes(b));
        // Both sides rounded alike, so an unchanged tree measures 0.
        let now: Vec<[f32; 5]> = self
            .ratios(&boxes, &leaf_area_sum)
            .map(|r| r.map(|x| from_bfloat16(bfloat16(x))))
            .collect();
        let built: Vec<[f32; 5]> = self.nodes.iter().map(CompactNode4::build_ratios).collect();
        let nodes = &self.nodes;
        let degradation =
            wide::refit::degradation(&built, |i| now[i], |i, s| nodes[i].count(s) > 1);
        (degradation, boxes)
    }

    /// Records the area ratios of `leaf_bounds` as the build-time reference.
    /// Returns the exact slot boxes they were measured on.
    pub(crate) fn record_build_ratios(
        &mut self,
        leaf_bounds: impl Fn(u32, u32) -> Aabb + Sync,
        leaf_area_sum: impl Fn(u32, u32) -> f32,
    ) -> Vec<[Option<Aabb>; 4]> {
        let boxes = self.exact_boxes(&leaf_bounds);
        let ratios: Vec<[f32; 5]> = self.ratios(&boxes, &leaf_area_sum).collect();
        for (n, r) in self.nodes.iter_mut().zip(ratios) {
            n.set_build_ratios(r);
        }
        boxes
    }

    fn ratios<'a>(
        &'a self,
        boxes: &'a [[Option<Aabb>; 4]],
        leaf_area_sum: &'a impl Fn(u32, u32) -> f32,
    ) -> impl Iterator<Item = [f32; 5]> + 'a {
        self.nodes.iter().zip(boxes).map(|(n, b)| {
            let slots = b.map(|b| b.unwrap_or(Aabb::EMPTY));
            let own = slots.iter().fold(Aabb::EMPTY, |u, b| u.union(*b));
            wide::refit::node_ratios(own.half_area(), slots.map(|b| b.half_area()), |s| {
                (n.count(s) > 1).then(|| leaf_area_sum(n.leaf_first(s), n.count(s)))
            })
        })
    }

    /// SAH cost of the tree as traced (decoded boxes), as
    /// [`Bvh4::sah_cost`] counts it.
    pub fn sah_cost(&self) -> f32 {
        fn slots(n: &CompactNode4) -> impl Iterator<Item = (usize, Aabb)> + '_ {
            let b = n.boxes();
            (0..4)
                .filter(move |&s| n.slot(s) != Slot::Empty)
                .map(move |s| (s, b.slot_aabb(s)))
        }
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        let root_area = slots(root)
            .fold(Aabb::EMPTY, |u, (_, b)| u.union(b))
            .half_area();
        if root_area.is_nan() || root_area <= 0.0 {
            return 0.0;
        }
        let total: f64 = self
            .nodes
            .iter()
            .map(|n| {
                let own = slots(n)
                    .fold(Aabb::EMPTY, |u, (_, b)| u.union(b))
                    .half_area() as f64;
                let leaves: f64 = slots(n)
                    .map(|(s, b)| b.half_area() as f64 * n.count(s) as f64)
                    .sum();
                own + leaves
            })
            .sum();
        (total / root_area as f64) as f32
    }
}

/// The slot boxes of every node of a compact tree of any width, exactly:
/// leaf slots from `leaf_box(node, s)`, inner ones as the union of their
/// child's, in one reverse sweep (children come after their parent).
/// `inner(node, s)` is the child of an inner slot.
pub(super) fn exact_boxes<T: Sync, const N: usize>(
    nodes: &[T],
    inner: impl Fn(&T, usize) -> Option<u32>,
    leaf_box: impl Fn(&T, usize) -> Option<Aabb> + Sync,
) -> Vec<[Option<Aabb>; N]> {
    let leaves = |n: &T| -> [Option<Aabb>; N] { std::array::from_fn(|s| leaf_box(n, s)) };
    let mut boxes: Vec<[Option<Aabb>; N]> = if nodes.len() >= 4096 {
        nodes.par_iter().with_min_len(256).map(leaves).collect()
    } else {
        nodes.iter().map(leaves).collect()
    };
    for i in (0..nodes.len()).rev() {
        for s in 0..N {
            if let Some(child) = inner(&nodes[i], s) {
                let b = boxes[child as usize].iter().flatten();
                boxes[i][s] = Some(b.fold(Aabb::EMPTY, |u, b| u.union(*b)));
            }
        }
    }
    boxes
}

impl WideTree for CompactBvh4 {
    /// First triangle slot and count.
    type Leaf = (u32, u32);

    #[inline(always)]
    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    #[inline(always)]
    fn boxes(&self, node: usize) -> Boxes4 {
        self.nodes[node].boxes()
    }

    #[inline(always)]
    fn slot(&self, node: usize, slot: usize) -> Slot {
        self.nodes[node].slot(slot)
    }

    #[inline(always)]
    fn leaf(&self, node: usize, slot: usize) -> (u32, u32) {
        let n = &self.nodes[node];
        (n.leaf_first(slot), n.count(slot))
    }

    /// Kept children are asked for as they are pushed, so their lines
    /// arrive while the nearest is handled: on a 2M hall the compact
    /// tree's incoherent rate went from 0.7x the plain one's to 1x.
    #[inline(always)]
    fn prefetch(&self, node: usize) {
        crate::bvh::traverse::prefetch(&self.nodes[node]);
    }
}
