//! The camera of a shadow query and its G-buffer: the surface each pixel
//! sees, found by rasterising the world (a z-buffer over row bands in
//! parallel), and the point where the pixel's centre ray meets it.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::occluders::Occluders;
use super::raster::Polygon;
use crate::{Error, Result};

/// Most pixels a shadow image may have (4096 x 4096).
pub const MAX_IMAGE_PIXELS: u64 = 1 << 24;

/// A pinhole camera: square pixels, `fov_y_deg` the vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, `+z` up, 60° field of
    /// view.
    pub fn looking_at(position: Vec3, look_at: Vec3, width: u32, height: u32) -> Self {
        Self {
            position,
            look_at,
            up: Vec3::Z,
            fov_y_deg: 60.0,
            width,
            height,
        }
    }

    pub fn check(&self) -> Result<()> {
        let bad = |field: &str, reason: &str| {
            Err(Error::InvalidOption {
                field: format!("camera.{field}"),
                reason: reason.into(),
            })
        };
        for (field, v) in [
            ("position", self.position),
            ("look_at", self.look_at),
            ("up", self.up),
        ] {
            if !v.is_finite() || v.abs().max_element() > 1e15 {
                return bad(field, "must be finite and within 1e15");
            }
        }
        let (forward, right, _) = self.basis();
        if !forward.is_finite() || forward == DVec3::ZERO {
            return bad("look_at", "must differ from the position");
        }
        if !right.is_finite() || right == DVec3::ZERO {
            return bad("up", "must not be zero or parallel to the view direction");
        }
        if !(self.fov_y_deg > 0.5 && self.fov_y_deg < 179.0) {
            return bad("fov_y_deg", "must lie in (0.5, 179) degrees");
        }
        if self.width == 0
            || self.height == 0
            || self.width as u64 * self.height as u64 > MAX_IMAGE_PIXELS
        {
            return bad(
                "width",
                &format!(
                    "width and height must be positive with at most {MAX_IMAGE_PIXELS} pixels"
                ),
            );
        }
        Ok(())
    }

    /// Unit forward, right and up vectors, in `f64`.
    fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let forward = (self.look_at.as_dvec3() - self.position.as_dvec3()).normalize_or_zero();
        let right = forward.cross(self.up.as_dvec3()).normalize_or_zero();
        (forward, right, right.cross(forward))
    }

    /// Pixels per unit of the image plane at distance 1.
    fn focal(&self) -> f64 {
        self.height as f64 * 0.5 / (self.fov_y_deg as f64 * 0.5).to_radians().tan()
    }

    /// Direction (not normalised) of the ray through the centre of pixel
    /// `(x, y)`, `y` down.
    pub fn pixel_direction(&self, x: u32, y: u32) -> DVec3 {
        PixelRays::of(self).direction(x, y)
    }
}

/// A camera's pixel rays, its basis worked out once.
struct PixelRays {
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    /// `(x + 0.5 - offset.0) / focal` is the pixel's offset along `right`.
    offset: (f64, f64),
    focal: f64,
}

impl PixelRays {
    fn of(camera: &Camera) -> Self {
        let (forward, right, up) = camera.basis();
        Self {
            forward,
            right,
            up,
            offset: (
                camera.width as f64 * 0.5 - 0.5,
                camera.height as f64 * 0.5 - 0.5,
            ),
            focal: camera.focal(),
        }
    }

    fn direction(&self, x: u32, y: u32) -> DVec3 {
        let px = (x as f64 - self.offset.0) / self.focal;
        let py = (y as f64 - self.offset.1) / self.focal;
        self.forward + self.right * px - self.up * py
    }
}

/// The surface point a pixel sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Receiver {
    /// Where the pixel's centre ray meets the triangle's plane.
    pub point: Vec3,
    /// Unit normal of the triangle (its winding), in the world.
    pub normal: Vec3,
    pub object: u32,
    /// Mesh triangle index.
    pub triangle: u32,
    /// The triangle's slot in the object's tree.
    pub(super) slot: u32,
}

/// The receivers of a camera's pixels, row by row (`None`: the pixel sees
/// nothing).
#[derive(Clone, Debug)]
pub struct GBuffer {
    pub width: u32,
    pub height: u32,
    pub receivers: Vec<Option<Receiver>>,
}

/// A triangle in camera space, clipped to the near plane and projected:
/// pixel coordinates, and the plane's inverse depth as an affine function
/// of them.
struct Projected {
    /// Pixel coordinates of the corners of the clipped polygon.
    corners: [[f64; 2]; 4],
    count: usize,
    /// `1/z = inv_z[0] + inv_z[1] * x + inv_z[2] * y` on the plane.
    inv_z: [f64; 3],
    /// Inclusive row range.
    rows: (u32, u32),
    /// Object and leaf slot of the triangle.
    id: (u32, u32),
}

const NO_HIT: u64 = u64::MAX;

