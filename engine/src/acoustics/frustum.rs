//! A frustum: the convex four-sided pyramid of directions that one beam of
//! sound occupies, from its apex (a source or an image source) through a
//! planar window.
//!
//! Directions are parametrised over the window as
//! `corner + u * edge_u + v * edge_v` with `u, v` in `[0, 1]`, so splitting
//! the window into `N x N` cells and merging cells back into rectangles are
//! both exact, and mirroring a frustum in a plane mirrors four vectors.
//! A point `p` has window coordinates `(x, y, s)` with
//! `p - apex = x edge_u + y edge_v + s corner`; it lies in the frustum when
//! `s > 0` and `(u, v) = (x / s, y / s)` is in the unit square. `s` is linear
//! in `p`, which makes it the depth used for occlusion: along one direction,
//! nearer points have smaller `s`.

use glam::{DMat3, DVec3};

use super::surfaces::Plane;

/// The half-space a secondary frustum's paths continue in: the side of the
/// surface that reflected or transmitted it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearPlane {
    pub plane: Plane,
    /// `+1.0` when the valid side is the normal's side, `-1.0` otherwise.
    pub side: f64,
}

impl NearPlane {
    /// Signed distance, positive on the valid side.
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.side * self.plane.distance(p)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    pub apex: DVec3,
    pub corner: DVec3,
    pub edge_u: DVec3,
    pub edge_v: DVec3,
    /// Inverse of `[edge_u, edge_v, corner]`: world offset to `(x, y, s)`.
    to_window: DMat3,
    /// Absent for frusta leaving a source.
    pub near: Option<NearPlane>,
}

/// The part of a frustum the point test reads (152 of its 216 bytes), kept
/// on its own so that traced beams can be stored without their windows and
/// tested by the very code [`Frustum::contains`] runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Containment {
    apex: DVec3,
    to_window: DMat3,
    near: Option<NearPlane>,
}

impl Containment {
    /// The beam with its apex moved by `by`, its window's directions and
    /// near plane kept: the same beam from a source that moved, the move
    /// mirrored in its reflections (see [`super::beams`]).
    #[inline]
    pub(crate) fn shifted(mut self, by: DVec3) -> Self {
        self.apex += by;
        self
    }

    #[cfg(test)]
    pub(crate) fn apex(&self) -> DVec3 {
        self.apex
    }

    /// See [`Frustum::contains`].
    #[inline]
    pub fn contains(&self, p: DVec3, margin: f64) -> bool {
        if let Some(near) = &self.near {
            if near.distance(p).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return false;
            }
        }
        let w = self.to_window * (p - self.apex);
        if w.z.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let (u, v) = (w.x / w.z, w.y / w.z);
        (-margin..=1.0 + margin).contains(&u) && (-margin..=1.0 + margin).contains(&v)
    }
}

impl Frustum {
    /// The frustum from `apex` through the window `corner + [0,1] edge_u +
    /// [0,1] edge_v`; `None` when the window is degenerate.
    pub fn new(
        apex: DVec3,
        corner: DVec3,
        edge_u: DVec3,
        edge_v: DVec3,
        near: Option<NearPlane>,
    ) -> Option<Self> {
        let m = DMat3::from_cols(edge_u, edge_v, corner);
        let det = m.determinant();
        let scale = edge_u.length() * edge_v.length() * corner.length();
        if det.abs() <= 1e-12 * scale || !det.is_finite() {
            return None;
        }
        Some(Self {
            apex,
            corner,
            edge_u,
            edge_v,
            to_window: m.inverse(),
            near,
        })
    }

    /// The frusta tiling the sphere of directions around `apex`: each cube
    /// face split into `split x split` windows.
    pub fn sphere(apex: DVec3, split: u32) -> Vec<Frustum> {
        let split = split.max(1);
        let step = 2.0 / f64::from(split);
        let mut out = Vec::with_capacity(6 * (split * split) as usize);
        for axis in 0..3 {
            for sign in [1.0, -1.0] {
                let mut n = DVec3::ZERO;
                n[axis] = sign;
                // Two tangents completing a basis on this face.
                let mut a = DVec3::ZERO;
                a[(axis + 1) % 3] = 1.0;
                let mut b = DVec3::ZERO;
                b[(axis + 2) % 3] = 1.0;
                for i in 0..split {
                    for j in 0..split {
                        let corner =
                            n + a * (-1.0 + step * f64::from(i)) + b * (-1.0 + step * f64::from(j));
                        out.extend(Frustum::new(apex, corner, a * step, b * step, None));
                    }
                }
            }
        }
        out
    }

    /// `(x, y, s)` of point `p`.
    #[inline]
    pub fn window_coords(&self, p: DVec3) -> DVec3 {
        self.to_window * (p - self.apex)
    }

    /// The largest change of `(x, y, s)` over every point when the apex
    /// moves by at most `reach` metres: each row of the inverse window
    /// matrix's length times `reach`.
    pub(crate) fn window_shift(&self, reach: f64) -> DVec3 {
        let m = self.to_window;
        DVec3::new(m.row(0).length(), m.row(1).length(), m.row(2).length()) * reach
    }

    /// The gradient of the depth `s`: `s(p) = depth_gradient() · (p - apex)`.
    pub fn depth_gradient(&self) -> DVec3 {
        self.to_window.row(2)
    }

    /// The direction through window point `(u, v)`.
    #[inline]
    pub fn direction(&self, u: f64, v: f64) -> DVec3 {
        self.corner + self.edge_u * u + self.edge_v * v
    }

