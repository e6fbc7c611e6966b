//! Conservative scan conversion on a texel grid: every texel whose square,
//! grown by a margin, meets a convex polygon (or a segment) is visited.
//!
//! A texel `(x, y)` covers `[x, x + 1] x [y, y + 1]`. For each row band
//! grown by the margin, the polygon's extent along the row is found from
//! its edges clipped to the band: a convex polygon meets the band in a
//! convex set whose leftmost and rightmost points lie on its boundary, so
//! the edges alone give them.

use glam::DVec3;

/// A convex polygon: a triangle clipped by up to five planes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Polygon {
    corners: [DVec3; 8],
    count: usize,
}

impl Polygon {
    pub fn triangle(t: &[DVec3; 3]) -> Self {
        let mut corners = [DVec3::ZERO; 8];
        corners[..3].copy_from_slice(t);
        Self { corners, count: 3 }
    }

    pub fn corners(&self) -> &[DVec3] {
        &self.corners[..self.count]
    }

    /// The part where `side >= 0` (`side` affine), or `None` when that
    /// leaves no area. A convex polygon gains at most one corner per
    /// plane; should rounding make it gain more than fit, the polygon is
    /// returned unclipped, which holds the part (a triangle, clipped
    /// first by the near plane, keeps at most four corners whatever the
    /// rounding).
    pub fn clipped(&self, side: impl Fn(DVec3) -> f64) -> Option<Self> {
        let c = self.corners();
        let s: [f64; 8] = std::array::from_fn(|i| if i < c.len() { side(c[i]) } else { 0.0 });
        if s[..c.len()].iter().all(|&v| v >= 0.0) {
            return Some(*self);
        }
        let mut out = [DVec3::ZERO; 16];
        let mut count = 0;
        for i in 0..c.len() {
            let j = (i + 1) % c.len();
            if s[i] >= 0.0 {
                out[count] = c[i];
                count += 1;
            }
            if (s[i] >= 0.0) != (s[j] >= 0.0) {
                out[count] = c[i] + (c[j] - c[i]) * (s[i] / (s[i] - s[j]));
                count += 1;
            }
        }
        if count > 8 {
            return Some(*self);
        }
        let mut corners = [DVec3::ZERO; 8];
        corners[..count].copy_from_slice(&out[..count]);
        (count >= 3).then_some(Self { corners, count })
    }
}

/// Calls `visit(y, x0, x1)` for every row of the texels `bounds` (`[x0,
/// y0, x1, y1]`, inclusive) with the inclusive range of texels whose
/// square grown by `margin` meets the convex polygon `corners` (texel
/// coordinates, either winding; two corners make a segment).
pub(super) fn conservative(
    corners: &[[f64; 2]],
    margin: f64,
    bounds: [u32; 4],
    mut visit: impl FnMut(u32, u32, u32),
) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for c in corners {
        lo = lo.min(c[1]);
        hi = hi.max(c[1]);
    }
    let [bx0, by0, bx1, by1] = bounds.map(|b| b as f64);
    let first_row = (lo - margin).floor().max(by0);
    let last_row = (hi + margin).floor().min(by1);
    if first_row.partial_cmp(&last_row).is_none_or(|o| o.is_gt()) {
        return;
    }
    for y in first_row as u32..=last_row as u32 {
        let (b0, b1) = (y as f64 - margin, y as f64 + 1.0 + margin);
        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..corners.len() {
            let (p, q) = (corners[i], corners[(i + 1) % corners.len()]);
            // The part of edge p -> q inside the band, by its parameter.
            let (mut s0, mut s1) = (0.0f64, 1.0f64);
            let dy = q[1] - p[1];
            if dy == 0.0 {
                if p[1] < b0 || p[1] > b1 {
                    continue;
                }
            } else {
                let (mut a, mut b) = ((b0 - p[1]) / dy, (b1 - p[1]) / dy);
                if a > b {
                    std::mem::swap(&mut a, &mut b);
                }
                s0 = s0.max(a);
                s1 = s1.min(b);
                if s0 > s1 {
                    continue;
                }
            }
            for s in [s0, s1] {
                let x = p[0] + (q[0] - p[0]) * s;
                x0 = x0.min(x);
                x1 = x1.max(x);
            }
        }
        let first = (x0 - margin).floor().max(bx0);
        let last_x = (x1 + margin).floor().min(bx1);
        if first.partial_cmp(&last_x).is_none_or(|o| o.is_gt()) {
            continue;
        }
        visit(y, first as u32, last_x as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texels(corners: &[[f64; 2]], margin: f64) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        conservative(corners, margin, [0, 0, 15, 15], |y, x0, x1| {
            out.extend((x0..=x1).map(|x| (x, y)))
        });
        out
    }

    #[test]
    fn a_thin_sliver_between_texel_centres_is_still_visited() {
        // A needle along y = 3.2 never covers a texel centre.
        let t = texels(&[[1.1, 3.2], [9.9, 3.2001], [1.1, 3.2002]], 0.0);
        assert_eq!(t, (1..=9).map(|x| (x, 3)).collect::<Vec<_>>());
    }

    #[test]
    fn a_margin_reaches_the_neighbours_and_a_segment_is_covered() {
        let t = texels(&[[4.5, 4.5], [4.6, 4.6]], 0.0);
        assert_eq!(t, vec![(4, 4)]);
        let t = texels(&[[4.5, 4.5], [4.6, 4.6]], 0.6);
        assert_eq!(t.len(), 9);
        // Exactly on a texel border: the smallest margin reaches both.
        let t = texels(&[[2.0, 0.5], [2.0, 0.7]], 1e-9);
        assert_eq!(t, vec![(1, 0), (2, 0)]);
    }

    #[test]
    fn every_texel_a_dense_sample_of_the_polygon_falls_in_is_visited() {
        let tri = [[0.3, 0.2], [13.7, 5.1], [6.2, 15.4]];
        let t = texels(&tri, 0.0);
        for i in 0..=200 {
            for j in 0..=200 - i {
                let (a, b) = (i as f64 / 200.0, j as f64 / 200.0);
                let x = tri[0][0] + a * (tri[1][0] - tri[0][0]) + b * (tri[2][0] - tri[0][0]);
                let y = tri[0][1] + a * (tri[1][1] - tri[0][1]) + b * (tri[2][1] - tri[0][1]);
                assert!(
                    t.contains(&(x.floor() as u32, y.floor() as u32)),
                    "({x}, {y})"
                );
            }
        }
    }
}
