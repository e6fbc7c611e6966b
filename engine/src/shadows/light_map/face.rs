//! One cube face of the light map: how world points land on it (frame,
//! clipping to the guarded frustum, margins), and a clipped triangle set
//! up for its texels.

use glam::DVec3;

use super::{BASE_MARGIN, GUARD_TEXELS, RAY_ERROR};
use crate::shadows::raster::Polygon;

/// Cube face `index` (0..6): depth along `+axis` (even) or `-axis` (odd).
#[derive(Clone, Copy, Debug)]
pub(super) struct Face {
    axis: usize,
    sign: f64,
}

impl Face {
    pub fn new(index: usize) -> Self {
        Self {
            axis: index / 2,
            sign: if index % 2 == 0 { 1.0 } else { -1.0 },
        }
    }

    /// `d` (from the light) in face coordinates: image axes, then depth.
    pub fn frame(&self, d: DVec3) -> DVec3 {
        let a = d.to_array();
        DVec3::new(
            a[(self.axis + 1) % 3],
            a[(self.axis + 2) % 3],
            self.sign * a[self.axis],
        )
    }
}

/// The face, continuous texel coordinates and depth of direction `d` from
/// the light.
pub(crate) fn locate(d: DVec3, size: u32) -> (usize, f64, f64, f64) {
    let a = d.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let index = axis * 2 + (d.to_array()[axis] < 0.0) as usize;
    let f = Face::new(index).frame(d);
    let half = size as f64 * 0.5;
    (
        index,
        (f.x / f.z + 1.0) * half,
        (f.y / f.z + 1.0) * half,
        f.z,
    )
}

/// How a face's rays run from the light.
#[derive(Clone, Copy, Debug)]
pub(super) enum View {
    /// A cube face around a point light: rays from `light`, image
    /// coordinates `x / z`.
    Cube { light: DVec3, face: Face },
    /// The one face of a directional light: parallel rays along
    /// `axes[2]` (the light's direction), face coordinates `axes · (v -
    /// origin)`, image coordinates `x / half_width`. `reach` is the length
    /// its shadow rays are scaled by (see `Eye::Parallel`).
    Ortho {
        origin: DVec3,
        axes: [DVec3; 3],
        half_width: f64,
        reach: f64,
    },
}

/// How world points land on a face.
pub(super) struct Projection {
    pub view: View,
    pub size: u32,
    pub near: f64,
    pub scale: f64,
}

impl Projection {
    /// World point `v` in face coordinates: image axes, then depth.
    pub fn frame(&self, v: DVec3) -> DVec3 {
        match self.view {
            View::Cube { light, face } => face.frame(v - light),
            View::Ortho { origin, axes, .. } => {
                let d = v - origin;
                DVec3::new(axes[0].dot(d), axes[1].dot(d), axes[2].dot(d))
            }
        }
    }

    /// What image coordinates are face coordinates over, at depth `z`.
    fn unit(&self, z: f64) -> f64 {
        match self.view {
            View::Cube { .. } => z,
            View::Ortho { half_width, .. } => half_width,
        }
    }

    pub fn texel(&self, c: DVec3) -> [f64; 2] {
        let half = self.size as f64 * 0.5;
        let w = self.unit(c.z);
        [(c.x / w + 1.0) * half, (c.y / w + 1.0) * half]
    }

    /// Margin in texels for geometry no nearer than depth `z`: the rays'
    /// rounding `e` moves a point's image `u = x / w` by up to
    /// `e (1 + |u|) / w` on each axis (`w = z` from a point light, the
    /// half width across parallel rays), and `|u|` reaches the guard `g`.
    pub fn margin(&self, z: f64) -> f64 {
        let reach = 1.5 * (1.0 + self.guard());
        BASE_MARGIN + reach * RAY_ERROR * self.scale / self.unit(z) * self.size as f64 * 0.5
    }

    /// How far the light lies from the plane of `tri` (world space), along
    /// its normal: for a directional light, how far a shadow ray's reach
    /// takes it from the plane.
    pub fn light_distance(&self, tri: &[DVec3; 3]) -> f64 {
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let along = match self.view {
            View::Cube { light, .. } => n.dot(light - tri[0]),
            View::Ortho { axes, reach, .. } => n.dot(axes[2]) * reach,
        };
        along.abs() / n.length()
    }

    /// The guarded frustum's half-width in image units.
    fn guard(&self) -> f64 {
        1.0 + GUARD_TEXELS * 2.0 / self.size as f64
    }

    /// `e` (face coordinates) is in front of the near plane and within the
    /// face's frustum grown by the guard: one side value per plane, all
    /// non-negative inside.
    fn sides(&self, e: DVec3) -> [f64; 5] {
        std::array::from_fn(|k| self.side(e, k))
    }

