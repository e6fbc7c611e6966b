//! The BVTT front, kept between frames (the dissertation's section 6.2.3),
//! and the parallel pair walk it restarts.
//!
//! A walk of the bounding-volume test tree stops at two kinds of node:
//! pairs of overlapping leaves and pairs found apart. Those stops form a
//! cut of the BVTT (every root-to-leaf path crosses exactly one), and so
//! does the cut the walk records, where a node whose children are all
//! stops stands for them (a wide BVTT node has up to sixteen children, and
//! one expansion tests them together). When the trees are refitted on the
//! same topology the next frame starts from that cut instead of the root:
//! a node that still overlaps is descended (or, as a leaf pair, visited),
//! one that is now apart stays. Volumes nest after a refit, so nothing
//! below a pair apart can touch, and the walk from the front finds exactly
//! what a walk from the root finds.
//!
//! The dissertation moves a front up again where parents stop
//! overlapping. Here, instead, a front is renewed by a walk from the root
//! every few frames, or sooner when it has gone stale (its share of
//! overlapping stops has fallen below half of what a fresh walk gave):
//! simpler, and a front never costs much more than a fresh one.

use rayon::prelude::*;

use super::pair::{descend, expand, leaf, Leaf, Pair, PairVolumes, Step};
use super::Flow;

/// Stops handed to one task of the parallel walks.
const CHUNK: usize = 256;

/// BVTT nodes the parallel walk from the root expands breadth-first
/// before it splits them over threads.
const SEEDS: usize = 256;

/// A walk's results: what `visit` collected, and the front it stopped at.
struct Walk<T> {
    found: Vec<T>,
    /// Where the walk stopped, when it is to be kept.
    front: Option<Vec<Pair>>,
    /// Stops that were overlapping leaf pairs.
    leaf_pairs: usize,
    /// Whether `visit` broke off the walk: the front is then not a cut.
    broken: bool,
}

impl<T> Walk<T> {
    fn new(keep_front: bool) -> Self {
        Self {
            found: Vec::new(),
            front: keep_front.then(Vec::new),
            leaf_pairs: 0,
            broken: false,
        }
    }

    fn stop(&mut self, pair: Pair) {
        if let Some(f) = &mut self.front {
            f.push(pair);
        }
    }

    /// A stop at two overlapping leaves.
    fn stop_at_leaves(
        &mut self,
        pair: Pair,
        la: Leaf,
        lb: Leaf,
        visit: &impl Fn(Leaf, Leaf, &mut Vec<T>) -> Flow,
    ) -> Flow {
        self.stop(pair);
        self.leaf_pairs += 1;
        visit(la, lb, &mut self.found)
    }

    /// The walk below overlapping BVTT node `p`.
    fn descend<V: PairVolumes>(
        &mut self,
        volumes: &V,
        p: Pair,
        stack: &mut Vec<Pair>,
        visit: &impl Fn(Leaf, Leaf, &mut Vec<T>) -> Flow,
    ) -> Flow {
        let (found, leaf_pairs) = (&mut self.found, &mut self.leaf_pairs);
        descend(volumes, p, stack, self.front.as_mut(), &mut |la, lb| {
            *leaf_pairs += 1;
            visit(la, lb, found)
        })
    }

    fn join(mut self, other: Self) -> Self {
        self.found.extend(other.found);
        if let (Some(f), Some(g)) = (&mut self.front, other.front) {
            f.extend(g);
        }
        self.leaf_pairs += other.leaf_pairs;
        self.broken |= other.broken;
        self
    }
}

/// Walks below each of `starts` (overlapping BVTT nodes) on one thread.
fn walk_below<V: PairVolumes, T>(
    volumes: &V,
    starts: &[Pair],
    keep_front: bool,
    visit: &(impl Fn(Leaf, Leaf, &mut Vec<T>) -> Flow + Sync),
) -> Walk<T> {
    let mut walk = Walk::new(keep_front);
    let mut stack = Vec::new();
    for &p in starts {
        if walk.descend(volumes, p, &mut stack, visit).is_break() {
            walk.broken = true;
            break;
        }
    }
    walk
}

/// The walk from `root` (the BVTT root, or a tree's root with itself),
/// over both threads: the top levels breadth-first until there are enough
/// nodes to share out, then one depth-first walk per chunk of them.
fn walk_from_root<V: PairVolumes, T: Send>(
    volumes: &V,
    root: Pair,
    keep_front: bool,
    visit: &(impl Fn(Leaf, Leaf, &mut Vec<T>) -> Flow + Sync),
) -> Walk<T> {
    let mut walk = Walk::new(keep_front);
    if volumes.tree_a().nodes.is_empty() || volumes.tree_b().nodes.is_empty() {
        return walk;
    }
    let mut level = vec![root];
    while !level.is_empty() && level.len() < SEEDS {
        let mut next = Vec::with_capacity(level.len() * 16);
        for &p in &level {
            let flow = expand(volumes, p, |pair, step| match step {
                Step::Apart => {
                    walk.stop(pair);
                    Flow::Continue(())
                }
                Step::Leaves(la, lb) => walk.stop_at_leaves(pair, la, lb, visit),
                Step::Inner => {
                    next.push(pair);
                    Flow::Continue(())
                }
            });
            if flow.is_break() {
                walk.broken = true;
                return walk;
            }
        }
        level = next;
    }
    let below = level
        .par_chunks(CHUNK.min(level.len().div_ceil(8)).max(1))
        .map(|starts| walk_below(volumes, starts, keep_front, visit))
        .reduce(|| Walk::new(keep_front), Walk::join);
    walk.join(below)
}

