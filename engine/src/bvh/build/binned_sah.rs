//! Binned SAH split (Wald 2007): centroids fall into equal-width bins along
//! each axis and the split is chosen among bin boundaries by the surface
//! area heuristic with a primitive-test cost of 1.

use glam::Vec3A;
use rayon::prelude::*;

use super::{Context, Split};
use crate::geometry::Aabb;

pub(super) const MAX_BINS: usize = 64;

/// How many times `parallel_threshold` a range must hold for its own
/// binning to run on rayon.
const PARALLEL_BINNING: usize = 16;

#[derive(Clone, Copy)]
pub(super) struct Bin {
    bounds: Aabb,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Aabb::EMPTY,
    count: 0,
};

/// Bins of the three axes, `bins` per axis, reused across the splits of a
/// subtree so that a split allocates nothing and clears only what it uses.
#[derive(Default)]
pub(super) struct Scratch {
    bins: Vec<Bin>,
}

/// Maps a centroid to its bin along each axis.
#[derive(Clone, Copy)]
struct Binning {
    origin: Vec3A,
    scale: Vec3A,
    last: usize,
}

impl Binning {
    /// The bin of `x`, the centroid's offset from the origin scaled to bin
    /// widths. Clamped in floating point first (NaN, negative and past the
    /// last bin land where a saturating cast would put them), so the
    /// conversion is one truncating instruction: the saturating `as usize`
    /// was a sixth of a build's instructions.
    #[inline(always)]
    fn index(&self, x: f32) -> usize {
        let x = x.max(0.0).min(self.last as f32);
        // SAFETY: `x` is finite and within `0..=last`.
        unsafe { x.to_int_unchecked::<u32>() as usize }
    }

    #[inline(always)]
    fn bin(&self, c: Vec3A, axis: usize) -> usize {
        self.index((c[axis] - self.origin[axis]) * self.scale[axis])
    }

    /// Adds a primitive to its bin on each axis of `bins` (axis-major).
    #[inline(always)]
    fn add(&self, bins: &mut [Bin], stride: usize, c: Vec3A, b: Aabb) {
        let scaled = ((c - self.origin) * self.scale).to_array();
        for (axis, x) in scaled.into_iter().enumerate() {
            let bin = &mut bins[axis * stride + self.index(x)];
            bin.bounds = bin.bounds.union(b);
            bin.count += 1;
        }
    }
}

