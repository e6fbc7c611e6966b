//! The distance between two triangles, in f64: zero when they intersect
//! (decided exactly), else the least of the vertex–face and edge–edge
//! distances, one of which is always the closest pair of two disjoint
//! triangles. The closest-point routines follow Ericson, "Real-Time
//! Collision Detection", 5.1.5 and 5.1.9.

use glam::DVec3;

use super::triangle::triangles_intersect;

/// The point of triangle `a b c` (with area) closest to `p`.
pub(crate) fn closest_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// The distance between segments `p1 q1` and `p2 q2` (either may be a
/// point).
fn segment_distance(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t) = if a <= f64::MIN_POSITIVE && e <= f64::MIN_POSITIVE {
        (0.0, 0.0)
    } else if a <= f64::MIN_POSITIVE {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= f64::MIN_POSITIVE {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    (p1 + d1 * s).distance(p2 + d2 * t)
}

fn has_area(t: &[DVec3; 3]) -> bool {
    (t[1] - t[0]).cross(t[2] - t[0]).length_squared() > 0.0
}

/// The distance between closed triangles `a` and `b`.
pub fn triangle_distance(a: &[DVec3; 3], b: &[DVec3; 3]) -> f64 {
    if triangles_intersect(a, b) {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    for i in 0..3 {
        for j in 0..3 {
            let d = segment_distance(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]);
            best = best.min(d);
        }
    }
    for (points, face) in [(a, b), (b, a)] {
        if has_area(face) {
            for &p in points {
                best = best.min(p.distance(closest_on_triangle(p, *face)));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Rng(u64);
    impl Rng {
        fn unit(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn point(&mut self) -> DVec3 {
            DVec3::new(self.unit(), self.unit(), self.unit()) * 2.0
        }
    }

    /// Points of a triangle on a barycentric grid, corners and edges
    /// included.
    fn samples(t: &[DVec3; 3], n: usize) -> Vec<DVec3> {
        let mut out = Vec::new();
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                out.push(t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v);
            }
        }
        out
    }

    /// Against dense sampling of both triangles: the distance is never
    /// above the closest sampled pair and within the sampling's spacing of
    /// it; intersecting triangles are at distance zero.
    #[test]
    fn matches_dense_sampling_of_both_triangles() {
        let mut rng = Rng(9);
        let n = 40;
        for _ in 0..300 {
            let a = [rng.point(), rng.point(), rng.point()];
            let b = [rng.point(), rng.point(), rng.point()].map(|p| p + DVec3::X * 1.5);
            let d = triangle_distance(&a, &b);
            let (sa, sb) = (samples(&a, n), samples(&b, n));
            let sampled = sa
                .iter()
                .flat_map(|p| sb.iter().map(move |q| p.distance(*q)))
                .fold(f64::INFINITY, f64::min);
            let spacing = [a, b]
                .iter()
                .flat_map(|t| {
                    [
                        t[0].distance(t[1]),
                        t[1].distance(t[2]),
                        t[2].distance(t[0]),
                    ]
                })
                .fold(0.0, f64::max)
                / n as f64;
            assert!(d <= sampled + 1e-12, "{d} > sampled {sampled}: {a:?} {b:?}");
            assert!(
                d >= sampled - 2.0 * spacing,
                "{d} << sampled {sampled}: {a:?} {b:?}"
            );
        }
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let through = [
            DVec3::new(0.2, 0.2, -1.0),
            DVec3::new(0.2, 0.2, 1.0),
            DVec3::new(0.3, 0.3, 1.0),
        ];
        assert_eq!(triangle_distance(&t, &through), 0.0);
        let above = t.map(|p| p + DVec3::Z * 0.25);
        assert!((triangle_distance(&t, &above) - 0.25).abs() < 1e-15);
    }
}
