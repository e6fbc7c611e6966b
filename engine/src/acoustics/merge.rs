//! Merging the cells of a frustum that meet one plane group into few
//! rectangles (Fig. 6.3 of the dissertation), each of which becomes one
//! secondary frustum, and gathering a frustum's `(group, cell)` pairs by
//! group ([`CellSets`]).
//!
//! The rectangles cover every given cell, so no path is lost; a rectangle
//! may also cover cells that were not given, which only costs validation.
//! Conservative tracing then cuts each rectangle to the window bounds of
//! the group's triangles it saw ([`GroupWindows`]), which every path
//! through the rectangle meets.
//! Splitting quad-tree fashion until each rectangle is at least half full
//! keeps both the number of frusta and the wasted area small.

/// Rectangles `[i0, i1, j0, j1]` (inclusive cell ranges) covering `cells`
/// (`(_, i * n + j)` pairs) of an `n x n` grid, `n <= 64`, appended to `out`.
pub(crate) fn merge_cells(cells: &[(u32, u32)], n: usize, out: &mut Vec<[u32; 4]>) {
    let mut rows = [0u64; 64];
    for &(_, c) in cells {
        let (i, j) = (c as usize / n, c as usize % n);
        rows[i] |= 1 << j;
    }
    split(&rows, [0, n as u32 - 1, 0, n as u32 - 1], out);
}

/// Scratch for [`CellSets::sort_dedup`], kept across frusta so that
/// sorting a frustum's pairs allocates nothing.
#[derive(Default)]
pub(crate) struct CellSets {
    /// Per plane group, the index of its set while it has one.
    set_of: Vec<u32>,
    /// `(group, set)` of the groups met, in the order first met.
    groups: Vec<(u32, u32)>,
    /// Each set's cells as bits, `words` per set.
    bits: Vec<u64>,
}

impl CellSets {
    /// Sorts `(group, cell)` pairs (cells below `cells`) by group, then
    /// cell, and drops repeats: what sorting the pairs and deduplicating
    /// gives, by collecting each group's cells as bits instead. Sorting
    /// the pairs of every frustum was a fifth of a conservative trace in
    /// hall-10k (order 3: a few hundred pairs a frustum, most repeated).
    pub(crate) fn sort_dedup(&mut self, touched: &mut Vec<(u32, u32)>, cells: usize) {
        let words = cells.div_ceil(64).max(1);
        self.groups.clear();
        self.bits.clear();
        for &(group, cell) in touched.iter() {
            let g = group as usize;
            if g >= self.set_of.len() {
                self.set_of.resize(g + 1, u32::MAX);
            }
            if self.set_of[g] == u32::MAX {
                self.set_of[g] = self.groups.len() as u32;
                self.groups.push((group, self.set_of[g]));
                self.bits.resize(self.bits.len() + words, 0);
            }
            let at = self.set_of[g] as usize * words + cell as usize / 64;
            self.bits[at] |= 1 << (cell % 64);
        }
        self.groups.sort_unstable_by_key(|&(group, _)| group);
        touched.clear();
        for &(group, set) in &self.groups {
            self.set_of[group as usize] = u32::MAX;
            let row = &self.bits[set as usize * words..(set as usize + 1) * words];
            for (w, &word) in row.iter().enumerate() {
                let mut bits = word;
                while bits != 0 {
                    touched.push((group, (w * 64) as u32 + bits.trailing_zeros()));
                    bits &= bits - 1;
                }
            }
        }
    }
}

/// Per plane group, the window bounds `[x0, y0, x1, y1]` of the triangles
/// of it a frustum sees: a secondary frustum needs no more of its cells
/// than that, since every path through it meets one of them.
#[derive(Default)]
pub(crate) struct GroupWindows {
    /// Per group id, its index in `windows` (`u32::MAX`: none yet).
    slot_of: Vec<u32>,
    windows: Vec<(u32, [f64; 4])>,
}

