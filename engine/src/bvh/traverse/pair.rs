//! Two trees walked together: the bounding-volume test tree (BVTT) of
//! collision queries (Lauterbach's dissertation, section 6.2).
//!
//! A BVTT node is a pair of tree slots whose volumes overlap; its children
//! are the overlapping pairs of their children, up to sixteen for two wide
//! nodes. The walk descends both trees at once and stops at pairs of
//! leaves, which it hands to the caller for the exact primitive tests.
//!
//! The volumes are the caller's: [`PairVolumes`] fetches a slot's volume
//! (moving the second tree's into the first one's frame) and tests two for
//! overlap, so boxes and oriented boxes fitted on the same topology share
//! this walk, and so does the front of [`super::front`], which restarts it
//! where the last frame stopped.

use glam::Vec3A;

use super::Flow;
use super::{NodeTest, OverlapTest};
use crate::bvh::wide::{Bvh4, Node4};
use crate::geometry::{Aabb, BoxMotion, RigidTransform};

/// A run of leaf slots, `first..first + count`, of a tree's leaf order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Leaf {
    pub first: u32,
    pub count: u32,
}

impl Leaf {
    /// The leaf order slots it holds.
    pub fn slots(self) -> std::ops::Range<usize> {
        self.first as usize..(self.first + self.count) as usize
    }
}

/// One side of a BVTT node: slot `slot` of wide node `node`, packed as
/// `node << 2 | slot`, or the whole tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Slot(u32);

impl Slot {
    /// The whole tree: the side the walk starts from, never tested itself.
    pub const ROOT: Slot = Slot(u32::MAX);

    fn new(node: usize, slot: usize) -> Self {
        Self(((node as u32) << 2) | slot as u32)
    }

    /// The wide node holding this slot.
    pub fn node(self) -> usize {
        (self.0 >> 2) as usize
    }

    /// Which of the node's four slots it is.
    pub fn slot(self) -> usize {
        (self.0 & 3) as usize
    }
}

/// A node of the bounding-volume test tree: a slot of each tree, and
/// whether both are the same subtree (self-collision pairs a subtree with
/// itself, which overlaps by definition).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Pair {
    pub a: Slot,
    pub b: Slot,
    pub same: bool,
}

impl Pair {
    /// The BVTT's root: both whole trees.
    pub const ROOT: Pair = Pair {
        a: Slot::ROOT,
        b: Slot::ROOT,
        same: false,
    };

    /// The root of a tree paired with itself.
    pub const SELF_ROOT: Pair = Pair {
        a: Slot::ROOT,
        b: Slot::ROOT,
        same: true,
    };
}

/// The bounding volumes of two trees' slots, and their overlap test. The
/// walk fetches each slot's volume once per BVTT node it expands, so
/// moving a volume into the first tree's frame belongs in
/// [`volume_b`](Self::volume_b). Tests must be conservative: a pair of
/// volumes reported apart has no pair of primitives that touch.
pub trait PairVolumes: Sync {
    type A: Copy;
    type B: Copy;
    fn tree_a(&self) -> &Bvh4;
    fn tree_b(&self) -> &Bvh4;
    fn volume_a(&self, slot: Slot) -> Self::A;
    fn volume_b(&self, slot: Slot) -> Self::B;
    fn overlap(&self, a: &Self::A, b: &Self::B) -> bool;

    /// The slots of `node` (a node of tree b) whose volumes may overlap `a`,
    /// as a bit per slot, tested together; `None` where the volumes have no
    /// such test (the walk then tests one slot at a time).
    fn node_overlaps(&self, _a: &Self::A, _node: &Node4) -> Option<u32> {
        None
    }

    /// Whether BVTT node `pair` overlaps (a subtree with itself always does).
    fn pair_overlaps(&self, pair: Pair) -> bool {
        pair.same || self.overlap(&self.volume_a(pair.a), &self.volume_b(pair.b))
    }
}

/// The trees' own boxes, `b`'s moved by `b_to_a` when given
/// (conservatively: a moved box is the box of its moved corners, padded)
/// and grown by `margin` (the broad phase of proximity queries).
pub struct BoxVolumes<'t> {
    pub a: &'t Bvh4,
    pub b: &'t Bvh4,
    pub b_to_a: Option<BoxMotion>,
    pub margin: f32,
}

