//! A binary tree collapsed into a wide one with the least surface area of
//! wide nodes: which descendants of each binary node fill the slots of its
//! wide node is chosen by dynamic programming over the binary tree
//! (Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs
//! Through Compressed Wide BVHs", HPG 2017).
//!
//! The leaves stay the binary tree's, so every wide tree of one build has
//! the same leaves and a leaf's box can be copied between them. A ray's
//! expected node visits are the areas of the wide nodes over the root's,
//! so the least total area is the least SAH cost; leaf costs are the same
//! in every collapse. The greedy collapse this replaces (open the largest
//! inner child until the node is full) left half the 8-wide nodes of a
//! mesh with two slots, a binary node whose children are leaves becoming
//! a node of its own: here such a node's leaves fill its parent's slots
//! wherever that saves area. On the bunny the 8-wide tree has half the
//! nodes (6.6 slots a node instead of 4.0).

use std::sync::atomic::{AtomicU64, Ordering};

use super::WideNode;
use crate::bvh::Node;

/// Subtrees at least this deep below the root are planned on one thread.
const PARALLEL_DEPTH: u32 = 4;

/// The wide nodes of binary tree `bin` (children after their parent), the
/// root first and every child after its parent.
pub(super) fn collapse_tree<N: WideNode>(bin: &[Node]) -> Vec<N> {
    let Some(root) = bin.first() else {
        return Vec::new();
    };
    if root.is_leaf() {
        let mut n = N::EMPTY;
        n.set_slot(0, root.aabb(), root.first(), root.count());
        return vec![n];
    }
    let plan = Plan {
        bin,
        width: N::WIDTH,
        shares: (0..bin.len()).map(|_| AtomicU64::new(0)).collect(),
    };
    plan.cost(0, 0);
    let mut nodes = Vec::with_capacity(bin.len() / (N::WIDTH - 1) + 1);
    plan.emit(0, &mut nodes);
    nodes
}

/// The dynamic program over one binary tree.
///
/// `cost(n)[i - 1]` is the least total area of the wide nodes made below
/// binary node `n` when `n`'s subtree fills at most `i` slots of its
/// parent: as one slot (a leaf, or an inner node of its own whose slots
/// its children share), or as slots its two children share. `shares[n]`
/// keeps the choice: byte `i - 1` (for `i >= 2`) is how many of the `i`
/// slots the left child fills, 0 for one slot; byte 0, where the choice is
/// always one slot, how many of its own wide node's slots the left child
/// fills.
struct Plan<'a> {
    bin: &'a [Node],
    width: usize,
    shares: Vec<AtomicU64>,
}