/// Calls `visit(leaf of a, leaf of b, found)` for every pair of leaves
/// whose volumes overlap, on all threads, and returns what the calls
/// pushed (in no particular order); a call that breaks ends its thread's
/// walk, and the others' at their next break. For one tree with itself (`volumes`
/// over the same tree twice), pass `same`: each unordered pair of distinct
/// leaves is then visited once, and each leaf with itself.
pub fn par_leaf_pairs<V: PairVolumes, T: Send>(
    volumes: &V,
    same: bool,
    visit: impl Fn(Leaf, Leaf, &mut Vec<T>) -> Flow + Sync,
) -> Vec<T> {
    let root = if same { Pair::SELF_ROOT } else { Pair::ROOT };
    walk_from_root(volumes, root, false, &visit).found
}

/// Where the last frame's pair walk stopped, to start the next one from.
#[derive(Clone, Debug, Default)]
pub struct Front {
    pairs: Vec<Pair>,
    /// The trees' topologies the pairs refer to.
    trees: (u64, u64),
    same: bool,
    /// Share of overlapping leaf pairs among the stops of the last walk
    /// from the root, and of the last frame.
    fresh_share: f64,
    share: f64,
    /// Walks from this front since the last walk from the root.
    age: u32,
}

/// Walks a front serves before one from the root replaces it: a front
/// never moves up where pairs have come apart, so it is renewed.
const RENEW_AFTER: u32 = 8;

impl Front {
    /// An empty front: its first walk starts from the root.
    pub fn new() -> Self {
        Self::default()
    }

    /// How many BVTT nodes it holds.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// [`par_leaf_pairs`], started from this front where it is still valid
    /// for `volumes`' trees (same topologies, same kind of walk, not stale)
    /// and from the root otherwise; leaves the front where this walk
    /// stopped.
    pub fn leaf_pairs<V: PairVolumes, T: Send>(
        &mut self,
        volumes: &V,
        same: bool,
        visit: impl Fn(Leaf, Leaf, &mut Vec<T>) -> Flow + Sync,
    ) -> Vec<T> {
        let trees = (volumes.tree_a().topology, volumes.tree_b().topology);
        let valid = !self.pairs.is_empty()
            && self.trees == trees
            && self.same == same
            && self.share * 2.0 >= self.fresh_share
            && self.age < RENEW_AFTER;
        let walk = if valid {
            self.pairs
                .par_chunks(CHUNK)
                .map(|stops| restart(volumes, stops, &visit))
                .reduce(|| Walk::new(true), Walk::join)
        } else {
            let root = if same { Pair::SELF_ROOT } else { Pair::ROOT };
            walk_from_root(volumes, root, true, &visit)
        };
        // A walk cut short left no cut of the BVTT: the next starts over.
        let pairs = walk.front.filter(|_| !walk.broken).unwrap_or_default();
        let share = walk.leaf_pairs as f64 / pairs.len().max(1) as f64;
        if !valid {
            self.fresh_share = share;
        }
        *self = Self {
            pairs,
            trees,
            same,
            fresh_share: self.fresh_share,
            share,
            age: if valid { self.age + 1 } else { 0 },
        };
        walk.found
    }
}

/// The walk from last frame's `stops`: those apart stay, overlapping leaf
/// pairs are visited and stay, and the walk descends from the others.
fn restart<V: PairVolumes, T>(
    volumes: &V,
    stops: &[Pair],
    visit: &(impl Fn(Leaf, Leaf, &mut Vec<T>) -> Flow + Sync),
) -> Walk<T> {
    let (a, b) = (volumes.tree_a(), volumes.tree_b());
    let mut walk = Walk::new(true);
    let mut stack = Vec::new();
    for &p in stops {
        if !volumes.pair_overlaps(p) {
            walk.stop(p);
            continue;
        }
        let flow = match (leaf(a, p.a), leaf(b, p.b)) {
            (Some(la), Some(lb)) => walk.stop_at_leaves(p, la, lb, visit),
            _ => walk.descend(volumes, p, &mut stack, visit),
        };
        if flow.is_break() {
            walk.broken = true;
            break;
        }
    }
    walk
}