impl PairVolumes for BoxVolumes<'_> {
    type A = Aabb;
    type B = Aabb;

    fn tree_a(&self) -> &Bvh4 {
        self.a
    }

    fn tree_b(&self) -> &Bvh4 {
        self.b
    }

    #[inline]
    fn volume_a(&self, s: Slot) -> Aabb {
        self.a.nodes[s.node()].slot_aabb(s.slot())
    }

    #[inline]
    fn volume_b(&self, s: Slot) -> Aabb {
        let mut b = self.b.nodes[s.node()].slot_aabb(s.slot());
        if let Some(t) = &self.b_to_a {
            b = t.apply(&b);
        }
        if self.margin > 0.0 {
            b = Aabb::new(
                b.min - Vec3A::splat(self.margin),
                b.max + Vec3A::splat(self.margin),
            );
        }
        b
    }

    #[inline]
    fn overlap(&self, a: &Aabb, b: &Aabb) -> bool {
        a.overlaps(b)
    }

    /// Unmoved, ungrown boxes: the node's own boxes, four per compare (the
    /// box query's node test).
    #[inline]
    fn node_overlaps(&self, a: &Aabb, node: &Node4) -> Option<u32> {
        (self.b_to_a.is_none() && self.margin == 0.0)
            .then(|| OverlapTest::new(*a).test4(&node.boxes, 0.0).1)
    }
}

/// A side and the leaf it is, if it is one.
type Child = (Slot, Option<Leaf>);

/// The children of a side: the used slots of its node, or a leaf itself
/// (a leaf paired with an inner node stays while the other side descends);
/// how many, and the node whose slots they are.
fn children(tree: &Bvh4, side: Slot, out: &mut [Child; 4]) -> (usize, Option<usize>) {
    let node = if side == Slot::ROOT {
        0
    } else {
        let n = &tree.nodes[side.node()];
        let s = side.slot();
        if n.is_leaf_slot(s) {
            out[0] = (
                side,
                Some(Leaf {
                    first: n.child[s],
                    count: n.count[s],
                }),
            );
            return (1, None);
        }
        n.child[s] as usize
    };
    let n = &tree.nodes[node];
    let mut k = 0;
    for slot in 0..4 {
        if n.is_leaf_slot(slot) {
            out[k] = (
                Slot::new(node, slot),
                Some(Leaf {
                    first: n.child[slot],
                    count: n.count[slot],
                }),
            );
            k += 1;
        } else if n.is_inner_slot(slot) {
            out[k] = (Slot::new(node, slot), None);
            k += 1;
        }
    }
    (k, Some(node))
}

/// The leaf a side is, if it is one.
pub(super) fn leaf(tree: &Bvh4, side: Slot) -> Option<Leaf> {
    if side == Slot::ROOT {
        return None;
    }
    let n = &tree.nodes[side.node()];
    n.is_leaf_slot(side.slot()).then(|| Leaf {
        first: n.child[side.slot()],
        count: n.count[side.slot()],
    })
}

/// What a child of a BVTT node is.
pub(super) enum Step {
    /// Its volumes are apart: nothing below it touches.
    Apart,
    /// Two overlapping leaves (or a leaf with itself).
    Leaves(Leaf, Leaf),
    /// Overlapping, with an inner node on at least one side: to descend.
    Inner,
}

