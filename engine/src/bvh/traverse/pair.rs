//! Two trees walked together: the bounding-volume test tree (BVTT) of
//! collision queries (Lauterbach's dissertation, section 6.2).
//!
//! A BVTT node is a pair of tree nodes whose boxes overlap; its children
//! are the overlapping pairs of their children, up to sixteen for two wide
//! nodes. The walk descends both trees at once and stops at pairs of
//! leaves, which it hands to the caller for the exact primitive tests.

use glam::Vec3A;

use super::Flow;
use crate::bvh::wide::{Bvh4, Node4};
use crate::geometry::{Aabb, RigidTransform};

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

/// A BVTT side: an inner node by index, or a leaf by this bit with its
/// node's index and slot.
const LEAF_REF: u32 = 1 << 31;

/// The children of a side with their boxes: the four slots of an inner
/// node, or a leaf itself (a leaf paired with an inner node stays while
/// the other side descends).
fn children(tree: &Bvh4, side: u32, out: &mut [(Aabb, u32); 4]) -> usize {
    if side & LEAF_REF != 0 {
        let (node, slot) = (((side & !LEAF_REF) >> 2) as usize, (side & 3) as usize);
        out[0] = (tree.nodes[node].slot_aabb(slot), side);
        return 1;
    }
    let node: &Node4 = &tree.nodes[side as usize];
    let mut k = 0;
    for slot in 0..4 {
        let side = if node.is_leaf_slot(slot) {
            LEAF_REF | (side << 2) | slot as u32
        } else if node.is_inner_slot(slot) {
            node.child[slot]
        } else {
            continue;
        };
        out[k] = (node.slot_aabb(slot), side);
        k += 1;
    }
    k
}

fn leaf(tree: &Bvh4, side: u32) -> Option<Leaf> {
    (side & LEAF_REF != 0).then(|| {
        let (node, slot) = (((side & !LEAF_REF) >> 2) as usize, (side & 3) as usize);
        let n = &tree.nodes[node];
        Leaf {
            first: n.child[slot],
            count: n.count[slot],
        }
    })
}

/// Calls `visit(leaf of a, leaf of b)` for every pair of leaves whose boxes
/// overlap, with `b`'s boxes moved into `a`'s frame by `b_to_a` when given
/// (conservatively: a moved box is the box of its moved corners, padded).
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
    if a.nodes.is_empty() || b.nodes.is_empty() {
        return;
    }
    let mut stack = vec![(0u32, 0u32)];
    let (mut ca, mut cb) = ([(Aabb::EMPTY, 0); 4], [(Aabb::EMPTY, 0); 4]);
    while let Some((sa, sb)) = stack.pop() {
        let ka = children(a, sa, &mut ca);
        let kb = children(b, sb, &mut cb);
        for (bx, _) in &mut cb[..kb] {
            if let Some(t) = b_to_a {
                *bx = bx.transformed(t);
            }
            *bx = Aabb::new(bx.min - Vec3A::splat(margin), bx.max + Vec3A::splat(margin));
        }
        for &(box_a, xa) in &ca[..ka] {
            for &(box_b, xb) in &cb[..kb] {
                if !box_a.overlaps(&box_b) {
                    continue;
                }
                match (leaf(a, xa), leaf(b, xb)) {
                    (Some(la), Some(lb)) => {
                        if visit(la, lb).is_break() {
                            return;
                        }
                    }
                    _ => stack.push((xa, xb)),
                }
            }
        }
    }
}

/// Calls `visit(x, y)` for every unordered pair of distinct leaves of
/// `tree` whose boxes overlap, once each, and `visit(x, x)` for every leaf,
/// whose own primitives may touch one another: the broad phase of
/// self-collision. `visit` breaks to end the walk.
pub fn self_overlapping_leaves(tree: &Bvh4, mut visit: impl FnMut(Leaf, Leaf) -> Flow) {
    if tree.nodes.is_empty() {
        return;
    }
    // (side, side, whether both are the same subtree)
    let mut stack = vec![(0u32, 0u32, true)];
    let (mut ca, mut cb) = ([(Aabb::EMPTY, 0); 4], [(Aabb::EMPTY, 0); 4]);
    while let Some((sa, sb, same)) = stack.pop() {
        let ka = children(tree, sa, &mut ca);
        let kb = if same {
            cb = ca;
            ka
        } else {
            children(tree, sb, &mut cb)
        };
        for (i, &(box_a, xa)) in ca[..ka].iter().enumerate() {
            // Within one subtree, each unordered pair of children once and
            // each child with itself.
            let from = if same { i } else { 0 };
            for (j, &(box_b, xb)) in cb[..kb].iter().enumerate().skip(from) {
                let itself = same && i == j;
                if !itself && !box_a.overlaps(&box_b) {
                    continue;
                }
                match (leaf(tree, xa), leaf(tree, xb)) {
                    (Some(la), Some(lb)) => {
                        if visit(la, lb).is_break() {
                            return;
                        }
                    }
                    _ => stack.push((xa, xb, itself)),
                }
            }
        }
    }
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