impl GroupWindows {
    pub(crate) fn clear(&mut self) {
        for &(group, _) in &self.windows {
            self.slot_of[group as usize] = u32::MAX;
        }
        self.windows.clear();
    }

    /// Grows `group`'s bounds to hold `b`.
    pub(crate) fn widen(&mut self, group: u32, b: [f64; 4]) {
        let g = group as usize;
        if g >= self.slot_of.len() {
            self.slot_of.resize(g + 1, u32::MAX);
        }
        match self.slot_of[g] {
            u32::MAX => {
                self.slot_of[g] = self.windows.len() as u32;
                self.windows.push((group, b));
            }
            at => {
                let w = &mut self.windows[at as usize].1;
                *w = [
                    w[0].min(b[0]),
                    w[1].min(b[1]),
                    w[2].max(b[2]),
                    w[3].max(b[3]),
                ];
            }
        }
    }

    /// Window rectangle `[x0, x1, y0, y1]` cut to `group`'s bounds, if it
    /// has any and they meet it.
    pub(crate) fn cut(&self, group: u32, [x0, x1, y0, y1]: [f64; 4]) -> [f64; 4] {
        let Some(&at) = self
            .slot_of
            .get(group as usize)
            .filter(|&&at| at != u32::MAX)
        else {
            return [x0, x1, y0, y1];
        };
        let w = self.windows[at as usize].1;
        let cut = [x0.max(w[0]), x1.min(w[2]), y0.max(w[1]), y1.min(w[3])];
        if cut[0] < cut[1] && cut[2] < cut[3] {
            cut
        } else {
            [x0, x1, y0, y1]
        }
    }
}

fn split(rows: &[u64; 64], rect: [u32; 4], out: &mut Vec<[u32; 4]>) {
    let Some([i0, i1, j0, j1]) = bounds(rows, rect) else {
        return;
    };
    let mask = column_mask(j0, j1);
    let filled: u32 = (i0..=i1)
        .map(|i| (rows[i as usize] & mask).count_ones())
        .sum();
    let area = (i1 - i0 + 1) * (j1 - j0 + 1);
    if 2 * filled >= area {
        out.push([i0, i1, j0, j1]);
    } else if i1 - i0 >= j1 - j0 {
        let mid = (i0 + i1) / 2;
        split(rows, [i0, mid, j0, j1], out);
        split(rows, [mid + 1, i1, j0, j1], out);
    } else {
        let mid = (j0 + j1) / 2;
        split(rows, [i0, i1, j0, mid], out);
        split(rows, [i0, i1, mid + 1, j1], out);
    }
}

fn column_mask(j0: u32, j1: u32) -> u64 {
    (u64::MAX >> (63 - j1)) & (u64::MAX << j0)
}