/// Calls `child(pair, step)` for each child of BVTT node `p` (whose own
/// overlap the caller has decided); `child` breaks to stop.
pub(super) fn expand<V: PairVolumes>(
    volumes: &V,
    p: Pair,
    mut child: impl FnMut(Pair, Step) -> Flow,
) -> Flow {
    let (a, b) = (volumes.tree_a(), volumes.tree_b());
    let (mut sa, mut sb) = ([(Slot::ROOT, None); 4], [(Slot::ROOT, None); 4]);
    let (ka, node_a) = children(a, p.a, &mut sa);
    let (kb, node_b) = if p.same {
        sb = sa;
        (ka, node_a)
    } else {
        children(b, p.b, &mut sb)
    };
    if ka == 0 || kb == 0 {
        return Flow::Continue(());
    }
    let va: [V::A; 4] = std::array::from_fn(|i| volumes.volume_a(sa[i.min(ka - 1)].0));
    // Where the volumes allow, each of a's children against all of b's at
    // once (by slot); otherwise b's volumes, fetched once.
    let masks: [Option<u32>; 4] = std::array::from_fn(|i| {
        let n = node_b.filter(|_| i < ka)?;
        volumes.node_overlaps(&va[i], &b.nodes[n])
    });
    let fetch = masks[..ka].iter().any(Option::is_none);
    let vb: [Option<V::B>; 4] =
        std::array::from_fn(|j| (fetch && j < kb).then(|| volumes.volume_b(sb[j].0)));
    for i in 0..ka {
        // Within one subtree, each unordered pair of children once and
        // each child with itself.
        let from = if p.same { i } else { 0 };
        for j in from..kb {
            let same = p.same && i == j;
            let pair = Pair {
                a: sa[i].0,
                b: sb[j].0,
                same,
            };
            let overlap = match (masks[i], &vb[j]) {
                (Some(m), _) => m >> sb[j].0.slot() & 1 != 0,
                (None, Some(vb)) => volumes.overlap(&va[i], vb),
                (None, None) => true,
            };
            let step = if !same && !overlap {
                Step::Apart
            } else if let (Some(la), Some(lb)) = (sa[i].1, sb[j].1) {
                Step::Leaves(la, lb)
            } else {
                Step::Inner
            };
            child(pair, step)?;
        }
    }
    Flow::Continue(())
}

/// Walks the BVTT below `start` (whose own overlap the caller has
/// decided): calls `visit` for every pair of overlapping leaves, and
/// records in `front` a cut of the BVTT where it stopped. A node all of
/// whose children are stops (leaf pairs visited, pairs found apart) is
/// recorded itself, in place of its up to sixteen children: restarting
/// there costs one expansion, as the walk did, instead of a volume fetch
/// and test per child. Other stops are recorded one by one. A leaf paired
/// with itself is visited, since its own primitives may touch one
/// another. `visit` breaks to end the walk.
pub(super) fn descend<V: PairVolumes>(
    volumes: &V,
    start: Pair,
    stack: &mut Vec<Pair>,
    mut front: Option<&mut Vec<Pair>>,
    visit: &mut impl FnMut(Leaf, Leaf) -> Flow,
) -> Flow {
    if volumes.tree_a().nodes.is_empty() || volumes.tree_b().nodes.is_empty() {
        return Flow::Continue(());
    }
    stack.clear();
    stack.push(start);
    while let Some(p) = stack.pop() {
        let (mut stops, mut count, mut inner) = ([Pair::ROOT; 16], 0, false);
        expand(volumes, p, |pair, step| {
            match step {
                Step::Apart => {}
                Step::Leaves(la, lb) => visit(la, lb)?,
                Step::Inner => {
                    inner = true;
                    stack.push(pair);
                    return Flow::Continue(());
                }
            }
            stops[count] = pair;
            count += 1;
            Flow::Continue(())
        })?;
        if let Some(f) = front.as_deref_mut() {
            // The root has no volume of its own to test again.
            if inner || p.a == Slot::ROOT || p.b == Slot::ROOT {
                f.extend_from_slice(&stops[..count]);
            } else {
                f.push(p);
            }
        }
    }
    Flow::Continue(())
}

/// Calls `visit(leaf of a, leaf of b)` for every pair of leaves whose boxes
/// overlap, with `b`'s boxes moved into `a`'s frame by `b_to_a` when given.
/// `visit` breaks to end the walk.
pub fn overlapping_leaves(
    a: &Bvh4,
    b: &Bvh4,
    b_to_a: Option<&RigidTransform>,
    visit: impl FnMut(Leaf, Leaf) -> Flow,
) {
    leaves_within(a, b, b_to_a, 0.0, visit);
}

/// [`overlapping_leaves`] for boxes closer than `margin` (each of `b`'s
/// boxes grown by it): the broad phase of proximity queries.
pub fn leaves_within(
    a: &Bvh4,
    b: &Bvh4,
    b_to_a: Option<&RigidTransform>,
    margin: f32,
    mut visit: impl FnMut(Leaf, Leaf) -> Flow,
) {
    let volumes = BoxVolumes {
        a,
        b,
        b_to_a: b_to_a.map(BoxMotion::new),
        margin,
    };
    let _ = descend(&volumes, Pair::ROOT, &mut Vec::new(), None, &mut visit);
}

