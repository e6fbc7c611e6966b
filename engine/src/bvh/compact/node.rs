//! The compact tree's node: four child boxes on an 8-bit grid over the
//! node's own box, and links by base index.
//!
//! 64 bytes, one cache line, where the plain node takes two: an origin and
//! a power-of-two step per axis (15 bytes), one byte per child plane (24),
//! a bit per inner slot (1), the first inner child and first triangle (8),
//! a count per slot (4), and
//! the rebuild heuristic's build-time ratios in bfloat16 (10), which only
//! refit reads but which fill what would be padding. Inner children are
//! stored contiguously in slot order, and so are the leaf slots'
//! triangles, so one index per kind serves the four slots (as in Ylitie et
//! al.'s compressed wide BVH).
//!
//! Decoding is `origin + q * step` in `f32`. `q * step` is exact (a byte
//! times a power of two; coordinates below the mesh limit of 1e15 keep
//! steps far below overflow), so the decoded plane is one correctly rounded sum,
//! the same on every machine and in the encoder, which picks each byte so
//! that the decoded box contains the true one. The robust slab test then
//! holds on decoded boxes as on stored ones.

use glam::Vec4;

use crate::bvh::traverse::Slot;
use crate::bvh::wide::Boxes4;
use crate::geometry::Aabb;

/// The most triangles a compact leaf holds: three leaves' counts sum in
/// one byte (see [`CompactNode4::leaf_first`]).
pub const MAX_LEAF: u32 = 85;

#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct CompactNode4 {
    /// The grid's origin: the minimum of the slots' boxes.
    origin: [f32; 3],
    /// Per axis, the grid step `2^e` stored as the biased exponent `e + 127`.
    exponent: [u8; 3],
    /// Grid coordinates of the slots' minima (x, y, z) and maxima (x, y, z).
    q: [[u8; 4]; 6],
    /// Bit `s` set: slot `s` is an inner node.
    inner: u8,
    /// Inner slots' children are nodes `child..`, in slot order.
    child: u32,
    /// Leaf slots' triangles are `first..`, in slot order.
    first: u32,
    /// Per slot, its triangles: 0 for inner and empty slots.
    count: [u8; 4],
    /// The area ratios at build time (see [`crate::bvh::refit`]), each the
    /// upper half of its `f32`.
    build_ratios: [u16; 5],
}

const _: () = assert!(std::mem::size_of::<CompactNode4>() == 64);

impl Default for CompactNode4 {
    fn default() -> Self {
        Self {
            origin: [0.0; 3],
            exponent: [1; 3],
            q: [
                [u8::MAX; 4],
                [u8::MAX; 4],
                [u8::MAX; 4],
                [0; 4],
                [0; 4],
                [0; 4],
            ],
            inner: 0,
            child: 0,
            first: 0,
            count: [0; 4],
            build_ratios: [bfloat16(1.0); 5],
        }
    }
}

/// The upper half of `x`'s bits: 8 significant bits, plenty for a ratio
/// compared with a 40% threshold.
pub(crate) const fn bfloat16(x: f32) -> u16 {
    (x.to_bits() >> 16) as u16
}

pub(crate) fn from_bfloat16(x: u16) -> f32 {
    f32::from_bits((x as u32) << 16)
}

#[inline(always)]
pub(crate) fn step(exponent: u8) -> f32 {
    f32::from_bits((exponent as u32) << 23)
}

#[inline(always)]
pub(crate) fn decode(origin: f32, q: u8, step: f32) -> f32 {
    origin + q as f32 * step
}

impl CompactNode4 {
    /// The four slot boxes, each containing the box it was encoded from.
    #[inline(always)]
    pub fn boxes(&self) -> Boxes4 {
        let q = grid_lanes(&self.q);
        let mut b = Boxes4::EMPTY;
        for axis in 0..3 {
            let origin = Vec4::splat(self.origin[axis]);
            let step = Vec4::splat(step(self.exponent[axis]));
            b.lo[axis] = origin + q[axis] * step;
            b.hi[axis] = origin + q[3 + axis] * step;
        }
        b
    }

    /// A node whose inner slots' children start at node `child` and whose
    /// leaf slots' triangles start at `first`; `slots` says what each slot
    /// holds (a leaf: its triangle count, at most [`MAX_LEAF`]).
    pub(crate) fn new(child: u32, first: u32, slots: [Slot; 4], counts: [u32; 4]) -> Self {
        let mut n = Self {
            child,
            first,
            ..Self::default()
        };
        for s in 0..4 {
            match slots[s] {
                Slot::Inner(_) => n.inner |= 1 << s,
                Slot::Leaf => {
                    assert!(
                        (1..=MAX_LEAF).contains(&counts[s]),
                        "a compact leaf holds 1 to {MAX_LEAF} triangles"
                    );
                    n.count[s] = counts[s] as u8;
                }
                Slot::Empty => {}
            }
        }
        n
    }