pub(super) fn split(ctx: &Context, prims: &mut [u32], scratch: &mut Scratch) -> Split {
    let n = prims.len();
    // Subtrees are built in parallel from `parallel_threshold` down; the
    // bins of one range only where a range is much larger, since each
    // chunk's bins are allocated and merged.
    let parallel = n / PARALLEL_BINNING >= ctx.options.parallel_threshold;
    let (bounds, centroid_bounds) = range_bounds(ctx, prims, parallel);
    let extent = centroid_bounds.extent();
    let parent_area = bounds.half_area();
    if parent_area.is_nan() || parent_area <= 0.0 || extent.max_element() <= 0.0 {
        return Split::Leaf;
    }
    // Few primitives need few bins; clearing and sweeping them is the
    // fixed cost of a split, and most splits are of small ranges. Embree's
    // rule, 4 and one more per 20 primitives.
    let bins = ctx.options.bins.min(4 + n / 20);
    let binning = Binning {
        origin: centroid_bounds.min,
        // Axes without extent get scale 0: one bin, never a candidate.
        scale: Vec3A::select(
            extent.cmpgt(Vec3A::ZERO),
            Vec3A::splat(bins as f32) / extent,
            Vec3A::ZERO,
        ),
        last: bins - 1,
    };
    let size = 3 * bins;
    let binned = &mut scratch.bins;
    binned.clear();
    if parallel {
        let merged = prims
            .par_chunks(4096)
            .map(|chunk| {
                let mut acc = vec![EMPTY_BIN; size];
                for &p in chunk {
                    binning.add(
                        &mut acc,
                        bins,
                        ctx.centroids[p as usize],
                        ctx.boxes[p as usize],
                    );
                }
                acc
            })
            .reduce(|| vec![EMPTY_BIN; size], merge);
        binned.extend(merged);
    } else {
        binned.resize(size, EMPTY_BIN);
        for &p in prims.iter() {
            binning.add(
                binned,
                bins,
                ctx.centroids[p as usize],
                ctx.boxes[p as usize],
            );
        }
    }

    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let bins_axis = &binned[axis * bins..(axis + 1) * bins];
        // Right-hand areas and counts for each boundary, swept once.
        let mut right_cost = [0.0f32; MAX_BINS];
        let (mut acc, mut count) = (Aabb::EMPTY, 0u32);
        for i in (1..bins).rev() {
            acc = acc.union(bins_axis[i].bounds);
            count += bins_axis[i].count;
            right_cost[i] = acc.half_area() * count as f32;
        }
        let (mut acc, mut count) = (Aabb::EMPTY, 0u32);
        for i in 0..bins - 1 {
            acc = acc.union(bins_axis[i].bounds);
            count += bins_axis[i].count;
            if count == 0 || count as usize == n {
                continue;
            }
            let cost = acc.half_area() * count as f32 + right_cost[i + 1];
            if cost < best.0 {
                best = (cost, axis, i);
            }
        }
    }
    let (cost, axis, bin) = best;
    if !cost.is_finite() {
        return Split::Leaf;
    }
    let split_cost = ctx.options.traversal_cost + cost / parent_area;
    if split_cost >= n as f32 && n <= ctx.options.max_leaf_size as usize {
        return Split::Leaf;
    }
    let mid = partition(prims, |p| {
        binning.bin(ctx.centroids[p as usize], axis) <= bin
    });
    if mid == 0 || mid == n {
        return Split::At(n / 2);
    }
    Split::At(mid)
}

fn merge(mut a: Vec<Bin>, b: Vec<Bin>) -> Vec<Bin> {
    for (x, y) in a.iter_mut().zip(&b) {
        x.bounds = x.bounds.union(y.bounds);
        x.count += y.count;
    }
    a
}

/// The union of the primitives' boxes and the box of their centroids.
fn range_bounds(ctx: &Context, prims: &[u32], parallel: bool) -> (Aabb, Aabb) {
    let one = |p: &u32| {
        let c = ctx.centroids[*p as usize];
        (ctx.boxes[*p as usize], Aabb::new(c, c))
    };
    let join = |a: (Aabb, Aabb), b: (Aabb, Aabb)| (a.0.union(b.0), a.1.union(b.1));
    let empty = (Aabb::EMPTY, Aabb::EMPTY);
    if parallel {
        prims
            .par_iter()
            .with_min_len(4096)
            .map(one)
            .reduce(|| empty, join)
    } else {
        prims.iter().map(one).fold(empty, join)
    }
}

/// Moves the elements for which `left` holds to the front; returns how many.
fn partition(items: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let (mut i, mut j) = (0, items.len());
    while i < j {
        if left(items[i]) {
            i += 1;
        } else {
            j -= 1;
            items.swap(i, j);
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_are_those_a_saturating_cast_gives_whatever_the_input() {
        let binning = Binning {
            origin: Vec3A::ZERO,
            scale: Vec3A::ONE,
            last: 31,
        };
        let inputs = [
            f32::NAN,
            f32::NEG_INFINITY,
            -1e30,
            -1.5,
            -0.5,
            -0.0,
            0.0,
            1e-45,
            0.999,
            1.0,
            17.5,
            30.999,
            31.0,
            31.5,
            1e30,
            f32::MAX,
            f32::INFINITY,
        ];
        for x in inputs {
            // Rust's `as` saturates (NaN to 0): the conversion the clamp
            // stands in for.
            let expected = (x as usize).min(31);
            assert_eq!(binning.index(x), expected, "{x}");
        }
    }
}