impl Plan<'_> {
    fn cost(&self, n: usize, depth: u32) -> [f32; 8] {
        let width = self.width;
        let node = &self.bin[n];
        if node.is_leaf() {
            return [0.0; 8];
        }
        let l = node.first() as usize;
        debug_assert!(l > n, "a child before its parent");
        if self.bin[l].is_leaf() && self.bin[l + 1].is_leaf() {
            // Its own node of two leaves, or the two leaves as slots.
            self.shares[n].store(
                u64::from_le_bytes([1, 1, 1, 1, 1, 1, 1, 1]),
                Ordering::Relaxed,
            );
            let mut cost = [0.0; 8];
            cost[0] = node.aabb().half_area().max(0.0);
            return cost;
        }
        let (left, right) = if depth < PARALLEL_DEPTH {
            rayon::join(|| self.cost(l, depth + 1), || self.cost(l + 1, depth + 1))
        } else {
            (self.cost(l, depth + 1), self.cost(l + 1, depth + 1))
        };
        // `split[j - 1]`: the children in at most `j` slots, the least cost
        // and the left child's share (one slot each where every cost is
        // infinite); each computed once, `j = width` also for its own node.
        let split: [(f32, usize); 8] = std::array::from_fn(|i| {
            let j = if i < width { i + 1 } else { 0 };
            (1..j)
                .map(|k| (left[k - 1] + right[j - k - 1], k))
                .fold((f32::INFINITY, 1), |a, b| if b.0 < a.0 { b } else { a })
        });
        let (inside, own) = split[width - 1];
        let mut cost = [f32::INFINITY; 8];
        // `how[i - 1]`: the left child's share of `i` slots, 0 for one slot.
        let mut how = [0u8; 8];
        cost[0] = node.aabb().half_area().max(0.0) + inside;
        for i in 2..=width {
            let (split, k) = split[i - 1];
            (cost[i - 1], how[i - 1]) = if split < cost[i - 2] {
                (split, k as u8)
            } else {
                (cost[i - 2], how[i - 2])
            };
        }
        how[0] = own as u8;
        self.shares[n].store(u64::from_le_bytes(how), Ordering::Relaxed);
        cost
    }

    fn share(&self, n: usize, i: usize) -> usize {
        self.shares[n].load(Ordering::Relaxed).to_le_bytes()[i - 1] as usize
    }

    /// Emits the wide node of binary inner node `n` and its inner
    /// descendants; returns its index.
    fn emit<N: WideNode>(&self, n: usize, out: &mut Vec<N>) -> u32 {
        let index = out.len();
        out.push(N::EMPTY);
        let mut slots = Slots::default();
        let (l, own) = (self.bin[n].first() as usize, self.share(n, 1));
        self.slots(l, own, &mut slots);
        self.slots(l + 1, self.width - own, &mut slots);
        let mut node = N::EMPTY;
        for (slot, &k) in slots.nodes[..slots.len].iter().enumerate() {
            let b = &self.bin[k];
            let (child, count) = if b.is_leaf() {
                (b.first(), b.count())
            } else {
                (self.emit(k, out), 0)
            };
            node.set_slot(slot, b.aabb(), child, count);
        }
        out[index] = node;
        index as u32
    }

    /// The binary nodes that fill the at most `i` slots subtree `n` fills.
    fn slots(&self, n: usize, i: usize, out: &mut Slots) {
        let k = if i >= 2 { self.share(n, i) } else { 0 };
        if k == 0 {
            out.nodes[out.len] = n;
            out.len += 1;
            return;
        }
        let l = self.bin[n].first() as usize;
        self.slots(l, k, out);
        self.slots(l + 1, i - k, out);
    }
}

/// The binary nodes filling one wide node's slots, without an allocation
/// per node.
#[derive(Default)]
struct Slots {
    nodes: [usize; 8],
    len: usize,
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::bvh::wide::{Node4, Node8};
    use crate::bvh::{BuildOptions, Bvh};
    use crate::geometry::Aabb;

    /// The least total area of wide nodes over every way to collapse
    /// `bin`: every subset of its inner nodes (the root always in) whose
    /// nodes each have at most `width` slots, counted by brute force.
    fn least_area(bin: &[Node], width: usize) -> f64 {
        let inner: Vec<usize> = (0..bin.len()).filter(|&n| !bin[n].is_leaf()).collect();
        assert_eq!(inner[0], 0);
        fn slots(bin: &[Node], wide: &[bool], n: usize) -> usize {
            let first = bin[n].first() as usize;
            [first, first + 1]
                .iter()
                .map(|&c| {
                    if bin[c].is_leaf() || wide[c] {
                        1
                    } else {
                        slots(bin, wide, c)
                    }
                })
                .sum()
        }
        let mut best = f64::INFINITY;
        for mask in 0..1u64 << (inner.len() - 1) {
            let mut wide = vec![false; bin.len()];
            wide[0] = true;
            for (bit, &n) in inner[1..].iter().enumerate() {
                wide[n] = mask >> bit & 1 == 1;
            }
            let chosen = inner.iter().filter(|&&n| wide[n]);
            if chosen.clone().all(|&n| slots(bin, &wide, n) <= width) {
                let area = chosen.map(|&n| f64::from(bin[n].aabb().half_area())).sum();
                best = best.min(area);
            }
        }
        best
    }

