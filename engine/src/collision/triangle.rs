//! Exact triangle–triangle intersection.
//!
//! Two closed triangles intersect exactly when an edge of one meets the
//! other: their intersection is convex, and each of its extreme points lies
//! on an edge of one triangle. So the test is six segment–triangle tests,
//! each decided by the signs of Shewchuk's orientation predicates (the
//! `robust` crate), which are exact for every finite input: touching,
//! edge-on and coplanar configurations are decided as they are, not as
//! rounding makes them look. Coplanar cases drop to 2D on an axis where
//! the triangle's projection keeps its area (chosen by the exact 2D
//! predicate, not by a rounded normal).
//!
//! A zero-area triangle is a segment or a point: it meets a proper
//! triangle where one of its edges does; two zero-area triangles are
//! reported apart (they bound no surface).

use glam::DVec3;
use robust::{orient2d, orient3d, Coord, Coord3D};

fn c3(p: DVec3) -> Coord3D<f64> {
    Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// Sign of the orientation of `d` against the plane `a, b, c`.
pub(super) fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> i8 {
    sign(orient3d(c3(a), c3(b), c3(c), c3(d)))
}

fn sign(x: f64) -> i8 {
    (x > 0.0) as i8 - (x < 0.0) as i8
}

/// `p` projected by dropping coordinate `axis`.
fn drop_axis(p: DVec3, axis: usize) -> Coord<f64> {
    let (x, y) = match axis {
        0 => (p.y, p.z),
        1 => (p.z, p.x),
        _ => (p.x, p.y),
    };
    Coord { x, y }
}

fn orient_2d(a: Coord<f64>, b: Coord<f64>, c: Coord<f64>) -> i8 {
    sign(orient2d(a, b, c))
}

/// An axis whose projection keeps the triangle's area, or `None` when the
/// triangle has none (its corners are collinear).
fn projection_axis(t: &[DVec3; 3]) -> Option<usize> {
    (0..3).rev().find(|&axis| {
        let [a, b, c] = t.map(|p| drop_axis(p, axis));
        orient_2d(a, b, c) != 0
    })
}

/// Whether closed 2D segments `p q` and `r s` meet.
fn segments_meet_2d(p: Coord<f64>, q: Coord<f64>, r: Coord<f64>, s: Coord<f64>) -> bool {
    let (d1, d2) = (orient_2d(r, s, p), orient_2d(r, s, q));
    let (d3, d4) = (orient_2d(p, q, r), orient_2d(p, q, s));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    // A point collinear with a segment lies on it when inside its box.
    let on = |a: Coord<f64>, b: Coord<f64>, x: Coord<f64>| {
        x.x >= a.x.min(b.x) && x.x <= a.x.max(b.x) && x.y >= a.y.min(b.y) && x.y <= a.y.max(b.y)
    };
    (d1 == 0 && on(r, s, p))
        || (d2 == 0 && on(r, s, q))
        || (d3 == 0 && on(p, q, r))
        || (d4 == 0 && on(p, q, s))
}

/// Whether 2D point `x` lies in the closed triangle `t` of orientation `turn`.
fn inside_2d(t: &[Coord<f64>; 3], turn: i8, x: Coord<f64>) -> bool {
    (0..3).all(|i| orient_2d(t[i], t[(i + 1) % 3], x) * turn >= 0)
}

/// Whether the closed segment `p q` meets the closed triangle `t`, which
/// has area; `dp` and `dq` are the sides of `p` and `q` against its plane.
fn segment_meets_triangle(
    (p, dp): (DVec3, i8),
    (q, dq): (DVec3, i8),
    t: &[DVec3; 3],
    axis: usize,
) -> bool {
    let [a, b, c] = *t;
    if dp * dq > 0 {
        return false;
    }
    if dp == 0 && dq == 0 {
        let tri = t.map(|v| drop_axis(v, axis));
        let turn = orient_2d(tri[0], tri[1], tri[2]);
        let (p2, q2) = (drop_axis(p, axis), drop_axis(q, axis));
        return inside_2d(&tri, turn, p2)
            || inside_2d(&tri, turn, q2)
            || (0..3).any(|i| segments_meet_2d(p2, q2, tri[i], tri[(i + 1) % 3]));
    }
    // The segment reaches the plane at one point: in the triangle exactly
    // when the line through it passes inside every edge, or on one.
    let s = [orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a)];
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

/// Relative error bound of the plane distance in [`sides`]: 18 units of
/// rounding (`2^-53`), twice what its eight roundings can reach.
const SIDE_FILTER: f64 = 2e-15;

/// Below this magnitude [`sides`]' bound could underflow: the exact
/// predicate decides.
const SIDE_FILTER_FLOOR: f64 = 1e-250;

/// `orient(t[0], t[1], t[2], p)` for each corner `p` of `u`, exactly, the
/// plane's normal computed once. The distance `d = n · (p − t[0])`, `n =
/// (t[1] − t[0]) × (t[2] − t[0])`, is `−orient3d` up to rounding: three
/// differences, a product and a difference per component of `n`, and a
/// product and two sums in the dot put it within `γ8 Σ |q_i| P_i` of the
/// true value (`P_i`: the component's two products' magnitudes, `q = p −
/// t[0]`). Its sign is kept where `|d|` exceeds that bound, computed
/// generously; the predicate decides the rest (the points on the plane, or
/// within rounding of it). Most of a cloth's candidate pairs are settled by
/// the first three signs, each far cheaper than an `orient3d`.
fn sides(t: &[DVec3; 3], u: &[DVec3; 3]) -> [i8; 3] {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let n = e1.cross(e2);
    let magnitude = DVec3::new(
        (e1.y * e2.z).abs() + (e1.z * e2.y).abs(),
        (e1.z * e2.x).abs() + (e1.x * e2.z).abs(),
        (e1.x * e2.y).abs() + (e1.y * e2.x).abs(),
    );
    u.map(|p| {
        let q = p - t[0];
        let d = n.dot(q);
        let bound = SIDE_FILTER * q.abs().dot(magnitude);
        if d.abs() > bound && bound > SIDE_FILTER_FLOOR {
            -sign(d)
        } else {
            orient(t[0], t[1], t[2], p)
        }
    })
}

/// Whether closed triangles `a` and `b` intersect, decided exactly for the
/// given coordinates.
pub fn triangles_intersect(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    // Each triangle's corners against the other's plane, once: most
    // candidate pairs lie strictly on one side and are settled here (`b`
    // beside `a`'s plane before `a`'s corners are looked at: a cloth's
    // candidates two rings apart mostly are), and the edge tests below
    // reuse the signs.
    let one_side = |s: &[i8; 3]| s.iter().all(|&x| x > 0) || s.iter().all(|&x| x < 0);
    let of_b = sides(a, b);
    if one_side(&of_b) {
        return false;
    }
    let of_a = sides(b, a);
    if one_side(&of_a) {
        return false;
    }
    // The edges of `u` (corners with their sides of `t`'s plane) against `t`.
    let hits = |u: &[DVec3; 3], s: &[i8; 3], t: &[DVec3; 3], axis: usize| {
        (0..3).any(|i| {
            let j = (i + 1) % 3;
            segment_meets_triangle((u[i], s[i]), (u[j], s[j]), t, axis)
        })
    };
    match (projection_axis(a), projection_axis(b)) {
        (Some(axis_a), Some(axis_b)) => hits(a, &of_a, b, axis_b) || hits(b, &of_b, a, axis_a),
        (None, Some(axis_b)) => hits(a, &of_a, b, axis_b),
        (Some(axis_a), None) => hits(b, &of_b, a, axis_a),
        (None, None) => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The separating-axis test in exact integer arithmetic: an independent
    /// reference for triangles with area on an integer grid. Closed sets
    /// are apart exactly when some axis among the normals, the edge cross
    /// products and the in-plane edge normals separates them strictly.
    fn sat_intersect(a: &[[i64; 3]; 3], b: &[[i64; 3]; 3]) -> bool {
        type V = [i128; 3];
        let v = |p: [i64; 3]| p.map(i128::from);
        let sub = |p: V, q: V| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
        let cross = |p: V, q: V| {
            [
                p[1] * q[2] - p[2] * q[1],
                p[2] * q[0] - p[0] * q[2],
                p[0] * q[1] - p[1] * q[0],
            ]
        };
        let dot = |p: V, q: V| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
        let (a, b) = (a.map(v), b.map(v));
        let edges = |t: [V; 3]| [sub(t[1], t[0]), sub(t[2], t[1]), sub(t[0], t[2])];
        let (ea, eb) = (edges(a), edges(b));
        let (na, nb) = (cross(ea[0], ea[1]), cross(eb[0], eb[1]));
        let mut axes = vec![na, nb];
        for &e in &ea {
            axes.extend(eb.iter().map(|&f| cross(e, f)));
            axes.push(cross(na, e));
        }
        axes.extend(eb.iter().map(|&f| cross(nb, f)));
        !axes.iter().filter(|&&x| x != [0; 3]).any(|&axis| {
            let range = |t: [V; 3]| {
                let d = t.map(|p| dot(p, axis));
                (*d.iter().min().unwrap(), *d.iter().max().unwrap())
            };
            let ((lo_a, hi_a), (lo_b, hi_b)) = (range(a), range(b));
            hi_a < lo_b || hi_b < lo_a
        })
    }

    fn has_area(t: &[[i64; 3]; 3]) -> bool {
        let d = |i: usize, k: usize| t[i][k] - t[0][k];
        let n = [
            d(1, 1) * d(2, 2) - d(1, 2) * d(2, 1),
            d(1, 2) * d(2, 0) - d(1, 0) * d(2, 2),
            d(1, 0) * d(2, 1) - d(1, 1) * d(2, 0),
        ];
        n != [0; 3]
    }

    struct Rng(u64);
    impl Rng {
        fn below(&mut self, n: u64) -> i64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 33) % n) as i64
        }
    }

    fn to_f64(t: &[[i64; 3]; 3], scale: f64, shift: f64) -> [DVec3; 3] {
        t.map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) * scale + DVec3::splat(shift))
    }

    /// Random triangles on small integer grids touch, share edges, lie
    /// coplanar and cross edge-on all the time; the exact test agrees with
    /// the integer separating-axis test on every pair, at every scale.
    #[test]
    fn agrees_with_exact_separating_axes_on_grid_triangles() {
        let mut rng = Rng(42);
        let mut counts = [0usize; 2];
        for trial in 0..60_000 {
            // Some pairs in a common plane z = 0, to make coplanar cases.
            let flat = trial % 3 == 0;
            let tri = |rng: &mut Rng| -> [[i64; 3]; 3] {
                std::array::from_fn(|_| {
                    let z = if flat { 0 } else { rng.below(5) - 2 };
                    [rng.below(5) - 2, rng.below(5) - 2, z]
                })
            };
            let (a, b) = (tri(&mut rng), tri(&mut rng));
            if !has_area(&a) || !has_area(&b) {
                continue;
            }
            let expected = sat_intersect(&a, &b);
            counts[expected as usize] += 1;
            // Scaling by a power of two and shifting by a representable
            // amount keep every coordinate exact.
            for (scale, shift) in [
                (1.0, 0.0),
                (0.125, 3.0),
                (1024.0, -5e5),
                (2f64.powi(-20), 0.0),
            ] {
                let (fa, fb) = (to_f64(&a, scale, shift), to_f64(&b, scale, shift));
                assert_eq!(
                    triangles_intersect(&fa, &fb),
                    expected,
                    "{a:?} {b:?} x{scale}+{shift}"
                );
                assert_eq!(
                    triangles_intersect(&fb, &fa),
                    expected,
                    "{b:?} {a:?} swapped"
                );
            }
        }
        assert!(counts[0] > 5_000 && counts[1] > 5_000, "{counts:?}");
    }

    /// The filtered signs against the exact predicate alone, on points
    /// rounded onto a triangle's plane (so within rounding of it, on
    /// either side or on it), at scales from 1e-3 to 1e4 and away from the
    /// origin: where rounding decides a sign, the filter must not. The
    /// rounded distance's own sign is wrong on many of these points (the
    /// test checks that too, so it cannot pass for want of hard cases).
    #[test]
    fn filtered_sides_are_the_exact_orientations() {
        let mut rng = Rng(17);
        let (mut off_plane, mut rounding_misleads) = (0, 0);
        for round in 0..20_000 {
            let scale = [1e-3, 1.0, 1e4][round % 3];
            let shift = [0.0, 1.0, 100.0][round / 3 % 3] * scale;
            let mut coord = || (rng.below(2001) - 1000) as f64 / 997.0 * scale + shift;
            let t = [(); 3].map(|_| DVec3::new(coord(), coord(), coord()));
            let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
            let mut weight = || (rng.below(3001) - 1000) as f64 / 991.0;
            let u = [(); 3].map(|_| t[0] + e1 * weight() + e2 * weight());
            let exact = u.map(|p| orient(t[0], t[1], t[2], p));
            off_plane += exact.iter().filter(|&&s| s != 0).count();
            let n = e1.cross(e2);
            rounding_misleads += u
                .iter()
                .zip(&exact)
                .filter(|(p, &s)| -sign(n.dot(**p - t[0])) != s)
                .count();
            assert_eq!(sides(&t, &u), exact, "{t:?} {u:?}");
        }
        assert!(off_plane > 10_000, "{off_plane}");
        assert!(rounding_misleads > 1_000, "{rounding_misleads}");
    }

    #[test]
    fn touching_at_a_vertex_or_an_edge_counts_and_a_hair_apart_does_not() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let above = |z: f64| {
            [
                DVec3::new(0.2, 0.2, z),
                DVec3::new(0.2, 0.2, z + 1.0),
                DVec3::new(0.3, 0.2, z + 1.0),
            ]
        };
        assert!(triangles_intersect(&t, &above(0.0)));
        assert!(!triangles_intersect(&t, &above(f64::MIN_POSITIVE)));
        assert!(triangles_intersect(&t, &above(-1e-300)));
        // Sharing only the edge from (1, 0, 0) to (0, 1, 0), folded up.
        let folded = [DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 1.0)];
        assert!(triangles_intersect(&t, &folded));
        // A zero-area triangle (a segment) piercing the face.
        let needle = [
            DVec3::new(0.1, 0.1, -1.0),
            DVec3::new(0.1, 0.1, 1.0),
            DVec3::new(0.1, 0.1, 0.5),
        ];
        assert!(triangles_intersect(&t, &needle));
        assert!(!triangles_intersect(&needle, &needle));
    }
}
