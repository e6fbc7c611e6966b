//! The watertight ray/triangle test of Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection" (JCGT 2013), with an exact tie-break on edges
//! and vertices.
//!
//! The ray is sheared so that it becomes the origin of a 2D plane; every
//! vertex is sheared the same way whichever triangle it belongs to, so the
//! edge functions of a shared edge are exact negatives of each other and no
//! ray slips between two triangles. Edge functions that round to zero in
//! `f32` are recomputed in `f64`, where products of `f32` values are exact,
//! so zero means the ray really passes through the edge.
//!
//! Woop et al. report such a ray as hitting both triangles. We instead
//! decide an exact zero by simulation of simplicity: the ray is moved by the
//! infinitesimal `(eps, eps^2)` in the sheared plane, the same move for
//! every triangle. The moved ray meets no edge, so a ray through an edge or
//! vertex of a closed mesh hits exactly one of the triangles there.

use glam::{Vec3A, Vec3Swizzles};

use super::Ray;

/// Where a ray meets a triangle: `t` along the ray, and the barycentric
/// weights `u` of the second and `v` of the third corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// The per-ray constants of the test, computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3A,
    /// The shear as weights of a vertex's coordinates (relative to the
    /// origin): sheared `x = q[kx] − sx q[kz]`, `y = q[ky] − sy q[kz]`,
    /// `z = sz q[kz]`, where `kz` is the direction's dominant axis and
    /// `kx`, `ky` are ordered so the sheared winding keeps its sign. Each
    /// has one or two non-zero weights, so the sum rounds as the two-term
    /// expression does (up to the sign of a zero), and no coordinate is
    /// picked by a run-time index.
    x: Vec3A,
    y: Vec3A,
    z: Vec3A,
}

/// A vertex in the ray's sheared frame.
#[derive(Clone, Copy)]
struct Sheared {
    x: f32,
    y: f32,
    z: f32,
}

impl WatertightRay {
    /// Precomputes the shear of `ray`. The ray must have a non-zero finite
    /// direction (see [`Ray::is_valid`]).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir.to_array();
        let a = ray.dir.abs();
        // The largest axis, and the others' order, by bit operations and
        // arrays, not branches: a random direction's axes do not predict.
        let x_over_y = a.x > a.y;
        let x_largest = x_over_y & (a.x > a.z);
        let y_largest = !x_over_y & (a.y > a.z);
        let kz = 2 - 2 * usize::from(x_largest) - usize::from(y_largest);
        let flip = usize::from(d[kz] < 0.0);
        let (kx, ky) = ((kz + 1 + flip) % 3, (kz + 2 - flip) % 3);
        // Lanes picked by masks, not written at run-time indices: a
        // vector read of lanes just written one by one waits for the
        // stores to drain.
        let lanes = Vec3A::new(0.0, 1.0, 2.0);
        let lane = |k: usize| lanes.cmpeq(Vec3A::splat(k as f32));
        let at_z = lane(kz);
        let weights = |k: usize, along: f32| {
            let off_z = Vec3A::select(at_z, Vec3A::splat(-along), Vec3A::ZERO);
            Vec3A::select(lane(k), Vec3A::ONE, off_z)
        };
        Self {
            origin: ray.origin,
            x: weights(kx, d[kx] / d[kz]),
            y: weights(ky, d[ky] / d[kz]),
            z: Vec3A::select(at_z, Vec3A::splat(1.0 / d[kz]), Vec3A::ZERO),
        }
    }

    /// Intersects the triangle `(a, b, c)`; a hit is reported when its `t`
    /// lies in `[t_min, t_max]`. Both sides of the triangle are hit;
    /// zero-area triangles never are.
    #[inline(always)]
    pub fn intersect(
        &self,
        a: Vec3A,
        b: Vec3A,
        c: Vec3A,
        t_min: f32,
        t_max: f32,
    ) -> Option<TriangleHit> {
        // The three corners a coordinate at a time (lanes a, b, c), so one
        // sheared coordinate of all three takes three products.
        let (a, b, c) = (a - self.origin, b - self.origin, c - self.origin);
        let row = |axis: usize| Vec3A::new(a[axis], b[axis], c[axis]);
        let (qx, qy, qz) = (row(0), row(1), row(2));
        let shear = |w: Vec3A| qx * w.x + qy * w.y + qz * w.z;
        let (x, y) = (shear(self.x), shear(self.y));
        // u = c.x b.y − c.y b.x, v = a.x c.y − a.y c.x, w = b.x a.y − b.y a.x.
        let uvw = x.zxy() * y.yzx() - y.zxy() * x.yzx();
        // One branch each, not one per comparison; whether a ray meets a
        // triangle does not predict.
        let zero = Vec3A::ZERO;
        if uvw.cmplt(zero).any() & uvw.cmpgt(zero).any() {
            return None;
        }
        let z = shear(self.z);
        if uvw.cmpeq(zero).any() {
            let corner = |i: usize| Sheared {
                x: x[i],
                y: y[i],
                z: z[i],
            };
            return exact_intersect(corner(0), corner(1), corner(2), t_min, t_max);
        }
        let (u, v, w) = (uvw.x, uvw.y, uvw.z);
        let det = u + v + w;
        let tz = uvw * z;
        let t = (tz.x + tz.y + tz.z) / det;
        if !((t >= t_min) & (t <= t_max)) {
            return None;
        }
        let inv = 1.0 / det;
        Some(TriangleHit {
            t,
            u: v * inv,
            v: w * inv,
        })
    }
}