    /// Plane `k` of [`Self::sides`].
    fn side(&self, e: DVec3, k: usize) -> f64 {
        let g = self.guard() * self.unit(e.z);
        match k {
            0 => e.z - self.near,
            1 => g - e.x,
            2 => g + e.x,
            3 => g - e.y,
            _ => g + e.y,
        }
    }

    /// The part of a triangle (face coordinates) the face can see.
    pub fn clip(&self, c: &[DVec3; 3]) -> Option<Polygon> {
        // Most triangles lie wholly outside a plane or inside all five.
        let sides = c.map(|v| self.sides(v));
        if (0..5).any(|k| sides.iter().all(|s| s[k] < 0.0)) {
            return None;
        }
        let mut poly = Polygon::triangle(c);
        for k in 0..5 {
            if sides.iter().any(|s| s[k] < 0.0) {
                poly = poly.clipped(|e| self.side(e, k))?;
            }
        }
        Some(poly)
    }

    /// The part of a segment the face can see.
    pub fn clip_segment(&self, [a, b]: [DVec3; 2]) -> Option<[DVec3; 2]> {
        let (sa, sb) = (self.sides(a), self.sides(b));
        let (mut s0, mut s1) = (0.0f64, 1.0f64);
        for k in 0..5 {
            if sa[k] < 0.0 && sb[k] < 0.0 {
                return None;
            }
            let at = sa[k] / (sa[k] - sb[k]);
            if sa[k] < 0.0 {
                s0 = s0.max(at);
            } else if sb[k] < 0.0 {
                s1 = s1.min(at);
            }
        }
        (s0 <= s1).then(|| [a + (b - a) * s0, a + (b - a) * s1])
    }
}

/// One clipped triangle on a face, set up for its texels: corners, margin,
/// inverse depth on its plane and its edges' lines, all in texel units.
pub(super) struct TriangleRaster {
    corners: [[f64; 2]; 8],
    count: usize,
    pub margin: f64,
    /// `1/z = plane[0] + plane[1] x + plane[2] y` from a point light (rays
    /// from a point meet a plane at inverse depths affine in the image),
    /// `z = ...` across parallel rays (`linear`); zeros for a plane the
    /// rays run along, whose corners alone bound it.
    plane: [f64; 3],
    linear: bool,
    spread: f64,
    /// Inverse depths of the farthest and nearest corner.
    corner_far: f64,
    corner_near: f64,
    /// Each edge's line `a x + b y + c`, unit normal pointing inwards; all
    /// zero for a triangle seen edge on, whose centre tests are ambiguous.
    edges: [[f64; 3]; 8],
}

impl TriangleRaster {
    pub fn new(poly: &Polygon, c: &[DVec3; 3], p: &Projection) -> Self {
        let count = poly.corners().len();
        let mut corners = [[0.0; 2]; 8];
        let (mut z_lo, mut z_hi) = (f64::INFINITY, 0.0f64);
        for (j, v) in poly.corners().iter().enumerate() {
            corners[j] = p.texel(*v);
            z_lo = z_lo.min(v.z);
            z_hi = z_hi.max(v.z);
        }
        let margin = p.margin(z_lo);
        let normal = (c[1] - c[0]).cross(c[2] - c[0]);
        let k = normal.dot(c[0]);
        let to_unit = 2.0 / p.size as f64;
        let (plane, linear) = match p.view {
            // 1/z on the plane n . e = k is n . (u, v, 1) / k with
            // u = 2x/size - 1: affine in texel coordinates.
            View::Cube { .. } => (
                (k != 0.0).then(|| {
                    [
                        (normal.z - normal.x - normal.y) / k,
                        normal.x * to_unit / k,
                        normal.y * to_unit / k,
                    ]
                }),
                false,
            ),
            // z on it is (k - n.x X - n.y Y) / n.z with X = w (2x/size - 1).
            View::Ortho { half_width: w, .. } => (
                (normal.z != 0.0).then(|| {
                    [
                        (k + (normal.x + normal.y) * w) / normal.z,
                        -normal.x * w * to_unit / normal.z,
                        -normal.y * w * to_unit / normal.z,
                    ]
                }),
                true,
            ),
        };
        // A plane the rays run along (or a triangle of no area): its
        // corners alone bound it, the plane bounds nothing.
        let (plane, spread) = match plane {
            Some(plane) => (plane, (plane[1].abs() + plane[2].abs()) * (0.5 + margin)),
            None => ([0.0; 3], f64::INFINITY),
        };
        let area: f64 = (0..count)
            .map(|i| {
                let (a, b) = (corners[i], corners[(i + 1) % count]);
                a[0] * b[1] - a[1] * b[0]
            })
            .sum();
        let mut edges = [[0.0; 3]; 8];
        if area != 0.0 && area.is_finite() {
            let o = area.signum();
            for (j, e) in edges.iter_mut().enumerate().take(count) {
                let (a, b) = (corners[j], corners[(j + 1) % count]);
                let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
                let len = ex.hypot(ey);
                *e = [
                    -o * ey / len,
                    o * ex / len,
                    o * (ey * a[0] - ex * a[1]) / len,
                ];
            }
        }
        Self {
            corners,
            count,
            margin,
            spread,
            plane,
            linear,
            corner_far: 1.0 / z_hi,
            corner_near: 1.0 / z_lo,
            edges,
        }
    }