/// Calls `visit(x, y)` for every unordered pair of distinct leaves of
/// `tree` whose boxes overlap, once each, and `visit(x, x)` for every leaf,
/// whose own primitives may touch one another: the broad phase of
/// self-collision. `visit` breaks to end the walk.
pub fn self_overlapping_leaves(tree: &Bvh4, mut visit: impl FnMut(Leaf, Leaf) -> Flow) {
    let volumes = BoxVolumes {
        a: tree,
        b: tree,
        b_to_a: None,
        margin: 0.0,
    };
    let _ = descend(&volumes, Pair::SELF_ROOT, &mut Vec::new(), None, &mut visit);
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;
    use std::ops::ControlFlow;

    use glam::{DQuat, DVec3, Quat, Vec3};

    use super::*;
    use crate::bvh::{BuildOptions, Bvh};

    /// SplitMix64: enough randomness for test inputs, no dependency.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        }
        fn point(&mut self, scale: f32) -> Vec3A {
            Vec3A::new(self.next(), self.next(), self.next()) * scale
        }
    }

    fn random_boxes(rng: &mut Rng, n: usize, size: f32) -> Vec<Aabb> {
        (0..n)
            .map(|_| {
                let lo = rng.point(10.0);
                Aabb::new(lo, lo + rng.point(size))
            })
            .collect()
    }

    fn tree(boxes: &[Aabb]) -> (Bvh4, Vec<u32>) {
        let bin = Bvh::build(boxes, &BuildOptions::default());
        (Bvh4::from_binary(&bin), bin.prim_ids)
    }

    /// The primitive pairs the walk's leaf pairs hold whose own boxes pass
    /// `exact`, and how many leaf pairs it reported more than once.
    fn expand(
        leaf_pairs: &[(Leaf, Leaf)],
        ids_a: &[u32],
        ids_b: &[u32],
        exact: impl Fn(u32, u32) -> bool,
    ) -> (BTreeSet<(u32, u32)>, usize) {
        let distinct: BTreeSet<_> = leaf_pairs.iter().copied().collect();
        let mut pairs = BTreeSet::new();
        for (la, lb) in leaf_pairs {
            for x in la.slots() {
                for y in lb.slots() {
                    let (p, q) = (ids_a[x], ids_b[y]);
                    if exact(p, q) {
                        pairs.insert((p, q));
                    }
                }
            }
        }
        (pairs, leaf_pairs.len() - distinct.len())
    }

    #[test]
    fn overlapping_leaves_find_every_overlapping_pair_of_random_boxes() {
        let mut rng = Rng(7);
        for (n, m, size) in [(1, 1, 1.0), (50, 300, 0.8), (700, 500, 0.3), (64, 64, 12.0)] {
            let (a, b) = (
                random_boxes(&mut rng, n, size),
                random_boxes(&mut rng, m, size),
            );
            let ((ta, ia), (tb, ib)) = (tree(&a), tree(&b));
            let mut leaf_pairs = Vec::new();
            overlapping_leaves(&ta, &tb, None, |x, y| {
                leaf_pairs.push((x, y));
                ControlFlow::Continue(())
            });
            let overlap = |p: u32, q: u32| a[p as usize].overlaps(&b[q as usize]);
            let (found, repeated) = expand(&leaf_pairs, &ia, &ib, overlap);
            let brute: BTreeSet<(u32, u32)> = (0..n as u32)
                .flat_map(|p| (0..m as u32).map(move |q| (p, q)))
                .filter(|&(p, q)| overlap(p, q))
                .collect();
            assert_eq!(found, brute, "{n} x {m}");
            assert_eq!(repeated, 0);
        }
    }

    #[test]
    fn self_overlapping_leaves_find_each_pair_once() {
        let mut rng = Rng(11);
        for (n, size) in [(1, 1.0), (2, 20.0), (400, 0.5), (900, 0.2)] {
            let boxes = random_boxes(&mut rng, n, size);
            let (t, ids) = tree(&boxes);
            let mut leaf_pairs = Vec::new();
            self_overlapping_leaves(&t, |x, y| {
                leaf_pairs.push((x.min(y), x.max(y)));
                ControlFlow::Continue(())
            });
            let overlap = |p: u32, q: u32| p != q && boxes[p as usize].overlaps(&boxes[q as usize]);
            let (found, repeated) = expand(&leaf_pairs, &ids, &ids, overlap);
            let found: BTreeSet<_> = found
                .into_iter()
                .map(|(p, q)| (p.min(q), p.max(q)))
                .collect();
            let brute: BTreeSet<(u32, u32)> = (0..n as u32)
                .flat_map(|p| (p + 1..n as u32).map(move |q| (p, q)))
                .filter(|&(p, q)| overlap(p, q))
                .collect();
            assert_eq!(found, brute, "{n}");
            assert_eq!(repeated, 0);
        }
    }

    /// Triangles of two meshes, the second moved rigidly: the walk over its
    /// object-frame tree finds every pair whose boxes overlap in the world,
    /// judged in f64 from the moved corners.
    #[test]
    fn moved_trees_miss_no_pair_of_triangles() {
        let mut rng = Rng(3);
        let triangles = |rng: &mut Rng, n: usize| -> Vec<[Vec3A; 3]> {
            (0..n)
                .map(|_| {
                    let a = rng.point(6.0);
                    [a, a + rng.point(0.7), a + rng.point(0.7)]
                })
                .collect()
        };
        let (ta, tb) = (triangles(&mut rng, 300), triangles(&mut rng, 300));
        let boxes = |t: &[[Vec3A; 3]]| -> Vec<Aabb> {
            t.iter()
                .map(|[p, q, r]| Aabb::of_triangle(*p, *q, *r))
                .collect()
        };
        let ((tree_a, ia), (tree_b, ib)) = (tree(&boxes(&ta)), tree(&boxes(&tb)));
        let axis = Vec3::new(0.3, -1.0, 0.5).normalize();
        let b_to_a =
            RigidTransform::new(Quat::from_axis_angle(axis, 0.9), Vec3::new(1.0, 2.0, -0.5))
                .unwrap();
        let q = b_to_a.rotation;
        let rot = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into());
        let shift = b_to_a.translation.as_dvec3();
        let dbox = |corners: &[DVec3]| {
            corners
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &c| {
                    (lo.min(c), hi.max(c))
                })
        };
        let world_a: Vec<_> = ta
            .iter()
            .map(|t| dbox(&t.map(|p| Vec3::from(p).as_dvec3())))
            .collect();
        let world_b: Vec<_> = tb
            .iter()
            .map(|t| dbox(&t.map(|p| rot * Vec3::from(p).as_dvec3() + shift)))
            .collect();
        let overlap = |p: u32, q: u32| {
            let ((alo, ahi), (blo, bhi)) = (world_a[p as usize], world_b[q as usize]);
            alo.cmple(bhi).all() && ahi.cmpge(blo).all()
        };
        let mut leaf_pairs = Vec::new();
        overlapping_leaves(&tree_a, &tree_b, Some(&b_to_a), |x, y| {
            leaf_pairs.push((x, y));
            ControlFlow::Continue(())
        });
        let (found, _) = expand(&leaf_pairs, &ia, &ib, overlap);
        let brute: BTreeSet<(u32, u32)> = (0..300)
            .flat_map(|p| (0..300).map(move |q| (p, q)))
            .filter(|&(p, q)| overlap(p, q))
            .collect();
        assert!(!brute.is_empty());
        assert_eq!(found, brute);
    }

    #[test]
    fn a_break_ends_the_walk_and_empty_trees_have_no_pairs() {
        let mut rng = Rng(5);
        let boxes = random_boxes(&mut rng, 200, 3.0);
        let (t, _) = tree(&boxes);
        let mut calls = 0;
        overlapping_leaves(&t, &t, None, |_, _| {
            calls += 1;
            ControlFlow::Break(())
        });
        assert_eq!(calls, 1);
        let empty = Bvh4::default();
        overlapping_leaves(&t, &empty, None, |_, _| panic!("no pairs"));
        self_overlapping_leaves(&empty, |_, _| panic!("no pairs"));
        // Unused wide slots hold empty boxes, which must overlap nothing.
        assert!(!Aabb::EMPTY.overlaps(&Aabb::new(Vec3A::splat(-1e30), Vec3A::splat(1e30))));
    }
}
