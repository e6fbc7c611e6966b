//! The conservative light map of a point light: six cube faces of texels,
//! each holding what every ray from the light through the texel's square
//! can meet, as bounds that let a pixel be proved lit or shadowed.
//!
//! Every triangle is scan converted conservatively (every texel its
//! projection touches, with a margin for the `f32` rounding of the rays
//! the reference traces), with its depth bounds over the texel. Per *part*
//! (a connected surface: triangles joined by welded edges) and texel that
//! gives the part's nearest and farthest depth there, how many of its
//! triangles strictly contain the texel's centre, and whether a *contour*
//! edge touches the texel: a boundary edge, or one between triangles facing
//! the light differently. Away from contours a part's projection has no
//! boundary, so it covers the whole texel or none of it; that is what the
//! two proofs rest on:
//! - **shadowed**: some part's contour-free projection contains the
//!   texel's centre, so every ray through the texel meets that part, no
//!   farther than the part's farthest depth there. A receiver beyond it is
//!   in shadow. The watertight ray test sees the same: a ray through an
//!   edge between two welded triangles hits one of them.
//! - **lit**: the receiver's own part is the nearest in the texel, with no
//!   contour there and exactly one triangle facing the light containing
//!   the centre, none near it (one light-facing sheet, crossed once by
//!   every ray through the texel: at the receiver), its triangles facing
//!   away (the sheets behind: a solid's far side) and every other part lie
//!   beyond the receiver.
//!
//! Anything else (a contour nearby, two layers, a part partly in front)
//! is potentially incorrect and traced.

use glam::DVec3;
use rayon::prelude::*;

use super::occluders::{ObjectOccluders, Occluders, Part, NONE};
use super::raster::{conservative, Polygon};
use crate::collision::closest_on_triangle;

/// Margin in texels every projection is grown by, beyond its rounding.
const BASE_MARGIN: f64 = 1e-3;
/// Bound on the `f32` error of a traced ray's position relative to the
/// scale of the coordinates (the direction's rounding, the move into an
/// object's frame, the shear of the watertight test: about 1e-6), with
/// room to spare.
pub(super) const RAY_ERROR: f64 = 4e-6;
/// Texels each face's frustum is grown by before triangles are clipped to
/// it, so that what lies outside cannot reach the face within its
/// rounding unless it passes very near the light.
const GUARD_TEXELS: f64 = 32.0;

/// How a triangle faces the light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Facing {
    Front,
    Back,
    /// Within the rays' rounding of containing the light.
    EdgeOn,
}

fn has_area(t: &[DVec3; 3]) -> bool {
    (t[1] - t[0]).cross(t[2] - t[0]) != DVec3::ZERO
}

fn facing(t: &[DVec3; 3], light: DVec3, scale: f64) -> Facing {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let to_light = light - t[0];
    let f = n.dot(to_light);
    let len = n.length() * to_light.length();
    let tolerance = 1e-6 + RAY_ERROR * scale / to_light.length().max(1e-300);
    if f.abs()
        .partial_cmp(&(tolerance * len))
        .is_none_or(|o| o.is_le())
    {
        Facing::EdgeOn
    } else if f > 0.0 {
        Facing::Front
    } else {
        Facing::Back
    }
}

/// Cube face `index` (0..6): depth along `+axis` (even) or `-axis` (odd).
#[derive(Clone, Copy, Debug)]
struct Face {
    axis: usize,
    sign: f64,
}

impl Face {
    fn new(index: usize) -> Self {
        Self {
            axis: index / 2,
            sign: if index % 2 == 0 { 1.0 } else { -1.0 },
        }
    }

