//! Area-weighted moments of triangles, summed up a tree in one pass: the
//! principal axes of OBBs ([`super::obb`]) and the planes of levels of
//! detail ([`super::lod`]) both come from their covariance.

use glam::{DVec3, Vec3A};
use glamx::{DMat3, DSymmetricEigen3};

/// Area-weighted first and second moments of a set of triangles, which add
/// up the tree.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Moments {
    area: f64,
    /// Integral of x over the area.
    first: DVec3,
    /// Integral of x x^T: xx, xy, xz, yy, yz, zz.
    second: [f64; 6],
}

impl Moments {
    pub(crate) fn triangle(t: &[Vec3A; 3]) -> Self {
        let [p, q, r] = t.map(|c| glam::Vec3::from(c).as_dvec3());
        let area = 0.5 * (q - p).cross(r - p).length();
        let m = (p + q + r) / 3.0;
        let outer = |u: DVec3, w: f64| {
            [
                u.x * u.x,
                u.x * u.y,
                u.x * u.z,
                u.y * u.y,
                u.y * u.z,
                u.z * u.z,
            ]
            .map(|x| x * w)
        };
        let [a, b, c, d] = [outer(m, 9.0), outer(p, 1.0), outer(q, 1.0), outer(r, 1.0)];
        Self {
            area,
            first: m * area,
            second: std::array::from_fn(|k| (a[k] + b[k] + c[k] + d[k]) * area / 12.0),
        }
    }

    pub(crate) fn add(&mut self, o: &Self) {
        self.area += o.area;
        self.first += o.first;
        for k in 0..6 {
            self.second[k] += o.second[k];
        }
    }

    /// The mean and the eigenvectors of the covariance, by ascending
    /// eigenvalue (the first is the normal of the best-fitting plane);
    /// `None` for no area.
    pub(crate) fn principal(&self) -> Option<(DVec3, [DVec3; 3])> {
        if self.area.is_nan() || self.area <= 0.0 || !self.area.is_finite() {
            return None;
        }
        let m = self.first / self.area;
        let s = self.second.map(|x| x / self.area);
        let (xx, xy, xz) = (s[0] - m.x * m.x, s[1] - m.x * m.y, s[2] - m.x * m.z);
        let (yy, yz, zz) = (s[3] - m.y * m.y, s[4] - m.y * m.z, s[5] - m.z * m.z);
        // Scaled to a largest entry of 1: the eigensolver's thresholds are
        // absolute (below about 1e-20 it answers x), which a 1 cm patch's
        // covariance in metres already falls under. Scaling keeps the
        // eigenvectors.
        let entries = [xx, xy, xz, yy, yz, zz];
        let size = entries.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if !(size.is_finite() && size > 0.0) {
            return None;
        }
        let cov = DMat3::from_cols_array(&[xx, xy, xz, xy, yy, yz, xz, yz, zz].map(|x| x / size));
        let vectors = DSymmetricEigen3::new(cov).eigenvectors;
        // glamx's own glam version: copied over by component.
        let column = |k: usize| {
            let c = vectors.col(k);
            DVec3::new(c.x, c.y, c.z)
        };
        Some((m, [0, 1, 2].map(column)))
    }

    /// Orthonormal principal axes; the coordinate axes where they are not
    /// defined.
    pub(crate) fn axes(&self) -> [Vec3A; 3] {
        let fallback = [Vec3A::X, Vec3A::Y, Vec3A::Z];
        let Some((_, column)) = self.principal() else {
            return fallback;
        };
        let u = column[0].normalize_or_zero();
        let v = (column[1] - u * u.dot(column[1])).normalize_or_zero();
        let w = u.cross(v);
        if w.length_squared().is_nan() || w.length_squared() <= 0.5 {
            return fallback;
        }
        [u, v, w].map(|a| Vec3A::from(a.as_vec3()))
    }
}