/// The slow path for rays that graze an edge or vertex in `f32`: edge
/// functions in exact `f64` arithmetic, exact zeros decided by the
/// `(eps, eps^2)` perturbation.
#[cold]
fn exact_intersect(
    a: Sheared,
    b: Sheared,
    c: Sheared,
    t_min: f32,
    t_max: f32,
) -> Option<TriangleHit> {
    let f = |p: Sheared| (p.x as f64, p.y as f64, p.z as f64);
    let (a, b, c) = (f(a), f(b), f(c));
    // Edge function of the directed edge s -> e at the sheared origin.
    let edge = |s: (f64, f64, f64), e: (f64, f64, f64)| s.0 * e.1 - s.1 * e.0;
    let u = edge(c, b);
    let v = edge(a, c);
    let w = edge(b, a);
    // Sign of an edge function once the origin moves to (eps, eps^2):
    // d/dx = s.y - e.y, d/dy = e.x - s.x.
    let sign = |value: f64, s: (f64, f64, f64), e: (f64, f64, f64)| -> i8 {
        let first = if value != 0.0 { value } else { s.1 - e.1 };
        let second = if first != 0.0 { first } else { e.0 - s.0 };
        (second > 0.0) as i8 - (second < 0.0) as i8
    };
    let su = sign(u, c, b);
    let sv = sign(v, a, c);
    let sw = sign(w, b, a);
    if su == 0 || su != sv || su != sw {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t = ((u * a.2 + v * b.2 + w * c.2) / det) as f32;
    if !(t >= t_min && t <= t_max) {
        return None;
    }
    Some(TriangleHit {
        t,
        u: (v / det) as f32,
        v: (w / det) as f32,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn hit(o: Vec3, d: Vec3, tri: [Vec3; 3]) -> Option<TriangleHit> {
        let r = WatertightRay::new(&Ray::new(o, d));
        r.intersect(
            tri[0].into(),
            tri[1].into(),
            tri[2].into(),
            0.0,
            f32::INFINITY,
        )
    }

    const TRI: [Vec3; 3] = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];

    #[test]
    fn hits_the_inside_with_correct_barycentrics() {
        let h = hit(Vec3::new(0.25, 0.5, 0.0), Vec3::Z, TRI).unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6);
        // The back side is hit too.
        let h = hit(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z, TRI).unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
    }

    #[test]
    fn misses_outside_behind_and_out_of_range() {
        assert!(hit(Vec3::new(0.8, 0.8, 0.0), Vec3::Z, TRI).is_none());
        assert!(hit(Vec3::new(0.2, 0.2, 2.0), Vec3::Z, TRI).is_none());
        let r = WatertightRay::new(&Ray::new(Vec3::new(0.2, 0.2, 0.0), Vec3::Z));
        let [a, b, c] = TRI.map(Vec3A::from);
        assert!(r.intersect(a, b, c, 0.0, 0.5).is_none());
        assert!(r.intersect(a, b, c, 1.5, 9.0).is_none());
    }

    #[test]
    fn degenerate_and_parallel_triangles_are_never_hit() {
        let line = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(2.0, 0.0, 1.0),
        ];
        assert!(hit(Vec3::new(0.5, 0.0, 0.0), Vec3::Z, line).is_none());
        let point = [Vec3::Z; 3];
        assert!(hit(Vec3::ZERO, Vec3::Z, point).is_none());
        // A ray in the triangle's plane.
        assert!(hit(Vec3::new(-1.0, 0.2, 1.0), Vec3::X, TRI).is_none());
    }

    /// A shared edge is hit by exactly one of its two triangles, whatever the
    /// direction the ray crosses it in.
    #[test]
    fn shared_edge_is_hit_exactly_once() {
        let (p0, p1, p2, p3) = (
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        );
        let quad = [[p0, p1, p2], [p0, p2, p3]];
        for o in [
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(0.3, 0.3, 2.0),
            Vec3::new(0.7, 0.7, -3.0),
        ] {
            for target in [
                Vec3::new(0.5, 0.5, 1.0),
                Vec3::new(0.25, 0.25, 1.0),
                Vec3::new(0.9, 0.9, 1.0),
            ] {
                let d = target - o;
                let n = quad.iter().filter(|t| hit(o, d, **t).is_some()).count();
                assert_eq!(n, 1, "origin {o} target {target}");
            }
        }
    }

    /// A ray through the centre vertex of a fan hits exactly one triangle.
    #[test]
    fn shared_vertex_is_hit_exactly_once() {
        let c = Vec3::new(0.0, 0.0, 1.0);
        let k = 7;
        let ring: Vec<Vec3> = (0..k)
            .map(|i| {
                let a = i as f32 / k as f32 * std::f32::consts::TAU;
                Vec3::new(a.cos(), a.sin(), 1.0 + 0.3 * (i % 2) as f32)
            })
            .collect();
        for o in [
            Vec3::ZERO,
            Vec3::new(0.3, -0.2, -1.0),
            Vec3::new(-0.1, 0.4, 3.0),
        ] {
            let n = (0..k)
                .filter(|&i| hit(o, c - o, [c, ring[i], ring[(i + 1) % k]]).is_some())
                .count();
            assert_eq!(n, 1, "origin {o}");
        }
    }

    /// The paper's test as written (Woop et al. 2013, listing 1): each
    /// corner sheared by picking its coordinates with the ray's axis
    /// indices, then the same decisions as [`WatertightRay::intersect`].
    fn by_axis_indices(o: Vec3, d: Vec3, [a, b, c]: [Vec3; 3]) -> Option<TriangleHit> {
        // The dominant axis, ties broken as `WatertightRay::new` does.
        let m = d.abs();
        let kz = match (m.x > m.y, m.x > m.z, m.y > m.z) {
            (true, true, _) => 0,
            (false, _, true) => 1,
            _ => 2,
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        let shear = |p: Vec3| {
            let q = p - o;
            Sheared {
                x: q[kx] - sx * q[kz],
                y: q[ky] - sy * q[kz],
                z: sz * q[kz],
            }
        };
        let (a, b, c) = (shear(a), shear(b), shear(c));
        let u = c.x * b.y - c.y * b.x;
        let v = a.x * c.y - a.y * c.x;
        let w = b.x * a.y - b.y * a.x;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        if u == 0.0 || v == 0.0 || w == 0.0 {
            return exact_intersect(a, b, c, 0.0, f32::INFINITY);
        }
        let det = u + v + w;
        let t = (u * a.z + v * b.z + w * c.z) / det;
        let inv = 1.0 / det;
        (t >= 0.0).then_some(TriangleHit {
            t,
            u: v * inv,
            v: w * inv,
        })
    }

    /// The corners' coordinates as weighted rows give the paper's sheared
    /// corners, so the same hits to the bit: rays of every dominant axis
    /// and sign, with zero and tiny direction components, through
    /// triangles' insides, edges and corners.
    #[test]
    fn shearing_by_rows_answers_as_the_paper_to_the_bit() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut unit = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut checked = 0;
        for i in 0..20_000 {
            let tri = [0; 3].map(|_| Vec3::new(unit(), unit(), unit()) * 4.0);
            let mut d = Vec3::new(unit(), unit(), unit());
            // Zero and tiny components, and each axis dominant in turn.
            match i % 5 {
                0 => d[i % 3] = 0.0,
                1 => d[(i + 1) % 3] = 1e-30,
                2 => d[i % 3] *= 100.0,
                _ => {}
            }
            // Aim at the inside, an edge or a corner.
            let (w1, w2) = match i % 3 {
                0 => (0.25, 0.25),
                1 => (0.5, 0.0),
                _ => (0.0, 0.0),
            };
            let target = tri[0] + (tri[1] - tri[0]) * w1 + (tri[2] - tri[0]) * w2;
            let o = if i % 2 == 0 {
                target - d * 3.0
            } else {
                Vec3::new(unit(), unit(), unit()) * 5.0
            };
            let mine = WatertightRay::new(&Ray::new(o, d)).intersect(
                tri[0].into(),
                tri[1].into(),
                tri[2].into(),
                0.0,
                f32::INFINITY,
            );
            let bits = |h: Option<TriangleHit>| h.map(|h| [h.t, h.u, h.v].map(|x| x.to_bits()));
            assert_eq!(
                bits(mine),
                bits(by_axis_indices(o, d, tri)),
                "{o} {d} {tri:?}"
            );
            checked += usize::from(mine.is_some());
        }
        assert!(checked > 5_000, "{checked} hits");
    }
}
