//! Refit and the rebuild heuristic's area ratios on the wide tree.
//!
//! The dissertation (section 4.1.5) measures, for each inner node, its area
//! over the sum of its children's areas: a node whose children drift apart
//! grows while they do not, so the ratio rises. It uses one primitive per
//! leaf; our leaves hold several, so a leaf's ratio is its area over the sum
//! of its primitives' box areas, which is what the nodes above it would
//! measure. Leaves with one primitive always measure 1 and are left out.

use rayon::prelude::*;

use super::{Bvh4, Node4, WideNode};
use crate::geometry::Aabb;

/// Below this many nodes a pass over them (the refit's leaves, the
/// degradation) runs on one thread.
pub(crate) const PARALLEL_NODES: usize = 4 * 1024;

/// Nodes per partial sum of the degradation: fixed chunks summed in order,
/// so its rounding, and the rebuild decision it drives, do not depend on
/// how rayon splits the work.
const DEGRADATION_CHUNK: usize = 1024;

/// Recomputes every box of a wide tree: leaf slots from
/// `leaf_bounds(first, count)` (on rayon: the triangles are most of the
/// work), then inner slots as the union of their child's slots.
pub(super) fn refit_boxes<N: WideNode>(
    nodes: &mut [N],
    leaf_bounds: impl Fn(u32, u32) -> Aabb + Sync,
) {
    refit_leaves(nodes, &mut vec![(); nodes.len()], |n: &mut N, _| {
        for s in 0..N::WIDTH {
            if let Some((first, count)) = n.leaf(s) {
                n.set_slot_aabb(s, leaf_bounds(first, count));
            }
        }
    });
    refit_inner(nodes);
}

/// `leaves(node, item)` on every node and its item of `with`, on rayon for
/// large trees.
pub(super) fn refit_leaves<N: WideNode, W: Send>(
    nodes: &mut [N],
    with: &mut [W],
    leaves: impl Fn(&mut N, &mut W) + Sync,
) {
    if nodes.len() >= PARALLEL_NODES {
        nodes
            .par_iter_mut()
            .zip(with)
            .with_min_len(256)
            .for_each(|(n, w)| leaves(n, w));
    } else {
        for (n, w) in nodes.iter_mut().zip(with) {
            leaves(n, w);
        }
    }
}

/// Inner slots as the union of their child's slots, in one reverse sweep
/// (children come after their parent).
pub(super) fn refit_inner<N: WideNode>(nodes: &mut [N]) {
    for i in (0..nodes.len()).rev() {
        for s in 0..N::WIDTH {
            if let Some(child) = nodes[i].inner(s) {
                let b = nodes[child].aabb();
                nodes[i].set_slot_aabb(s, b);
            }
        }
    }
}

/// Ratio of a box area to the sum of the areas it bounds; 1 when both are 0.
#[inline]
fn ratio(area: f32, parts: f32) -> f32 {
    if parts > 0.0 {
        (area / parts).min(1e6)
    } else if area > 0.0 {
        1e6
    } else {
        1.0
    }
}

impl Bvh4 {
    /// Recomputes every box: leaf slots from `leaf_bounds(first, count)`,
    /// inner slots as the union of their child's slots, in one reverse sweep
    /// (children come after their parent).
    pub(crate) fn refit(&mut self, leaf_bounds: impl Fn(u32, u32) -> Aabb + Sync) {
        self.pose = super::next_id();
        refit_boxes(&mut self.nodes, leaf_bounds);
    }

    /// Area ratios of a node and of its leaf slots (see [`node_ratios`]),
    /// `leaf_area_sum(slot)` the sum of a leaf slot's primitives' box areas.
    fn ratios(n: &Node4, leaf_area_sum: impl Fn(usize) -> f32) -> [f32; 5] {
        node_ratios(n.aabb().half_area(), n.boxes.half_areas(), |s| {
            (n.is_leaf_slot(s) && n.count[s] > 1).then(|| leaf_area_sum(s))
        })
    }

    /// Records the current ratios as the build-time reference.
    pub(crate) fn record_build_ratios(&mut self, leaf_area_sum: impl Fn(u32, u32) -> f32) {
        self.build_ratios = self
            .nodes
            .iter()
            .map(|n| Self::ratios(n, |s| leaf_area_sum(n.child[s], n.count[s])))
            .collect();
    }

    /// Refits, as [`refit`](Self::refit), from `leaf(first, count)`, a leaf
    /// slot's box and the sum of its primitives' box areas, and returns the
    /// rebuild heuristic on the new boxes (see [`degradation`]): one read
    /// of each leaf's primitives serves both.
    pub(crate) fn refit_measured(&mut self, leaf: impl Fn(u32, u32) -> (Aabb, f32) + Sync) -> f32 {
        self.pose = super::next_id();
        let mut leaf_areas = vec![[0.0f32; 4]; self.nodes.len()];
        refit_leaves(&mut self.nodes, &mut leaf_areas, |n: &mut Node4, areas| {
            for (s, area) in areas.iter_mut().enumerate() {
                if n.is_leaf_slot(s) {
                    let b;
                    (b, *area) = leaf(n.child[s], n.count[s]);
                    n.set_slot_aabb(s, b);
                }
            }
        });
        refit_inner(&mut self.nodes);
        let nodes = &self.nodes;
        degradation(
            &self.build_ratios,
            |i| Self::ratios(&nodes[i], |s| leaf_areas[i][s]),
            |i, s| nodes[i].is_leaf_slot(s) && nodes[i].count[s] > 1,
        )
    }
}