    /// What slot `slot` holds; an inner slot's child is counted from
    /// `child` by the inner slots before it.
    #[inline(always)]
    pub fn slot(&self, slot: usize) -> Slot {
        if self.count[slot] != 0 {
            Slot::Leaf
        } else if self.inner & (1 << slot) != 0 {
            let before = (self.inner & ((1 << slot) - 1)).count_ones();
            Slot::Inner(self.child + before)
        } else {
            Slot::Empty
        }
    }

    /// Triangles in slot `slot`: 0 unless it is a leaf.
    #[inline(always)]
    pub fn count(&self, slot: usize) -> u32 {
        self.count[slot] as u32
    }

    /// First triangle of leaf slot `slot`: the leaf slots before it come
    /// first. The counts before it are summed as bytes of one word, which
    /// [`MAX_LEAF`] keeps from carrying.
    #[inline(always)]
    pub fn leaf_first(&self, slot: usize) -> u32 {
        let below = u32::from_le_bytes(self.count) & ((1u64 << (8 * slot)) - 1) as u32;
        self.first + (below.wrapping_mul(0x0101_0101) >> 24)
    }

    /// The build-time area ratios, as stored.
    pub(crate) fn build_ratios(&self) -> [f32; 5] {
        self.build_ratios.map(from_bfloat16)
    }

    pub(crate) fn set_build_ratios(&mut self, ratios: [f32; 5]) {
        self.build_ratios = ratios.map(bfloat16);
    }

    /// Encodes the slots' boxes (`None`: an empty slot) on a grid over
    /// their union.
    pub(crate) fn set_boxes(&mut self, slots: &[Option<Aabb>; 4]) {
        (self.origin, self.exponent, self.q) = encode_grid(slots);
    }
}

/// The grid of `slots` (`None`: an empty slot) over their union, for a
/// node of any width: per axis its origin and biased exponent, and each
/// slot's codes (minima x, y, z, then maxima), every decoded box holding
/// its slot's box.
pub(crate) fn encode_grid<const N: usize>(
    slots: &[Option<Aabb>; N],
) -> ([f32; 3], [u8; 3], [[u8; N]; 6]) {
    let union = slots.iter().flatten().fold(Aabb::EMPTY, |u, b| u.union(*b));
    let mut origin = [0.0; 3];
    let mut exponent = [0; 3];
    let mut q = [[0; N]; 6];
    for axis in 0..3 {
        let (low, top) = if union.is_empty() {
            (0.0, 0.0)
        } else {
            (union.min[axis], union.max[axis])
        };
        exponent[axis] = grid_exponent(low, top);
        origin[axis] = low;
        let step = step(exponent[axis]);
        for (s, b) in slots.iter().enumerate() {
            (q[axis][s], q[3 + axis][s]) = match b {
                Some(b) => (
                    floor_code(low, step, b.min[axis]),
                    ceil_code(low, step, b.max[axis]),
                ),
                None => (u8::MAX, 0),
            };
        }
    }
    (origin, exponent, q)
}

/// The 24 grid bytes as six vectors of four floats.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn grid_lanes(q: &[[u8; 4]; 6]) -> [Vec4; 6] {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of the x86-64 baseline; the loads read bytes
    // 0..16 and 16..24 of the 24.
    unsafe {
        let p = q.as_ptr() as *const u8;
        let first = _mm_loadu_si128(p as *const __m128i);
        let last = _mm_loadl_epi64(p.add(16) as *const __m128i);
        let zero = _mm_setzero_si128();
        let floats = |words: __m128i| {
            let lo = _mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero));
            let hi = _mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero));
            (Vec4::from(lo), Vec4::from(hi))
        };
        let (lx, ly) = floats(_mm_unpacklo_epi8(first, zero));
        let (lz, hx) = floats(_mm_unpackhi_epi8(first, zero));
        let (hy, hz) = floats(_mm_unpacklo_epi8(last, zero));
        [lx, ly, lz, hx, hy, hz]
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn grid_lanes(q: &[[u8; 4]; 6]) -> [Vec4; 6] {
    q.map(|q| Vec4::new(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32))
}

/// The smallest biased exponent whose grid of 255 steps from `origin`
/// reaches `top` once decoded.
fn grid_exponent(origin: f32, top: f32) -> u8 {
    let extent = (top as f64 - origin as f64).max(0.0);
    let guess = if extent > 0.0 {
        // floor(log2(extent / 255)), read off the double's exponent.
        ((extent / 255.0).to_bits() >> 52) as i32 - 1023 + 127
    } else {
        1
    };
    let mut e = guess.clamp(1, 254) as u8;
    // The grid must reach the top, and a step must leave the origin (on a
    // flat axis too), so that an empty slot's codes (255 above 0) decode
    // to an empty box.
    while e < 254
        && (decode(origin, u8::MAX, step(e)) < top || decode(origin, 1, step(e)) == origin)
    {
        e += 1;
    }
    e
}