    pub fn corners(&self) -> &[[f64; 2]] {
        &self.corners[..self.count]
    }

    /// Texel box `[x0, y0, x1, y1]` of the corners grown by the margin.
    pub fn texel_box(&self) -> [f64; 4] {
        texel_box(self.corners(), self.margin)
    }

    /// The inverse depth of the triangle's plane on the ray through
    /// `(cx, cy)` (0 for a plane the rays run along).
    pub fn inverse_depth_at(&self, cx: f64, cy: f64) -> f64 {
        let at = self.plane[0] + self.plane[1] * cx + self.plane[2] * cy;
        match self.linear {
            true if at > 0.0 => 1.0 / at,
            true => 0.0,
            false => at,
        }
    }

    /// Bounds on the inverse depth of the triangle over the grown texel
    /// centred at `(cx, cy)`, as `f32` (nearest, farthest).
    #[inline]
    pub fn inverse_depths(&self, cx: f64, cy: f64) -> (f32, f32) {
        let at = self.plane[0] + self.plane[1] * cx + self.plane[2] * cy;
        let (plane_near, plane_far) = if self.linear {
            let (z_lo, z_hi) = (at - self.spread, at + self.spread);
            (
                if z_lo > 0.0 {
                    1.0 / z_lo
                } else {
                    f64::INFINITY
                },
                if z_hi > 0.0 { 1.0 / z_hi } else { 0.0 },
            )
        } else {
            (at + self.spread, at - self.spread)
        };
        let near = self.corner_near.min(plane_near);
        let far = self.corner_far.max(plane_far);
        // Crossed only by rounding, where the plane's range just touches
        // the corners'.
        (near.max(far) as f32, far.min(near) as f32)
    }

    /// Signed distance in texels from `(cx, cy)` to the nearest edge,
    /// positive inside (never positive for a triangle seen edge on).
    #[inline]
    pub fn centre_distance(&self, cx: f64, cy: f64) -> f64 {
        self.edges[..self.count]
            .iter()
            .map(|e| e[0] * cx + e[1] * cy + e[2])
            .fold(f64::INFINITY, f64::min)
    }
}

/// Texel box `[x0, y0, x1, y1]` of `corners` grown by `margin`.
pub(super) fn texel_box(corners: &[[f64; 2]], margin: f64) -> [f64; 4] {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for c in corners {
        b = [
            b[0].min(c[0]),
            b[1].min(c[1]),
            b[2].max(c[0]),
            b[3].max(c[1]),
        ];
    }
    [b[0] - margin, b[1] - margin, b[2] + margin, b[3] + margin]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn projection() -> Projection {
        Projection {
            view: View::Cube {
                light: DVec3::ZERO,
                face: Face::new(4),
            },
            size: 64,
            near: 1e-6,
            scale: 1.0,
        }
    }

    #[test]
    fn a_plane_through_the_light_is_bounded_by_its_corners() {
        // The plane y = 0 holds the light: every ray from the light meets
        // it nowhere or everywhere, so only the corners bound its depth.
        let c = [
            DVec3::new(-1.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, 2.0),
        ];
        let r = TriangleRaster::new(&Polygon::triangle(&c), &c, &projection());
        for (x, y) in [(32.0, 32.0), (10.5, 40.5)] {
            assert_eq!(r.inverse_depths(x, y), (1.0, 0.5));
        }
    }

    #[test]
    fn depth_bounds_hold_the_plane_over_the_grown_texel() {
        let c = [
            DVec3::new(-1.0, -1.0, 1.0),
            DVec3::new(1.0, -1.0, 2.0),
            DVec3::new(0.0, 1.0, 1.5),
        ];
        let p = projection();
        let r = TriangleRaster::new(&Polygon::triangle(&c), &c, &p);
        // The inverse depth where the ray through (x, y) meets the plane.
        let n = (c[1] - c[0]).cross(c[2] - c[0]);
        let exact = |x: f64, y: f64| {
            let d = DVec3::new(2.0 * x / 64.0 - 1.0, 2.0 * y / 64.0 - 1.0, 1.0);
            n.dot(d) / n.dot(c[0])
        };
        let (near, far) = r.inverse_depths(30.5, 33.5);
        for (dx, dy) in [
            (-0.5, -0.5),
            (0.5, 0.5),
            (-0.5, 0.5),
            (0.5, -0.5),
            (0.0, 0.0),
        ] {
            let v = exact(30.5 + dx, 33.5 + dy) as f32;
            assert!(far <= v && v <= near, "{far} <= {v} <= {near}");
        }
    }
}
