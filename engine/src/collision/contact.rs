//! Where two intersecting triangles meet: the segment along which they
//! cross (a point where they touch at one), or the region they share where
//! they are coplanar. Which side of a plane each corner lies on is decided
//! exactly (the orientation predicate of [`super::triangle`]), so a corner
//! in the other's plane is a contact point as it is; the points themselves
//! are computed in f64.

use glam::DVec3;

use super::triangle::orient;

/// Where triangles `a` and `b` meet, for a pair [`super::triangles_intersect`]
/// reports: the two ends of the segment they share (one point where they
/// touch at a point), or, coplanar, the corners of the polygon they share.
/// Empty where they do not meet.
pub fn contact_points(a: &[DVec3; 3], b: &[DVec3; 3]) -> Vec<DVec3> {
    let side_a = a.map(|p| orient(b[0], b[1], b[2], p));
    let side_b = b.map(|p| orient(a[0], a[1], a[2], p));
    if side_a == [0; 3] || side_b == [0; 3] {
        return coplanar(a, b);
    }
    let normal = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]);
    let (on_b, on_a) = (
        in_plane(a, side_a, b[0], normal(b)),
        in_plane(b, side_b, a[0], normal(a)),
    );
    let line = normal(a).cross(normal(b));
    let span = |points: &[DVec3]| {
        let key = |p: &&DVec3| p.dot(line);
        let lo = points.iter().min_by(|x, y| key(x).total_cmp(&key(y)));
        let hi = points.iter().max_by(|x, y| key(x).total_cmp(&key(y)));
        lo.zip(hi).map(|(lo, hi)| (*lo, *hi))
    };
    let (Some((a_lo, a_hi)), Some((b_lo, b_hi))) = (span(&on_b), span(&on_a)) else {
        return Vec::new();
    };
    let lo = if a_lo.dot(line) >= b_lo.dot(line) {
        a_lo
    } else {
        b_lo
    };
    let hi = if a_hi.dot(line) <= b_hi.dot(line) {
        a_hi
    } else {
        b_hi
    };
    if lo.dot(line) >= hi.dot(line) {
        // A point contact, or ends crossed by rounding.
        return vec![lo.lerp(hi, 0.5)];
    }
    vec![lo, hi]
}

/// The points of triangle `t` in the plane through `q` with normal `n`,
/// given each corner's exact side of it: corners on it, and where edges
/// cross it.
fn in_plane(t: &[DVec3; 3], side: [i8; 3], q: DVec3, n: DVec3) -> Vec<DVec3> {
    let mut points = Vec::with_capacity(3);
    for i in 0..3 {
        let j = (i + 1) % 3;
        if side[i] == 0 {
            points.push(t[i]);
        }
        if side[i] * side[j] < 0 {
            let (di, dj) = ((t[i] - q).dot(n), (t[j] - q).dot(n));
            points.push(t[i] + (t[j] - t[i]) * (di / (di - dj)));
        }
    }
    points
}

/// The polygon two coplanar triangles share: `a` clipped by the three
/// edges of `b` (Sutherland–Hodgman), in their common plane.
fn coplanar(a: &[DVec3; 3], b: &[DVec3; 3]) -> Vec<DVec3> {
    let (clip, subject) = if (b[1] - b[0]).cross(b[2] - b[0]) != DVec3::ZERO {
        (b, a)
    } else {
        (a, b)
    };
    let n = (clip[1] - clip[0]).cross(clip[2] - clip[0]);
    let mut polygon: Vec<DVec3> = subject.to_vec();
    for i in 0..3 {
        let (p, q, r) = (clip[i], clip[(i + 1) % 3], clip[(i + 2) % 3]);
        let mut inward = n.cross(q - p);
        if (r - p).dot(inward) < 0.0 {
            inward = -inward;
        }
        let inside = |x: DVec3| (x - p).dot(inward);
        let mut kept = Vec::with_capacity(polygon.len() + 1);
        for (k, &x) in polygon.iter().enumerate() {
            let y = polygon[(k + 1) % polygon.len()];
            let (dx, dy) = (inside(x), inside(y));
            if dx >= 0.0 {
                kept.push(x);
            }
            if (dx >= 0.0) != (dy >= 0.0) {
                kept.push(x + (y - x) * (dx / (dx - dy)));
            }
        }
        polygon = kept;
        if polygon.is_empty() {
            break;
        }
    }
    polygon.dedup();
    if polygon.len() > 1 && polygon.first() == polygon.last() {
        polygon.pop();
    }
    polygon
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::triangles_intersect;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    fn close(p: DVec3, q: DVec3) -> bool {
        p.distance(q) < 1e-12
    }

    #[test]
    fn crossing_triangles_share_the_overlap_of_their_two_chords() {
        let a = [v(0.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(0.0, 2.0, 0.0)];
        // Upright in x = 0.5: it crosses z = 0 along y in [0, 2], a's chord
        // there is y in [0, 1.5].
        let b = [v(0.5, -1.0, -1.0), v(0.5, 3.0, -1.0), v(0.5, 1.0, 1.0)];
        let points = contact_points(&a, &b);
        assert_eq!(points.len(), 2, "{points:?}");
        let (p, q) = (points[0].min(points[1]), points[0].max(points[1]));
        assert!(
            close(p, v(0.5, 0.0, 0.0)) && close(q, v(0.5, 1.5, 0.0)),
            "{points:?}"
        );
    }

    #[test]
    fn a_corner_resting_on_a_face_is_one_point() {
        let a = [v(0.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(0.0, 2.0, 0.0)];
        let b = [v(0.5, 0.5, 0.0), v(0.5, 0.5, 1.0), v(1.0, 0.2, 1.0)];
        assert!(triangles_intersect(&a, &b));
        let points = contact_points(&a, &b);
        assert_eq!(points.len(), 1, "{points:?}");
        assert!(close(points[0], v(0.5, 0.5, 0.0)));
    }

    #[test]
    fn coplanar_overlap_is_the_shared_polygon() {
        let a = [v(0.0, 0.0, 1.0), v(2.0, 0.0, 1.0), v(0.0, 2.0, 1.0)];
        let b = [v(0.0, 0.0, 1.0), v(2.0, 0.0, 1.0), v(2.0, 2.0, 1.0)];
        let points = contact_points(&a, &b);
        // The triangle (0,0) (2,0) (1,1), area 1.
        let area: f64 = (1..points.len() - 1)
            .map(|i| {
                0.5 * (points[i] - points[0])
                    .cross(points[i + 1] - points[0])
                    .length()
            })
            .sum();
        assert!((area - 1.0).abs() < 1e-12, "{points:?}");
        assert!(points.iter().all(|p| p.z == 1.0));
    }

    #[test]
    fn every_point_lies_on_both_triangles() {
        let mut state = 7u64;
        let mut unit = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut tested = 0;
        for _ in 0..4000 {
            let mut tri = || [(); 3].map(|_| v(unit(), unit(), unit()));
            let (a, b) = (tri(), tri());
            if !triangles_intersect(&a, &b) {
                continue;
            }
            tested += 1;
            let points = contact_points(&a, &b);
            assert!(!points.is_empty() && points.len() <= 2, "{a:?} {b:?}");
            for p in points {
                for t in [&a, &b] {
                    let d = p.distance(crate::collision::distance::closest_on_triangle(p, *t));
                    assert!(d < 1e-9, "{p} is {d} from {t:?}");
                }
            }
        }
        assert!(tested > 500, "{tested}");
    }
}
