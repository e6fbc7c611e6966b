//! Morton-curve splits for the LBVH and hybrid builders (Lauterbach et al.
//! 2009; dissertation, section 5.3): primitives sorted along a 63-bit Morton
//! curve split where the highest differing bit of their codes flips.

use glam::Vec3A;
use rayon::prelude::*;

use super::Split;
use crate::geometry::Aabb;

/// Sorts `prims` along the Morton curve of their centroids and returns the
/// sorted codes.
pub(super) fn sort_by_code(
    centroids: &[Vec3A],
    prims: &mut [u32],
    parallel_threshold: usize,
) -> Vec<u64> {
    let bounds = Aabb::of_points(centroids.iter().map(|&c| c.into()));
    let extent = bounds.extent();
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(((1u32 << 21) - 1) as f32) / extent,
        Vec3A::ZERO,
    );
    let code = |p: &u32| {
        let q = (centroids[*p as usize] - bounds.min) * scale;
        (morton_code(q), *p)
    };
    let mut keyed: Vec<(u64, u32)> = if prims.len() >= parallel_threshold {
        let mut k: Vec<_> = prims.par_iter().map(code).collect();
        k.par_sort_unstable();
        k
    } else {
        let mut k: Vec<_> = prims.iter().map(code).collect();
        k.sort_unstable();
        k
    };
    for (slot, (_, p)) in prims.iter_mut().zip(&keyed) {
        *slot = *p;
    }
    keyed.drain(..).map(|(c, _)| c).collect()
}

/// Interleaves three 21-bit grid coordinates into a 63-bit code.
fn morton_code(q: Vec3A) -> u64 {
    let grid = |v: f32| spread((v.max(0.0) as u64).min((1 << 21) - 1));
    grid(q.x) << 2 | grid(q.y) << 1 | grid(q.z)
}

/// Spreads the low 21 bits of `v` so that two zero bits follow each.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// Splits a sorted range of codes at its highest differing bit; ranges of at
/// most `max_leaf` primitives, or with one code, become leaves.
pub(super) fn split(codes: &[u64], max_leaf: usize) -> Split {
    let n = codes.len();
    let (first, last) = (codes[0], codes[n - 1]);
    if n <= max_leaf || first == last {
        return Split::Leaf;
    }
    let bit = 63 - (first ^ last).leading_zeros();
    let mask = 1u64 << bit;
    Split::At(codes.partition_point(|&c| c & mask == 0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_interleave_axes() {
        assert_eq!(spread(0b1), 0b1);
        assert_eq!(spread(0b11), 0b1001);
        assert_eq!(spread((1 << 21) - 1), 0x1249_2492_4924_9249);
        assert_eq!(morton_code(Vec3A::new(1.0, 0.0, 0.0)), 0b100);
        assert_eq!(morton_code(Vec3A::new(0.0, 1.0, 1.0)), 0b011);
    }

    #[test]
    fn split_at_highest_differing_bit() {
        let codes = [0b0001, 0b0010, 0b0100, 0b1000, 0b1001];
        assert!(matches!(split(&codes, 1), Split::At(3)));
        assert!(matches!(split(&[5, 5, 5], 1), Split::Leaf));
    }
}