/// The largest code whose decoded plane lies at or below `x` (0 always
/// does: it decodes to the origin, the minimum).
fn floor_code(origin: f32, step: f32, x: f32) -> u8 {
    let mut q = ((x as f64 - origin as f64) * (1.0 / step as f64))
        .floor()
        .clamp(0.0, 255.0) as u8;
    while q > 0 && decode(origin, q, step) > x {
        q -= 1;
    }
    while q < u8::MAX && decode(origin, q + 1, step) <= x {
        q += 1;
    }
    q
}

/// The smallest code whose decoded plane lies at or above `x` (255 always
/// does, by the grid's exponent).
fn ceil_code(origin: f32, step: f32, x: f32) -> u8 {
    let mut q = ((x as f64 - origin as f64) * (1.0 / step as f64))
        .ceil()
        .clamp(0.0, 255.0) as u8;
    while q < u8::MAX && decode(origin, q, step) < x {
        q += 1;
    }
    while q > 0 && decode(origin, q - 1, step) >= x {
        q -= 1;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    fn encoded(slots: [Option<Aabb>; 4]) -> Boxes4 {
        let mut n = CompactNode4::default();
        n.set_boxes(&slots);
        n.boxes()
    }

    fn assert_contains(outer: Aabb, inner: Aabb) {
        assert!(
            outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all(),
            "{outer:?} does not contain {inner:?}"
        );
    }

    #[test]
    fn decoded_boxes_contain_the_true_ones_at_every_scale() {
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        for &(offset, size) in &[
            (0.0, 1.0),
            (1e6, 1e-3),
            (-3e14, 1e14),
            (1e-30, 1e-35),
            (5.0, 0.0),
            (-7.25, 1e-7),
        ] {
            for _ in 0..200 {
                let slots: [Option<Aabb>; 4] = std::array::from_fn(|_| {
                    let p = Vec3A::new(next(), next(), next()) * size + Vec3A::splat(offset);
                    let q = Vec3A::new(next(), next(), next()) * size * 0.3;
                    Some(Aabb::new(p, p + q))
                });
                let boxes = encoded(slots);
                for (s, b) in slots.iter().enumerate() {
                    assert_contains(boxes.slot_aabb(s), b.unwrap());
                }
            }
        }
    }

    #[test]
    fn boxes_stay_tight() {
        // A unit box split in four: the grid step is 1/255 of the union, so
        // each decoded plane is within a step of the true one.
        let slots = [0.0f32, 0.25, 0.5, 0.75].map(|x| {
            Some(Aabb::new(
                Vec3A::new(x, 0.0, 0.0),
                Vec3A::new(x + 0.25, 1.0, 1.0),
            ))
        });
        let boxes = encoded(slots);
        for (s, b) in slots.iter().enumerate() {
            let d = boxes.slot_aabb(s);
            let b = b.unwrap();
            assert!((d.min - b.min).abs().max_element() <= 1.0 / 255.0);
            assert!((d.max - b.max).abs().max_element() <= 1.0 / 255.0);
        }
    }

    #[test]
    fn empty_slots_decode_empty_and_flat_boxes_stay_flat() {
        let flat = Aabb::new(Vec3A::new(2.0, 3.0, 4.0), Vec3A::new(2.0, 5.0, 4.0));
        let point = Aabb::new(Vec3A::splat(5.0), Vec3A::splat(5.0));
        for b in [flat, point] {
            let boxes = encoded([Some(b), None, None, None]);
            assert_eq!(boxes.slot_aabb(0).min, b.min);
            assert_eq!(boxes.slot_aabb(0).max.x, b.max.x);
            for s in 1..4 {
                let e = boxes.slot_aabb(s);
                assert!(e.min.x > e.max.x && e.min.z > e.max.z, "{e:?}");
            }
        }
    }

    #[test]
    fn the_sse2_decode_is_the_portable_one() {
        let n = CompactNode4 {
            q: std::array::from_fn(|i| std::array::from_fn(|j| (i * 40 + j * 13) as u8)),
            ..CompactNode4::default()
        };
        let portable =
            n.q.map(|q| Vec4::new(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32));
        assert_eq!(grid_lanes(&n.q), portable);
    }

    #[test]
    fn leaf_starts_sum_the_counts_before_without_carrying() {
        let slots = [Slot::Leaf, Slot::Leaf, Slot::Leaf, Slot::Leaf];
        let n = CompactNode4::new(0, 1000, slots, [MAX_LEAF; 4]);
        let firsts: Vec<u32> = (0..4).map(|s| n.leaf_first(s)).collect();
        assert_eq!(firsts, [1000, 1085, 1170, 1255]);
        let mixed = [Slot::Inner(0), Slot::Leaf, Slot::Empty, Slot::Leaf];
        let n = CompactNode4::new(7, 20, mixed, [0, 3, 0, 85]);
        assert_eq!(n.leaf_first(3), 23);
        assert_eq!(n.slot(0), Slot::Inner(7));
        assert_eq!(n.slot(2), Slot::Empty);
        assert_eq!(n.count(3), 85);
    }
}