/// The bounding rectangle of the set cells inside `rect`.
fn bounds(rows: &[u64; 64], [i0, i1, j0, j1]: [u32; 4]) -> Option<[u32; 4]> {
    let mask = column_mask(j0, j1);
    let mut used = (i0..=i1).filter(|&i| rows[i as usize] & mask != 0);
    let first = used.next()?;
    let (last, cols) = used.fold((first, rows[first as usize] & mask), |(_, acc), i| {
        (i, acc | (rows[i as usize] & mask))
    });
    Some([
        first,
        last,
        cols.trailing_zeros(),
        63 - cols.leading_zeros(),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn covered(rects: &[[u32; 4]], i: u32, j: u32) -> bool {
        rects
            .iter()
            .any(|r| (r[0]..=r[1]).contains(&i) && (r[2]..=r[3]).contains(&j))
    }

    #[test]
    fn group_windows_cut_rectangles_to_their_groups_bounds_and_reset() {
        let mut w = GroupWindows::default();
        let rect = [0.0, 0.5, 0.25, 0.75];
        // No bounds for a group: the rectangle as it is.
        assert_eq!(w.cut(7, rect), rect);
        w.widen(7, [0.1, 0.3, 0.2, 0.4]);
        w.widen(7, [0.15, 0.35, 0.3, 0.5]);
        w.widen(2, [0.9, 0.9, 1.0, 1.0]);
        assert_eq!(w.cut(7, rect), [0.1, 0.3, 0.3, 0.5]);
        // Bounds apart from the rectangle (a group's own cells never give
        // such) leave it whole: the safe side.
        assert_eq!(w.cut(2, rect), rect);
        // Partly outside: cut to the overlap.
        w.widen(3, [0.4, 0.7, 0.9, 0.8]);
        assert_eq!(w.cut(3, rect), [0.4, 0.5, 0.7, 0.75]);
        w.clear();
        assert_eq!(w.cut(7, rect), rect);
        w.widen(7, [0.2, 0.3, 0.3, 0.4]);
        assert_eq!(w.cut(7, rect), [0.2, 0.3, 0.3, 0.4]);
    }

    #[test]
    fn a_full_block_is_one_rectangle() {
        let cells: Vec<(u32, u32)> = (2..5)
            .flat_map(|i| (1..4).map(move |j| (0, i * 8 + j)))
            .collect();
        let mut out = Vec::new();
        merge_cells(&cells, 8, &mut out);
        assert_eq!(out, vec![[2, 4, 1, 3]]);
    }

    #[test]
    fn opposite_corners_stay_apart_and_everything_is_covered() {
        let cells = vec![(0, 0), (0, 63 * 64 + 63), (0, 5 * 64 + 40)];
        let mut out = Vec::new();
        merge_cells(&cells, 64, &mut out);
        assert_eq!(out.len(), 3);
        for &(_, c) in &cells {
            assert!(covered(&out, c / 64, c % 64));
        }
        let area: u32 = out
            .iter()
            .map(|r| (r[1] - r[0] + 1) * (r[3] - r[2] + 1))
            .sum();
        assert_eq!(area, 3);
    }

    #[test]
    fn every_rectangle_is_at_least_half_full() {
        let n = 16u32;
        let cells: Vec<(u32, u32)> = (0..n * n)
            .filter(|c| (c * 7919) % 5 < 2)
            .map(|c| (0, c))
            .collect();
        let mut out = Vec::new();
        merge_cells(&cells, n as usize, &mut out);
        for r in &out {
            let inside = cells
                .iter()
                .filter(|&&(_, c)| {
                    (r[0]..=r[1]).contains(&(c / n)) && (r[2]..=r[3]).contains(&(c % n))
                })
                .count() as u32;
            assert!(2 * inside >= (r[1] - r[0] + 1) * (r[3] - r[2] + 1));
        }
        for &(_, c) in &cells {
            assert!(covered(&out, c / n, c % n));
        }
    }

    /// The pairs come out as sorting and deduplicating them gives, for
    /// grids of 1 to 64 cells a side, scattered and large group ids, and a
    /// scratch reused across calls (whose sets must start empty).
    #[test]
    fn cell_sets_sort_and_dedup_as_a_sort_does() {
        let mut sets = CellSets::default();
        let mut state = 12345u64;
        let mut next = |m: u64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) % m
        };
        for case in 0..200 {
            let n = [1, 2, 8, 9, 64][case % 5] as u64;
            let groups = 1 + next(12);
            let pairs: Vec<(u32, u32)> = (0..next(300))
                .map(|_| {
                    (
                        (next(groups) * 977 + next(3) * 100_000) as u32,
                        next(n * n) as u32,
                    )
                })
                .collect();
            let mut expected = pairs.clone();
            expected.sort_unstable();
            expected.dedup();
            let mut touched = pairs;
            sets.sort_dedup(&mut touched, (n * n) as usize);
            assert_eq!(touched, expected, "case {case}");
        }
    }
}