    /// Whether `p` lies in the frustum and on the valid side of its near
    /// plane, with the window widened by `margin` (in window units) so that a
    /// point on the boundary of two frusta belongs to both.
    #[inline]
    pub fn contains(&self, p: DVec3, margin: f64) -> bool {
        self.containment().contains(p, margin)
    }

    /// What [`Self::contains`] reads.
    #[inline]
    pub(crate) fn containment(&self) -> Containment {
        Containment {
            apex: self.apex,
            to_window: self.to_window,
            near: self.near,
        }
    }

    /// The frustum through the sub-window `[u0, u1] x [v0, v1]`.
    pub fn sub(&self, u0: f64, u1: f64, v0: f64, v1: f64) -> Option<Frustum> {
        Frustum::new(
            self.apex,
            self.direction(u0, v0),
            self.edge_u * (u1 - u0),
            self.edge_v * (v1 - v0),
            self.near,
        )
    }

    /// This frustum mirrored in `plane`: its apex becomes the image source,
    /// and paths continue on the side the sound came from.
    pub fn reflected(&self, plane: &Plane) -> Option<Frustum> {
        let side = self.plane_side(plane)?;
        Frustum::new(
            plane.mirror(self.apex),
            plane.mirror_vector(self.corner),
            plane.mirror_vector(self.edge_u),
            plane.mirror_vector(self.edge_v),
            Some(NearPlane {
                plane: *plane,
                side,
            }),
        )
    }

    /// This frustum continued through `plane`: same apex, paths continue on
    /// the far side.
    pub fn transmitted(&self, plane: &Plane) -> Option<Frustum> {
        let side = self.plane_side(plane)?;
        Some(Frustum {
            near: Some(NearPlane {
                plane: *plane,
                side: -side,
            }),
            ..*self
        })
    }

    /// The side of `plane` the apex is on; `None` when the apex lies in the
    /// plane (grazing: no reflection to speak of).
    fn plane_side(&self, plane: &Plane) -> Option<f64> {
        let d = plane.distance(self.apex);
        let tol = 1e-12 * (1.0 + self.apex.length());
        (d.abs() > tol).then(|| d.signum())
    }

    /// Inward normals of the four side planes, which all pass through the
    /// apex.
    pub fn side_normals(&self) -> [DVec3; 4] {
        let w = [
            self.corner,
            self.corner + self.edge_u,
            self.corner + self.edge_u + self.edge_v,
            self.corner + self.edge_v,
        ];
        let centre = self.direction(0.5, 0.5);
        [0, 1, 2, 3].map(|i| {
            let n = w[i].cross(w[(i + 1) % 4]);
            if n.dot(centre) < 0.0 {
                -n
            } else {
                n
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_frusta_cover_every_direction_once_inside() {
        let fs = Frustum::sphere(DVec3::ZERO, 3);
        assert_eq!(fs.len(), 54);
        let mut state = 12345u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let p = DVec3::new(rnd(), rnd(), rnd());
            let inside = fs.iter().filter(|f| f.contains(p, 0.0)).count();
            assert!(inside >= 1, "{p} in no frustum");
            let strictly = fs.iter().filter(|f| f.contains(p, -1e-9)).count();
            assert!(strictly <= 1, "{p} strictly inside {strictly} frusta");
        }
    }

    #[test]
    fn a_point_on_a_shared_side_is_in_both_frusta() {
        let fs = Frustum::sphere(DVec3::ZERO, 2);
        // The +X face is split at y = 0 and z = 0: (1, 0, 0.5) is on a border.
        let p = DVec3::new(1.0, 0.0, 0.5);
        assert_eq!(fs.iter().filter(|f| f.contains(p, 1e-9)).count(), 2);
        let corner = DVec3::new(1.0, 1.0, 1.0);
        assert_eq!(fs.iter().filter(|f| f.contains(corner, 1e-9)).count(), 3);
    }

    #[test]
    fn reflection_moves_the_apex_to_the_image_and_keeps_the_real_side() {
        let f = Frustum::sphere(DVec3::new(2.0, 3.0, 1.0), 1)[0];
        let wall = Plane {
            normal: DVec3::X,
            offset: 10.0,
        };
        let r = f.reflected(&wall).unwrap();
        assert_eq!(r.apex, DVec3::new(18.0, 3.0, 1.0));
        // The real side is x < 10: the reflected frustum points back there.
        assert!(r.contains(DVec3::new(5.0, 3.0, 1.0), 0.0));
        assert!(!r.contains(DVec3::new(12.0, 3.0, 1.0), 0.0));
        let t = f.transmitted(&wall).unwrap();
        assert!(t.contains(DVec3::new(12.0, 3.0, 1.0), 0.0));
        assert!(!t.contains(DVec3::new(5.0, 3.0, 1.0), 0.0));
    }

    #[test]
    fn grazing_reflection_is_refused() {
        let f = Frustum::sphere(DVec3::new(10.0, 3.0, 1.0), 1)[0];
        let wall = Plane {
            normal: DVec3::X,
            offset: 10.0,
        };
        assert!(f.reflected(&wall).is_none());
        assert!(Frustum::new(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Y, None).is_none());
    }

    #[test]
    fn sub_windows_partition_the_window() {
        let f = Frustum::sphere(DVec3::ZERO, 1)[0];
        let a = f.sub(0.0, 0.5, 0.0, 1.0).unwrap();
        let b = f.sub(0.5, 1.0, 0.0, 1.0).unwrap();
        let p = f.apex + f.direction(0.25, 0.3) * 4.0;
        assert!(a.contains(p, 0.0) && !b.contains(p, 0.0));
        let q = f.apex + f.direction(0.75, 0.9) * 0.1;
        assert!(b.contains(q, 0.0) && !a.contains(q, 0.0));
    }
}