    /// `d` (from the light) in face coordinates: image axes, then depth.
    fn frame(&self, d: DVec3) -> DVec3 {
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
pub(super) fn locate(d: DVec3, size: u32) -> (usize, f64, f64, f64) {
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

/// One face's texels, row by row.
pub struct FaceMap {
    /// Farthest depth of the nearest part proved to cover the texel
    /// (infinite where none is), and that part's nearest depth.
    pub cover_max: Vec<f32>,
    pub cover_min: Vec<f32>,
    /// Nearest depth of any part's triangles touching the texel, the part,
    /// and the nearest depth of any other part.
    pub first: Vec<f32>,
    pub first_part: Vec<u32>,
    pub second: Vec<f32>,
    /// Whether the first part's triangles facing the light form one sheet
    /// there, and the nearest depth of its triangles that do not face it.
    pub first_sheet: Vec<bool>,
    pub first_back: Vec<f32>,
    /// Nearest depth at the texel's centre: the plain shadow map.
    pub centre: Vec<f32>,
}

/// A point light's conservative cube map.
pub struct LightMap {
    pub light: DVec3,
    pub size: u32,
    /// Faces that were asked for.
    pub faces: [Option<FaceMap>; 6],
    /// Some triangle passes so close to the light that the faces cannot
    /// hold it: nothing is proved.
    pub unknown: bool,
    /// Largest coordinate magnitude of the scene and the light.
    pub scale: f64,
}

/// Per-part scratch of a face: depth bounds, centre count and flags.
struct Scratch {
    min: Vec<f32>,
    max: Vec<f32>,
    inside: Vec<u8>,
    /// Of those, the triangles facing the light.
    front_inside: Vec<u8>,
    /// Nearest depth of the triangles not facing the light.
    back_min: Vec<f32>,
    flags: Vec<u8>,
    /// Texels touched, as a box: `x0, y0, x1, y1` inclusive.
    touched: [u32; 4],
}

const CONTOUR: u8 = 1;
/// A triangle's edge passes within the margin of the texel's centre.
const AMBIGUOUS: u8 = 2;

impl Scratch {
    fn new(size: u32) -> Self {
        let n = size as usize * size as usize;
        Self {
            min: vec![f32::INFINITY; n],
            max: vec![f32::NEG_INFINITY; n],
            inside: vec![0; n],
            front_inside: vec![0; n],
            back_min: vec![f32::INFINITY; n],
            flags: vec![0; n],
            touched: [u32::MAX, u32::MAX, 0, 0],
        }
    }

    fn touch(&mut self, x: u32, y: u32) {
        let t = &mut self.touched;
        if t[0] == u32::MAX {
            *t = [x, y, x, y];
        } else {
            *t = [t[0].min(x), t[1].min(y), t[2].max(x), t[3].max(y)];
        }
    }
}

impl LightMap {
    /// The faces in `needed` of the light map at `light`, `size` texels a
    /// side.
    pub(super) fn build(occluders: &Occluders, light: DVec3, size: u32, needed: [bool; 6]) -> Self {
        let scale = occluders.scale.max(light.abs().max_element());
        let near = 1e-6 * scale.max(1e-30);
        // A point outside a face's guarded frustum at depth z reaches the
        // face only when its rounding, 3 e / z radians, spans the guard.
        let reach = (RAY_ERROR * scale * 3.0 * size as f64 / GUARD_TEXELS).max(near) * 2.0;
        let unknown = occluders.objects.par_iter().any(|o| {
            o.tris.iter().any(|t| {
                let lo = t[0].min(t[1]).min(t[2]);
                let hi = t[0].max(t[1]).max(t[2]);
                (lo - light).max_element() <= reach
                    && (light - hi).max_element() <= reach
                    && has_area(t)
                    && closest_on_triangle(light, *t).distance(light) <= reach
            })
        });
        let facings: Vec<Vec<Facing>> = occluders
            .objects
            .par_iter()
            .map(|o| {
                let s = o.scale.max(scale);
                o.tris.iter().map(|t| facing(t, light, s)).collect()
            })
            .collect();
        let mut faces: [Option<FaceMap>; 6] = Default::default();
        if !unknown {
            let built: Vec<(usize, FaceMap)> = (0..6)
                .into_par_iter()
                .filter(|&i| needed[i])
                .map(|i| {
                    (
                        i,
                        build_face(occluders, &facings, light, Face::new(i), size, near, scale),
                    )
                })
                .collect();
            for (i, f) in built {
                faces[i] = Some(f);
            }
        }
        Self {
            light,
            size,
            faces,
            unknown,
            scale,
        }
    }
}

fn build_face(
    occluders: &Occluders,
    facings: &[Vec<Facing>],
    light: DVec3,
    face: Face,
    size: u32,
    near: f64,
    scale: f64,
) -> FaceMap {
    let n = size as usize * size as usize;
    let mut map = FaceMap {
        cover_max: vec![f32::INFINITY; n],
        cover_min: vec![f32::INFINITY; n],
        first: vec![f32::INFINITY; n],
        first_part: vec![NONE; n],
        second: vec![f32::INFINITY; n],
        first_sheet: vec![false; n],
        first_back: vec![f32::INFINITY; n],
        centre: vec![f32::INFINITY; n],
    };
    let mut scratch = Scratch::new(size);
    for (o, obj) in occluders.objects.iter().enumerate() {
        let ctx = Projection {
            light,
            face,
            size,
            near,
            scale: obj.scale.max(scale),
        };
        for part in &obj.parts {
            rasterise_part(obj, part, &facings[o], &ctx, &mut scratch, &mut map.centre);
            merge(&mut scratch, part.id, size, &mut map);
        }
    }
    map
}

/// How world points land on a face.
struct Projection {
    light: DVec3,
    face: Face,
    size: u32,
    near: f64,
    scale: f64,
}

impl Projection {
    fn texel(&self, c: DVec3) -> [f64; 2] {
        let half = self.size as f64 * 0.5;
        [(c.x / c.z + 1.0) * half, (c.y / c.z + 1.0) * half]
    }

    /// Margin in texels for geometry no nearer than depth `z`: the rays'
    /// rounding `e` moves a point's image by up to `3 e / z` (`u = x / z`
    /// with `|u| <= 1.1`, both image axes).
    fn margin(&self, z: f64) -> f64 {
        BASE_MARGIN + 3.0 * RAY_ERROR * self.scale / z * self.size as f64 * 0.5
    }

    /// `e` (face coordinates) is in front of the near plane and within the
    /// face's frustum grown by the guard: one side value per plane, all
    /// non-negative inside.
    fn sides(&self, e: DVec3) -> [f64; 5] {
        let g = 1.0 + GUARD_TEXELS * 2.0 / self.size as f64;
        [
            e.z - self.near,
            g * e.z - e.x,
            g * e.z + e.x,
            g * e.z - e.y,
            g * e.z + e.y,
        ]
    }

    /// The part of a triangle (face coordinates) the face can see.
    fn clip(&self, c: &[DVec3; 3]) -> Option<Polygon> {
        let mut poly = Polygon::triangle(c);
        for k in 0..5 {
            poly = poly.clipped(|e| self.sides(e)[k])?;
        }
        Some(poly)
    }

    /// The part of a segment the face can see.
    fn clip_segment(&self, [a, b]: [DVec3; 2]) -> Option<[DVec3; 2]> {
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

fn rasterise_part(
    obj: &ObjectOccluders,
    part: &Part,
    facing: &[Facing],
    p: &Projection,
    s: &mut Scratch,
    centre: &mut [f32],
) {
    let size = p.size;
    for &t in &obj.by_part[part.tris.clone()] {
        let tri = &obj.tris[t as usize];
        if !has_area(tri) {
            continue;
        }
        let c = tri.map(|v| p.face.frame(v - p.light));
        let Some(poly) = p.clip(&c) else {
            continue;
        };
        let mut corners = [[0.0; 2]; 8];
        let (mut z_lo, mut z_hi) = (f64::INFINITY, 0.0f64);
        for (j, v) in poly.corners().iter().enumerate() {
            corners[j] = p.texel(*v);
            z_lo = z_lo.min(v.z);
            z_hi = z_hi.max(v.z);
        }
        let corners = &corners[..poly.corners().len()];
        let m = p.margin(z_lo);
        // 1/z on the plane, affine in texel coordinates: n . (u, v, 1) / k
        // with u = 2x/size - 1.
        let normal = (c[1] - c[0]).cross(c[2] - c[0]);
        let k = normal.dot(c[0]);
        let to_unit = 2.0 / size as f64;
        let plane = (k != 0.0).then(|| {
            let a = normal.x * to_unit / k;
            let b = normal.y * to_unit / k;
            [(normal.z - normal.x - normal.y) / k, a, b]
        });
        let area: f64 = (0..corners.len())
            .map(|i| {
                let (a, b) = (corners[i], corners[(i + 1) % corners.len()]);
                a[0] * b[1] - a[1] * b[0]
            })
            .sum();
        let orientation = area.signum();
        let front = facing[t as usize] == Facing::Front;
        conservative(corners, m, size, |x, y| {
            let i = (y * size + x) as usize;
            let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
            let (mut lo, mut hi) = (z_lo, z_hi);
            if let Some([c0, a, b]) = plane {
                let at = c0 + a * cx + b * cy;
                let spread = (a.abs() + b.abs()) * (0.5 + m);
                if at - spread > 0.0 {
                    lo = lo.max(1.0 / (at + spread));
                    hi = hi.min(1.0 / (at - spread));
                }
            }
            // Empty only by rounding, where the plane's range just touches
            // the corners'.
            if lo > hi {
                (lo, hi) = (hi, lo);
            }
            s.min[i] = s.min[i].min(lo as f32);
            s.max[i] = s.max[i].max(hi as f32);
            if !front {
                s.back_min[i] = s.back_min[i].min(lo as f32);
            }
            s.touch(x, y);
            if orientation == 0.0 || !orientation.is_finite() {
                s.flags[i] |= AMBIGUOUS;
                return;
            }
            // Signed distances of the centre to the edges, in texels.
            let mut nearest = f64::INFINITY;
            for j in 0..corners.len() {
                let (a, b) = (corners[j], corners[(j + 1) % corners.len()]);
                let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
                let d = orientation * (ex * (cy - a[1]) - ey * (cx - a[0])) / ex.hypot(ey);
                nearest = nearest.min(d);
            }
            if nearest > m {
                s.inside[i] = s.inside[i].saturating_add(1);
                s.front_inside[i] = s.front_inside[i].saturating_add(front as u8);
            } else if nearest > -m {
                s.flags[i] |= AMBIGUOUS;
            }
            if nearest > -m {
                if let Some([c0, a, b]) = plane {
                    let at = c0 + a * cx + b * cy;
                    if at > 0.0 {
                        centre[i] = centre[i].min((1.0 / at) as f32);
                    }
                }
            }
        });
    }
    for e in &obj.edges[part.edges.clone()] {
        let contour = e.tris[1] == NONE
            || facing[e.tris[0] as usize] != facing[e.tris[1] as usize]
            || facing[e.tris[0] as usize] == Facing::EdgeOn;
        if !contour {
            continue;
        }
        let Some(ends) = p.clip_segment(e.ends.map(|v| p.face.frame(v - p.light))) else {
            continue;
        };
        let m = p.margin(ends[0].z.min(ends[1].z));
        let seg = [p.texel(ends[0]), p.texel(ends[1])];
        conservative(&seg, m, size, |x, y| {
            s.flags[(y * size + x) as usize] |= CONTOUR;
            s.touch(x, y);
        });
    }
}

/// Folds one part's scratch into the face and clears it.
fn merge(s: &mut Scratch, part: u32, size: u32, map: &mut FaceMap) {
    let [x0, y0, x1, y1] = s.touched;
    if x0 == u32::MAX {
        return;
    }
    for y in y0..=y1 {
        for x in x0..=x1 {
            let i = (y * size + x) as usize;
            let (min, max, inside, flags) = (s.min[i], s.max[i], s.inside[i], s.flags[i]);
            let (front_inside, back_min) = (s.front_inside[i], s.back_min[i]);
            s.front_inside[i] = 0;
            s.back_min[i] = f32::INFINITY;
            s.min[i] = f32::INFINITY;
            s.max[i] = f32::NEG_INFINITY;
            s.inside[i] = 0;
            s.flags[i] = 0;
            if min == f32::INFINITY {
                continue;
            }
            let contour = flags & CONTOUR != 0;
            if !contour && inside >= 1 && max < map.cover_max[i] {
                map.cover_max[i] = max;
                map.cover_min[i] = min;
            }
            if min < map.first[i] {
                map.second[i] = map.first[i];
                map.first[i] = min;
                map.first_part[i] = part;
                map.first_sheet[i] = flags == 0 && front_inside == 1;
                map.first_back[i] = back_min;
            } else if min < map.second[i] {
                map.second[i] = min;
            }
        }
    }
    s.touched = [u32::MAX, u32::MAX, 0, 0];
}
