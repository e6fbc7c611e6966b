//! Refitting: after geometry moves, every box is recomputed bottom-up while
//! the topology stays. O(n), and the leaves are refitted in parallel.

use rayon::prelude::*;

use super::Node;
use crate::geometry::Aabb;

/// Mean growth of the per-node area ratio, since the build, above which a
/// refit hierarchy is rebuilt: the 40% of the dissertation, section 4.1.5.
pub const DEFAULT_REBUILD_THRESHOLD: f32 = 0.4;

/// Below this many nodes the leaf pass runs on one thread.
const PARALLEL_NODES: usize = 16 * 1024;

/// Recomputes all boxes: leaves from `leaf_bounds(first, count)`, inner
/// nodes as the union of their children. Children come after their parent,
/// so one reverse sweep visits children first.
pub(crate) fn refit_nodes(nodes: &mut [Node], leaf_bounds: impl Fn(u32, u32) -> Aabb + Sync) {
    let leaf = |n: &mut Node| {
        if n.is_leaf() {
            n.set_aabb(leaf_bounds(n.first(), n.count()));
        }
    };
    if nodes.len() >= PARALLEL_NODES {
        nodes.par_iter_mut().with_min_len(1024).for_each(leaf);
    } else {
        nodes.iter_mut().for_each(leaf);
    }
    for i in (0..nodes.len()).rev() {
        let n = nodes[i];
        if !n.is_leaf() {
            let l = n.first() as usize;
            nodes[i].set_aabb(nodes[l].aabb().union(nodes[l + 1].aabb()));
        }
    }
}
