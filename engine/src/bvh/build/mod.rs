//! BVH construction.
//!
//! One recursive driver builds the topology top-down; a method only decides
//! how a range of primitives splits ([`BuildMethod`]). Large ranges are
//! built in parallel with rayon, each half into its own node list, and the
//! lists are laid out into one when the whole tree is known. Boxes are
//! filled by one bottom-up pass at the end, so the Morton builder never
//! computes a box while splitting.

mod binned_sah;
mod morton;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{refit, Bvh, Node};
use crate::geometry::Aabb;
use binned_sah::Scratch;

/// How the hierarchy is split.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BuildMethod {
    /// Binned surface area heuristic: the best trees for ray tracing.
    #[default]
    Sah,
    /// Linear BVH: sort on a 63-bit Morton curve and split on its bits.
    /// Fastest to build, lower quality; for objects rebuilt every frame.
    Lbvh,
    /// Morton splits for the top levels and binned SAH below
    /// (dissertation, section 5.3): near-SAH quality at near-LBVH speed on
    /// large inputs.
    Hybrid,
}

/// Build parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BuildOptions {
    pub method: BuildMethod,
    /// Leaves never hold more primitives than this (1..=255).
    pub max_leaf_size: u32,
    /// SAH bins per axis (2..=64) of large ranges; a range of `n`
    /// primitives uses at most `4 + n / 20`, as Embree does.
    pub bins: usize,
    /// Cost of visiting an inner node relative to one primitive test.
    pub traversal_cost: f32,
    /// Ranges at least this large are built in parallel (their two halves
    /// on rayon, and the centroids and Morton sort of inputs this large);
    /// a range's own binning from 16 times this.
    pub parallel_threshold: usize,
    /// Hybrid builder: ranges at most this large switch to SAH.
    pub hybrid_sah_size: usize,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            method: BuildMethod::Sah,
            max_leaf_size: 8,
            bins: 32,
            traversal_cost: 1.0,
            parallel_threshold: 1024,
            hybrid_sah_size: 4 * 1024,
        }
    }
}

impl BuildOptions {
    pub fn with_method(method: BuildMethod) -> Self {
        Self {
            method,
            ..Self::default()
        }
    }

    fn sanitized(&self) -> Self {
        Self {
            max_leaf_size: self.max_leaf_size.clamp(1, 255),
            bins: self.bins.clamp(2, binned_sah::MAX_BINS),
            traversal_cost: if self.traversal_cost.is_finite() {
                self.traversal_cost.max(0.0)
            } else {
                1.0
            },
            parallel_threshold: self.parallel_threshold.max(64),
            hybrid_sah_size: self.hybrid_sah_size.max(1),
            ..self.clone()
        }
    }
}

/// Past this depth every split is a median split, which halves the range:
/// the tree stays shallower than `FORCE_MEDIAN_DEPTH + 32`, within the
/// traversal stack, whatever the input.
const FORCE_MEDIAN_DEPTH: u32 = 40;

/// What a method decided for a range.
enum Split {
    Leaf,
    /// The range splits at this index (both halves non-empty).
    At(usize),
}

/// The inputs every split decision reads.
struct Context<'a> {
    options: BuildOptions,
    boxes: &'a [Aabb],
    centroids: &'a [glam::Vec3A],
    /// Morton codes in the order of `prim_ids` (Morton methods only).
    codes: &'a [u64],
}

impl Bvh {
    /// Builds a hierarchy over primitives with the given boxes. Empty boxes
    /// are allowed and end up in leaves that no ray reaches.
    ///
    /// ```
    /// use frusta_engine::bvh::{Bvh, BuildOptions};
    /// use frusta_engine::geometry::Aabb;
    /// use glam::Vec3A;
    /// let boxes: Vec<Aabb> = (0..100)
    ///     .map(|i| Aabb::new(Vec3A::splat(i as f32), Vec3A::splat(i as f32 + 0.5)))
    ///     .collect();
    /// let bvh = Bvh::build(&boxes, &BuildOptions::default());
    /// assert_eq!(bvh.prim_ids().len(), 100);
    /// ```
    pub fn build(boxes: &[Aabb], options: &BuildOptions) -> Bvh {
        let options = options.sanitized();
        let n = boxes.len();
        let mut prim_ids: Vec<u32> = (0..n as u32).collect();
        if n == 0 {
            return Bvh::default();
        }
        let centroids: Vec<glam::Vec3A> = if n >= options.parallel_threshold {
            boxes.par_iter().map(centroid).collect()
        } else {
            boxes.iter().map(centroid).collect()
        };
        let codes = match options.method {
            BuildMethod::Sah => Vec::new(),
            BuildMethod::Lbvh | BuildMethod::Hybrid => {
                morton::sort_by_code(&centroids, &mut prim_ids, options.parallel_threshold)
            }
        };
        let ctx = Context {
            options,
            boxes,
            centroids: &centroids,
            codes: &codes,
        };
        let mut nodes = build_range(&ctx, &mut prim_ids, 0, 0).lay_out();
        refit::refit_nodes(&mut nodes, |first, count| {
            prim_ids[first as usize..(first + count) as usize]
                .iter()
                .fold(Aabb::EMPTY, |b, &p| b.union(boxes[p as usize]))
        });
        Bvh { nodes, prim_ids }
    }
}

