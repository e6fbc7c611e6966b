//! A memo of the double-double coordinates one search has computed.

use twofloat::TwoFloat;

use super::inclusion::Primitives;

/// Coordinates of F in double-double already computed in this search, by
/// parameters and axis: boxes share corners with their neighbours, and
/// three in five of the coordinates re-evaluated on the sample queries
/// were repeats. Direct-mapped; an entry of an older search is told by its
/// generation, so a search starts without clearing anything.
#[derive(Debug, Default)]
pub(super) struct ExactMemo {
    entries: Vec<MemoEntry>,
    generation: u32,
}

#[derive(Clone, Copy, Debug)]
struct MemoEntry {
    generation: u32,
    axis: u32,
    at: [u64; 3],
    value: TwoFloat,
}

/// The memo holds `2^MEMO_BITS` entries of 48 bytes.
const MEMO_BITS: u32 = 7;

impl ExactMemo {
    pub(super) fn start(&mut self) {
        self.generation = self.generation.wrapping_add(1);
        if self.entries.is_empty() || self.generation == 0 {
            let empty = MemoEntry {
                generation: 0,
                axis: 0,
                at: [0; 3],
                value: TwoFloat::from(0.0),
            };
            self.entries = vec![empty; 1 << MEMO_BITS];
            self.generation = 1;
        }
    }

    /// Coordinate `axis` of F at `(t, u, v)`, as [`Primitives::at`] gives
    /// it.
    #[inline(always)]
    pub(super) fn coordinate<P: Primitives>(
        &mut self,
        primitives: &P,
        axis: usize,
        t: f64,
        u: f64,
        v: f64,
    ) -> TwoFloat {
        let at = [t.to_bits(), u.to_bits(), v.to_bits()];
        let hash = (at[0] ^ at[1].rotate_left(21) ^ at[2].rotate_left(42) ^ axis as u64)
            .wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let entry = &mut self.entries[(hash >> (64 - MEMO_BITS)) as usize];
        if entry.generation == self.generation && entry.axis == axis as u32 && entry.at == at {
            return entry.value;
        }
        let value = primitives.at(axis, t, u, v);
        *entry = MemoEntry {
            generation: self.generation,
            axis: axis as u32,
            at,
            value,
        };
        value
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::collision::continuous::EdgeEdge;

    fn edges(z: f64) -> EdgeEdge {
        let still = |p: DVec3| [p, p * 2.0];
        EdgeEdge {
            a: [
                still(DVec3::new(0.0, 0.0, z)),
                still(DVec3::new(1.0, 0.5, z)),
            ],
            b: [
                still(DVec3::new(0.25, -1.0, 1.0)),
                still(DVec3::new(0.5, 1.0, -1.0)),
            ],
        }
    }

    /// The memo answers as a fresh evaluation on every lookup, over many
    /// more keys than entries (so entries are overwritten and slots
    /// shared), and never with an entry of an earlier search at the same
    /// parameters.
    #[test]
    fn the_memo_answers_as_a_fresh_evaluation() {
        let grid: Vec<f64> = (0..=10).map(|i| f64::from(i) / 10.0).collect();
        let mut memo = ExactMemo::default();
        for z in [0.0, 0.5] {
            let query = edges(z);
            memo.start();
            for _ in 0..2 {
                for &t in &grid {
                    for &u in &grid {
                        for &v in &grid {
                            // The axes of one corner one after another:
                            // where two share a slot, the second finds the
                            // first there.
                            for axis in 0..3 {
                                let fresh: TwoFloat = query.at(axis, t, u, v);
                                let kept = memo.coordinate(&query, axis, t, u, v);
                                assert_eq!((kept.hi(), kept.lo()), (fresh.hi(), fresh.lo()));
                            }
                        }
                    }
                }
            }
        }
    }
}