impl GBuffer {
    /// Rasterises the world through `camera` (checked first).
    pub(super) fn render(camera: &Camera, occluders: &Occluders) -> GBuffer {
        let (w, h) = (camera.width, camera.height);
        let (forward, right, up) = camera.basis();
        let eye = camera.position.as_dvec3();
        let f = camera.focal();
        let near = 1e-6 * (occluders.scale + eye.abs().max_element()).max(1e-30);
        let view = |p: DVec3| {
            let d = p - eye;
            DVec3::new(d.dot(right), d.dot(up), d.dot(forward))
        };
        let to_pixel = |c: DVec3| {
            [
                w as f64 * 0.5 + f * c.x / c.z,
                h as f64 * 0.5 - f * c.y / c.z,
            ]
        };
        let projected: Vec<Projected> = occluders
            .objects
            .par_iter()
            .enumerate()
            .flat_map_iter(|(o, obj)| {
                obj.tris.iter().enumerate().filter_map(move |(i, t)| {
                    let c = t.map(view);
                    let poly = Polygon::triangle(&c).clipped(|p| p.z - near)?;
                    let n = (c[1] - c[0]).cross(c[2] - c[0]);
                    let k = n.dot(c[0]);
                    if k == 0.0 || n == DVec3::ZERO {
                        return None;
                    }
                    let mut corners = [[0.0; 2]; 4];
                    let mut lo = f64::INFINITY;
                    let mut hi = f64::NEG_INFINITY;
                    for (j, p) in poly.corners().iter().enumerate() {
                        corners[j] = to_pixel(*p);
                        lo = lo.min(corners[j][1]);
                        hi = hi.max(corners[j][1]);
                    }
                    // Plane n . c = k with c = z (x', y', 1), x' = (x - w/2) / f,
                    // y' = (h/2 - y) / f: 1/z = n . (x', y', 1) / k.
                    let inv_z = [
                        (n.z - n.x * w as f64 * 0.5 / f + n.y * h as f64 * 0.5 / f) / k,
                        n.x / (f * k),
                        -n.y / (f * k),
                    ];
                    let first = (lo - 0.5).ceil().max(0.0);
                    let last = (hi - 0.5).floor().min(h as f64 - 1.0);
                    (first <= last).then(|| Projected {
                        corners,
                        count: poly.corners().len(),
                        inv_z,
                        rows: (first as u32, last as u32),
                        id: (o as u32, i as u32),
                    })
                })
            })
            .collect();
        let mut best = vec![(f64::INFINITY, NO_HIT); w as usize * h as usize];
        let band = (h as usize)
            .div_ceil(rayon::current_num_threads() * 8)
            .max(1);
        best.par_chunks_mut(band * w as usize)
            .enumerate()
            .for_each(|(b, rows)| {
                let y0 = (b * band) as u32;
                let y1 = y0 + (rows.len() / w as usize) as u32 - 1;
                for (index, p) in projected.iter().enumerate() {
                    if p.rows.1 < y0 || p.rows.0 > y1 {
                        continue;
                    }
                    fill(
                        p,
                        index as u64,
                        w,
                        (y0.max(p.rows.0), y1.min(p.rows.1)),
                        y0,
                        rows,
                    );
                }
            });
        let rays = PixelRays::of(camera);
        let receivers = best
            .par_iter()
            .enumerate()
            .map(|(i, &(_, index))| {
                if index == NO_HIT {
                    return None;
                }
                let p = &projected[index as usize];
                let (object, slot) = p.id;
                let dir = rays.direction(i as u32 % w, i as u32 / w);
                receiver(occluders, object, slot, eye, dir)
            })
            .collect();
        GBuffer {
            width: w,
            height: h,
            receivers,
        }
    }
}

/// The pixel's centre ray `eye + s dir` met with the plane of the triangle.
fn receiver(
    occluders: &Occluders,
    object: u32,
    slot: u32,
    eye: DVec3,
    dir: DVec3,
) -> Option<Receiver> {
    let obj = &occluders.objects[object as usize];
    let [a, b, c] = obj.tris[slot as usize];
    let n = (b - a).cross(c - a).normalize();
    let s = n.dot(a - eye) / n.dot(dir);
    let point = (eye + dir * s).as_vec3();
    (s.is_finite() && s > 0.0 && point.is_finite()).then(|| Receiver {
        point,
        normal: n.as_vec3(),
        object,
        triangle: obj.mesh_triangle[slot as usize],
        slot,
    })
}

/// Z-buffers one projected polygon over rows `rows` of a band starting at
/// row `y0`. Pixel centres on an edge count as inside: both triangles of a
/// shared edge may claim it, and the nearer (or the earlier) wins.
fn fill(p: &Projected, index: u64, w: u32, rows: (u32, u32), y0: u32, band: &mut [(f64, u64)]) {
    let c = &p.corners[..p.count];
    let area: f64 = (0..c.len())
        .map(|i| {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum();
    if area == 0.0 || !area.is_finite() {
        return;
    }
    let s = area.signum();
    for y in rows.0..=rows.1 {
        let cy = y as f64 + 0.5;
        // The polygon's span on this row, from its edges.
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..c.len() {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            if (a[1] - cy) * (b[1] - cy) <= 0.0 && a[1] != b[1] {
                let x = a[0] + (cy - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                lo = lo.min(x);
                hi = hi.max(x);
            } else if a[1] == cy && b[1] == cy {
                lo = lo.min(a[0].min(b[0]));
                hi = hi.max(a[0].max(b[0]));
            }
        }
        let first = (lo - 0.5).ceil().max(0.0);
        let last = (hi - 0.5).floor().min(w as f64 - 1.0);
        if first.partial_cmp(&last).is_none_or(|o| o.is_gt()) {
            continue;
        }
        let row = &mut band[((y - y0) * w) as usize..][..w as usize];
        for x in first as u32..=last as u32 {
            let cx = x as f64 + 0.5;
            let inside = (0..c.len()).all(|i| {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                s * ((b[0] - a[0]) * (cy - a[1]) - (b[1] - a[1]) * (cx - a[0])) >= 0.0
            });
            if !inside {
                continue;
            }
            let inv = p.inv_z[0] + p.inv_z[1] * cx + p.inv_z[2] * cy;
            if inv <= 0.0 {
                continue;
            }
            let z = 1.0 / inv;
            let slot = &mut row[x as usize];
            if z < slot.0 {
                *slot = (z, index);
            }
        }
    }
}