/// Box centre; an empty box (e.g. a degenerate primitive's placeholder)
/// counts as the origin so that binning stays finite.
fn centroid(b: &Aabb) -> glam::Vec3A {
    if b.is_empty() {
        glam::Vec3A::ZERO
    } else {
        b.center()
    }
}

/// A built subtree: the nodes one thread built (root at index 0, children
/// of every inner node an adjacent pair after it), or two subtrees built in
/// parallel under a new root. Laid out once, when the whole tree is known:
/// joining the lists at every parallel level copied every node once per
/// level (with a fresh allocation each time).
enum Subtree {
    Nodes(Vec<Node>),
    Join(Box<Subtree>, Box<Subtree>, usize),
}

impl Subtree {
    fn join(left: Subtree, right: Subtree) -> Self {
        let len = 1 + left.len() + right.len();
        Self::Join(Box::new(left), Box::new(right), len)
    }

    fn len(&self) -> usize {
        match self {
            Self::Nodes(nodes) => nodes.len(),
            Self::Join(_, _, len) => *len,
        }
    }

    /// One node list: `[root, left root, right root, rest of left, rest of
    /// right]` at every join.
    fn lay_out(self) -> Vec<Node> {
        let mut out = vec![Node::default(); self.len()];
        self.write(&mut out, 0, 1);
        out
    }

    /// Writes the root at `root` and the other nodes from `rest` on.
    fn write(self, out: &mut [Node], root: usize, rest: usize) {
        match self {
            Self::Nodes(nodes) => {
                // Local index i >= 1 moves to rest + i - 1.
                let shift = |n: &Node| {
                    let mut n = *n;
                    if !n.is_leaf() {
                        n.set_first((rest + n.first() as usize - 1) as u32);
                    }
                    n
                };
                out[root] = shift(&nodes[0]);
                for (slot, n) in out[rest..].iter_mut().zip(&nodes[1..]) {
                    *slot = shift(n);
                }
            }
            Self::Join(left, right, _) => {
                out[root] = Node::inner(Aabb::EMPTY, rest as u32);
                let right_rest = rest + 2 + left.len() - 1;
                left.write(out, rest, rest + 2);
                right.write(out, rest + 1, right_rest);
            }
        }
    }
}

/// Builds the subtree over `prims` (leaf slots `offset..offset+len`).
fn build_range(ctx: &Context, prims: &mut [u32], offset: usize, depth: u32) -> Subtree {
    if prims.len() < ctx.options.parallel_threshold {
        let mut nodes = Vec::with_capacity(2 * prims.len().div_ceil(2));
        nodes.push(Node::default());
        let mut scratch = Scratch::default();
        build_sequential(ctx, &mut scratch, &mut nodes, 0, prims, offset, depth);
        return Subtree::Nodes(nodes);
    }
    match split(ctx, &mut Scratch::default(), prims, offset, depth) {
        Split::Leaf => Subtree::Nodes(vec![Node::leaf(
            Aabb::EMPTY,
            offset as u32,
            prims.len() as u32,
        )]),
        Split::At(mid) => {
            let (lp, rp) = prims.split_at_mut(mid);
            let (left, right) = rayon::join(
                || build_range(ctx, lp, offset, depth + 1),
                || build_range(ctx, rp, offset + mid, depth + 1),
            );
            Subtree::join(left, right)
        }
    }
}

fn build_sequential(
    ctx: &Context,
    scratch: &mut Scratch,
    nodes: &mut Vec<Node>,
    node: usize,
    prims: &mut [u32],
    offset: usize,
    depth: u32,
) {
    match split(ctx, scratch, prims, offset, depth) {
        Split::Leaf => nodes[node] = Node::leaf(Aabb::EMPTY, offset as u32, prims.len() as u32),
        Split::At(mid) => {
            let first = nodes.len();
            nodes.push(Node::default());
            nodes.push(Node::default());
            nodes[node] = Node::inner(Aabb::EMPTY, first as u32);
            let (lp, rp) = prims.split_at_mut(mid);
            build_sequential(ctx, scratch, nodes, first, lp, offset, depth + 1);
            build_sequential(ctx, scratch, nodes, first + 1, rp, offset + mid, depth + 1);
        }
    }
}

/// Chooses how `prims` splits, reordering it if the method needs to.
fn split(
    ctx: &Context,
    scratch: &mut Scratch,
    prims: &mut [u32],
    offset: usize,
    depth: u32,
) -> Split {
    let n = prims.len();
    let max_leaf = ctx.options.max_leaf_size as usize;
    if n <= 1 {
        return Split::Leaf;
    }
    if depth >= FORCE_MEDIAN_DEPTH {
        return if n <= max_leaf {
            Split::Leaf
        } else {
            Split::At(n / 2)
        };
    }
    let codes = if ctx.codes.is_empty() {
        &[][..]
    } else {
        &ctx.codes[offset..offset + n]
    };
    let split = match ctx.options.method {
        BuildMethod::Sah => binned_sah::split(ctx, prims, scratch),
        BuildMethod::Lbvh => morton::split(codes, max_leaf),
        BuildMethod::Hybrid if n > ctx.options.hybrid_sah_size => morton::split(codes, 1),
        BuildMethod::Hybrid => binned_sah::split(ctx, prims, scratch),
    };
    match split {
        Split::Leaf if n > max_leaf => Split::At(n / 2),
        s => s,
    }
}
