//! The refit check: after a refit to the deformed positions, every
//! implementation's closest hits on a sample of rays are compared with brute
//! force over the deformed triangles.
//!
//! The reference is computed in `f64` over every triangle, with no tree, so
//! it shares no code with any implementation (ours included): a refit that
//! leaves a stale box, or a "refit" that keeps the old triangles, loses or
//! moves hits and is counted. Rays whose answer a correct `f32` tracer may
//! legitimately get either way are left out rather than tolerated: a
//! candidate hit within [`BARY_EPS`] of a triangle's edge, at a grazing
//! angle, or at the origin, no farther than the clean closest hit.

use frusta_engine::geometry::Ray;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;

/// Barycentric margin (scale-free) inside which a hit counts as on an edge.
const BARY_EPS: f64 = 1e-4;
/// `|cos|` between ray and triangle normal below which a hit is grazing.
const GRAZING_COS: f64 = 1e-4;
/// Relative tolerance on the closest-hit distance.
const T_REL: f64 = 1e-4;

/// What a correct tracer must answer for one sampled ray.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Expected {
    Hit(f64),
    Miss,
    /// Either answer is defensible in `f32`: not checked.
    Ambiguous,
}

/// Brute-force closest hits of a sample of rays on one set of positions.
pub struct Reference {
    rays: Vec<Ray>,
    expected: Vec<Expected>,
    /// Absolute slack on `t` (a millionth of the bounding diagonal, `f32`
    /// rounding of far hits).
    t_abs: f64,
}

/// Rays checked after a refit and how many of them were wrong.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct RefitCheck {
    pub checked: usize,
    pub wrong: usize,
}

impl std::ops::AddAssign for RefitCheck {
    fn add_assign(&mut self, o: Self) {
        self.checked += o.checked;
        self.wrong += o.wrong;
    }
}

/// Every `len / n`-th ray of `rays` (all of them when there are fewer).
pub fn sample(rays: &[Ray], n: usize) -> Vec<Ray> {
    let step = (rays.len() / n.max(1)).max(1);
    rays.iter().step_by(step).take(n).copied().collect()
}

impl Reference {
    /// Brute force of `rays` against `triangles` over `positions`.
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]], rays: Vec<Ray>) -> Self {
        let tris: Vec<[DVec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| positions[i as usize].as_dvec3()))
            .collect();
        let (lo, hi) = tris.iter().flatten().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        let t_abs = 1e-6 * (hi - lo).max(DVec3::ZERO).length();
        let expected = rays.par_iter().map(|r| expect(r, &tris, t_abs)).collect();
        Self {
            rays,
            expected,
            t_abs,
        }
    }

    pub fn rays(&self) -> &[Ray] {
        &self.rays
    }

    /// Compares closest-hit distances (one per [`Self::rays`]) with the
    /// reference.
    pub fn check(&self, got: &[Option<f32>]) -> RefitCheck {
        assert_eq!(got.len(), self.expected.len());
        let mut c = RefitCheck::default();
        for (e, g) in self.expected.iter().zip(got) {
            let ok = match (e, g) {
                (Expected::Ambiguous, _) => continue,
                (Expected::Hit(t), Some(g)) => (*g as f64 - t).abs() <= T_REL * t + self.t_abs,
                (Expected::Miss, None) => true,
                _ => false,
            };
            c.checked += 1;
            c.wrong += usize::from(!ok);
        }
        c
    }
}

/// Double-sided Möller–Trumbore in `f64` over every triangle.
fn expect(ray: &Ray, tris: &[[DVec3; 3]], t_abs: f64) -> Expected {
    let o = Vec3::from(ray.origin).as_dvec3();
    let d = Vec3::from(ray.dir).as_dvec3();
    let t_max = ray.t_max as f64;
    let (mut clean, mut unsure) = (f64::INFINITY, f64::INFINITY);
    for [a, b, c] in tris {
        let (e1, e2) = (*b - *a, *c - *a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            continue;
        }
        let s = o - *a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        let margin = u.min(v).min(1.0 - u - v);
        if margin < -BARY_EPS || t < -t_abs || t > t_max {
            continue;
        }
        let n = e1.cross(e2);
        let grazing = d.dot(n).abs() < GRAZING_COS * n.length() * d.length();
        if margin > BARY_EPS && !grazing && t > t_abs {
            clean = clean.min(t);
        } else {
            unsure = unsure.min(t.max(0.0));
        }
    }
    if unsure.is_finite() && unsure <= clean * (1.0 + T_REL) + t_abs {
        Expected::Ambiguous
    } else if clean.is_finite() {
        Expected::Hit(clean)
    } else {
        Expected::Miss
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1 x 1 square in z = 0 (two triangles).
    fn square(z: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
            .map(|(x, y)| Vec3::new(x, y, z))
            .to_vec();
        (p, vec![[0, 1, 2], [0, 2, 3]])
    }

    fn down(x: f32, y: f32) -> Ray {
        Ray::new(Vec3::new(x, y, 5.0), Vec3::NEG_Z)
    }

    #[test]
    fn hits_misses_and_edges() {
        let (p, t) = square(1.0);
        // Inside, outside, on the shared diagonal, on the outer edge.
        let rays = vec![
            down(0.7, 0.2),
            down(2.0, 0.5),
            down(0.5, 0.5),
            down(1.0, 0.3),
        ];
        let r = Reference::new(&p, &t, rays);
        assert_eq!(r.expected[0], Expected::Hit(4.0));
        assert_eq!(r.expected[1], Expected::Miss);
        assert_eq!(r.expected[2..], [Expected::Ambiguous; 2]);
        let c = r.check(&[Some(4.0), None, None, Some(4.0)]);
        assert_eq!((c.checked, c.wrong), (2, 0));
        // A stale structure: the hit at the old height, and a phantom hit.
        let c = r.check(&[Some(5.0), Some(4.0), None, None]);
        assert_eq!((c.checked, c.wrong), (2, 2));
    }

    #[test]
    fn a_refit_that_keeps_the_old_boxes_is_caught() {
        use frusta_engine::bvh::{BuildOptions, MeshBvh};
        use frusta_engine::geometry::TriangleMesh;

        let (p, t) = square(0.0);
        let (moved, _) = square(1.0);
        let rays: Vec<Ray> = (0..100)
            .map(|i| down(0.05 + 0.009 * i as f32, 0.3))
            .collect();
        let reference = Reference::new(&moved, &t, rays);
        let mesh = TriangleMesh::new(p, t.clone()).unwrap();
        let mut bvh = MeshBvh::build(&mesh, &BuildOptions::default());
        let trace = |b: &MeshBvh| -> Vec<Option<f32>> {
            reference
                .rays()
                .iter()
                .map(|r| b.closest_hit(r).map(|h| h.t))
                .collect()
        };
        let stale = reference.check(&trace(&bvh));
        assert_eq!(stale.wrong, stale.checked);
        bvh.refit(&TriangleMesh::new(moved, t).unwrap()).unwrap();
        let fresh = reference.check(&trace(&bvh));
        assert_eq!((fresh.checked, fresh.wrong), (100, 0));
    }
}