/// Area ratios of a node and of its leaf slots: the node's box over the sum
/// of its slots' boxes (half areas `own` and `slots`), and a leaf's box over
/// `leaf_parts(slot)`, the sum of its primitives' box areas (`None`: inner,
/// empty or single, which read 1).
pub(crate) fn node_ratios(
    own: f32,
    slots: [f32; 4],
    leaf_parts: impl Fn(usize) -> Option<f32>,
) -> [f32; 5] {
    let mut r = [1.0; 5];
    r[0] = ratio(own, slots.iter().sum());
    for s in 0..4 {
        if let Some(parts) = leaf_parts(s) {
            r[s + 1] = ratio(slots[s], parts);
        }
    }
    r
}

/// The rebuild heuristic (dissertation, section 4.1.5): the mean growth of
/// the area ratios since the build, over nodes and over the leaf slots
/// `counted(node, slot)` names (those with several primitives), `now(node)`
/// giving a node's ratios. 0 under translation; large when neighbours
/// part. Large trees measure on rayon: five ratios per node.
pub(crate) fn degradation(
    built: &[[f32; 5]],
    now: impl Fn(usize) -> [f32; 5] + Sync,
    counted: impl Fn(usize, usize) -> bool + Sync,
) -> f32 {
    let growth = |i: usize| {
        let (now, built) = (now(i), &built[i]);
        let mut sum = f64::from(now[0] - built[0]);
        let mut count = 1usize;
        for s in 0..4 {
            if counted(i, s) {
                sum += f64::from(now[s + 1] - built[s + 1]);
                count += 1;
            }
        }
        (sum, count)
    };
    let add = |a: (f64, usize), b: (f64, usize)| (a.0 + b.0, a.1 + b.1);
    let chunk = |c: usize| {
        let end = ((c + 1) * DEGRADATION_CHUNK).min(built.len());
        (c * DEGRADATION_CHUNK..end).map(growth).fold((0.0, 0), add)
    };
    let chunks = built.len().div_ceil(DEGRADATION_CHUNK);
    let partial: Vec<(f64, usize)> = if built.len() >= PARALLEL_NODES {
        (0..chunks).into_par_iter().map(chunk).collect()
    } else {
        (0..chunks).map(chunk).collect()
    };
    let (sum, count) = partial.into_iter().fold((0.0, 0), add);
    if count == 0 {
        0.0
    } else {
        (sum / count as f64) as f32
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use super::*;

    /// Every node grew by 0.5, and every other node's first slot, counted,
    /// by 2: the mean over 1.5 n terms is exactly (0.5 n + 2 n/2) / 1.5 n = 1.
    fn half_counted(n: usize) -> f32 {
        let built = vec![[1.0; 5]; n];
        degradation(
            &built,
            |_| [1.5, 3.0, 1.0, 1.0, 1.0],
            |i, s| s == 0 && i % 2 == 0,
        )
    }

    #[test]
    fn degradation_is_the_mean_growth_on_one_thread_and_on_rayon() {
        assert_eq!(half_counted(100), 1.0);
        let large = 3 * PARALLEL_NODES / 2;
        assert_eq!(large % 2, 0);
        assert_eq!(half_counted(large), 1.0);
        assert_eq!(half_counted(0), 0.0);
    }

    /// Four slots' half areas at a time are each slot's
    /// [`Aabb::half_area`], bit for bit; an empty slot's is 0.
    #[test]
    fn four_slots_half_areas_are_each_slots() {
        let mut n4 = super::super::EMPTY_NODE;
        let boxes = [
            Aabb::new(Vec3A::new(-3.0, 0.5, 2.0), Vec3A::new(-1.0, 4.1, 2.7)),
            Aabb::new(Vec3A::new(1e6, -2.0, -7.0), Vec3A::new(2e6, -1.0, 9.3)),
            Aabb::new(Vec3A::splat(0.1), Vec3A::new(0.1, 0.2, 0.1)),
        ];
        for (s, b) in [0, 1, 3].into_iter().zip(boxes) {
            n4.set_slot(s, b, 0, 1);
        }
        let areas = n4.boxes.half_areas();
        for (s, area) in areas.iter().enumerate() {
            assert_eq!(
                area.to_bits(),
                n4.slot_aabb(s).half_area().to_bits(),
                "slot {s}"
            );
        }
        assert_eq!(areas[2], 0.0);
        assert!(areas[1] > 1e6);
    }
}
