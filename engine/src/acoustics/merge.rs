//! Merging the cells of a frustum that meet one plane group into few
//! rectangles (Fig. 6.3 of the dissertation), each of which becomes one
//! secondary frustum.
//!
//! The rectangles cover every given cell, so no path is lost; a rectangle
//! may also cover cells that were not given, which only costs validation.
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
}