    /// The total area of `nodes`, after checking that they are a wide tree
    /// over exactly the leaves of `bin`, children after their parents.
    fn checked_area<N: WideNode>(bin: &[Node], nodes: &[N]) -> f64 {
        let mut leaves: Vec<(u32, u32)> = Vec::new();
        let mut reached = vec![false; nodes.len()];
        reached[0] = true;
        for (i, n) in nodes.iter().enumerate() {
            assert!(reached[i], "node {i} has no parent");
            for s in 0..N::WIDTH {
                if let Some(leaf) = n.leaf(s) {
                    leaves.push(leaf);
                }
                if let Some(child) = n.inner(s) {
                    assert!(child > i && !reached[child]);
                    reached[child] = true;
                }
            }
        }
        let mut expected: Vec<(u32, u32)> = bin
            .iter()
            .filter(|b| b.is_leaf())
            .map(|b| (b.first(), b.count()))
            .collect();
        leaves.sort_unstable();
        expected.sort_unstable();
        assert_eq!(leaves, expected);
        nodes.iter().map(|n| f64::from(n.aabb().half_area())).sum()
    }

    fn random_tree(rng: &mut ChaCha8Rng, boxes: usize, max_leaf: u32) -> Bvh {
        let boxes: Vec<Aabb> = (0..boxes)
            .map(|_| {
                let at = Vec3A::new(rng.random(), rng.random(), rng.random()) * 10.0;
                let size = Vec3A::new(rng.random(), rng.random(), rng.random());
                Aabb::new(at, at + size)
            })
            .collect();
        let options = BuildOptions {
            max_leaf_size: max_leaf,
            ..BuildOptions::default()
        };
        Bvh::build(&boxes, &options)
    }

    /// On random builds small enough to try every collapse, the wide trees
    /// have the least node area there is, 4-wide and 8-wide, and keep the
    /// binary tree's leaves.
    #[test]
    fn the_collapse_has_the_least_node_area_of_all_collapses() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut checked = 0;
        for case in 0..60 {
            let bin = random_tree(&mut rng, 4 + case % 11, 1 + case as u32 % 3);
            let inner = bin.nodes().iter().filter(|b| !b.is_leaf()).count();
            if inner == 0 || inner > 14 {
                continue;
            }
            let four = checked_area(bin.nodes(), &collapse_tree::<Node4>(bin.nodes()));
            let eight = checked_area(bin.nodes(), &collapse_tree::<Node8>(bin.nodes()));
            for (area, width) in [(four, 4), (eight, 8)] {
                let least = least_area(bin.nodes(), width);
                assert!(
                    (area - least).abs() <= 1e-5 * least,
                    "case {case}, width {width}: {area} against the least {least}"
                );
            }
            checked += 1;
        }
        assert!(checked >= 40, "only {checked} trees small enough");
    }

    /// Boxes so large that their areas overflow to infinity still give wide
    /// trees over exactly the binary leaves (every share then costs the
    /// same, and each node keeps its two children apart).
    #[test]
    fn infinite_areas_still_collapse_into_a_tree_of_the_leaves() {
        let boxes: Vec<Aabb> = (0..40)
            .map(|i| {
                let at = Vec3A::new(i as f32 * 1e37 - 2e38, 0.0, (i % 7) as f32);
                Aabb::new(at, at + Vec3A::new(1e37, 3e38, 1.0))
            })
            .collect();
        let bin = Bvh::build(&boxes, &BuildOptions::default());
        assert!(bin.nodes()[0].aabb().half_area().is_infinite());
        checked_area(bin.nodes(), &collapse_tree::<Node4>(bin.nodes()));
        checked_area(bin.nodes(), &collapse_tree::<Node8>(bin.nodes()));
    }

    /// A tree whose root is a leaf becomes one node of one slot.
    #[test]
    fn a_single_leaf_is_one_node() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let bin = random_tree(&mut rng, 1, 4);
        let nodes = collapse_tree::<Node8>(bin.nodes());
        assert_eq!(nodes.len(), 1);
        assert_eq!(
            checked_area(bin.nodes(), &nodes),
            f64::from(bin.nodes()[0].aabb().half_area())
        );
    }
}
