//! A face rendered tile by tile: triangles and contour edges are set up
//! once, binned to the tiles of `TILE x TILE` texels their grown boxes
//! touch (in part order), and each tile is rasterised and merged part by
//! part in a scratch that stays in cache, tiles in parallel.

use rayon::prelude::*;

use super::face::{texel_box, Projection, TriangleRaster};
use glam::DVec3;

use super::{Facing, Texel, AMBIGUOUS, CONTOUR, GRAZING, RAY_ERROR, TILE};
use crate::shadows::occluders::{ObjectOccluders, ObjectTopology, Part, NONE};
use crate::shadows::raster::conservative;
use crate::shadows::SHADOW_T_MIN;

/// A triangle of a part's layer 0 (facing the light) or 1, set up.
struct Triangle {
    part: u32,
    layer: usize,
    /// Facing the light, but with the light so near its plane that a
    /// traced ray from a receiver beside it may cross the plane after
    /// `SHADOW_T_MIN` by rounding alone.
    grazing: bool,
    raster: TriangleRaster,
}

/// Whether a ray from within the rounding of `tri`'s plane to the light
/// can cross that plane past `SHADOW_T_MIN`: the crossing falls at about
/// the rounding over the light's distance from the plane.
fn grazing(tri: &[DVec3; 3], p: &Projection) -> bool {
    (p.light_distance(tri) * SHADOW_T_MIN as f64)
        .partial_cmp(&(2.0 * RAY_ERROR * p.scale))
        .is_none_or(|o| o.is_le())
}

/// A contour edge's visible segment, in texels, and its margin.
struct Contour {
    part: u32,
    ends: [[f64; 2]; 2],
    margin: f64,
}

/// Bin entries with this bit set index the contours, else the triangles.
const CONTOUR_BIT: u32 = 1 << 31;

/// A face's triangles and contours, and for each tile the entries that
/// touch it, in part order.
pub(super) struct Binned {
    triangles: Vec<Triangle>,
    contours: Vec<Contour>,
    bins: Vec<Vec<u32>>,
    tiles_x: u32,
}

impl Binned {
    pub fn new(size: u32) -> Self {
        let tiles_x = size.div_ceil(TILE);
        Self {
            triangles: Vec::new(),
            contours: Vec::new(),
            bins: vec![Vec::new(); (tiles_x * tiles_x) as usize],
            tiles_x,
        }
    }

    /// Sets up and bins a part's triangles and its contour edges.
    pub fn add_part(
        &mut self,
        obj: &ObjectOccluders,
        topology: &ObjectTopology,
        part: &Part,
        facing: &[Facing],
        p: &Projection,
    ) {
        let tris = topology.by_part[part.tris.clone()].iter().copied();
        self.add_triangles(obj, tris, part.id, facing, p);
        for e in &topology.edges[part.edges.clone()] {
            let contour = e.tris[1] == NONE
                || facing[e.tris[0] as usize] != facing[e.tris[1] as usize]
                || facing[e.tris[0] as usize] == Facing::EdgeOn;
            if !contour {
                continue;
            }
            let Some(ends) = p.clip_segment(e.ends.map(|v| p.frame(v))) else {
                continue;
            };
            let margin = p.margin(ends[0].z.min(ends[1].z));
            let ends = [p.texel(ends[0]), p.texel(ends[1])];
            let bbox = texel_box(&ends, margin);
            let entry = self.contours.len() as u32 | CONTOUR_BIT;
            if self.bin(entry, bbox, p.size) {
                let part = part.id;
                self.contours.push(Contour { part, ends, margin });
            }
        }
    }

    /// Sets up and bins the triangles `tris` (slots) of `obj` as `part`.
    pub fn add_triangles(
        &mut self,
        obj: &ObjectOccluders,
        tris: impl Iterator<Item = u32>,
        part: u32,
        facing: &[Facing],
        p: &Projection,
    ) {
        for t in tris {
            // Triangles of no area too: the ray test may still see area in
            // its own rounding; they bound depths and settle nothing.
            let tri = &obj.tris[t as usize];
            let c = tri.map(|v| p.frame(v));
            let Some(poly) = p.clip(&c) else {
                continue;
            };
            let raster = TriangleRaster::new(&poly, &c, p);
            let front = facing[t as usize] == Facing::Front;
            let entry = self.triangles.len() as u32;
            if self.bin(entry, raster.texel_box(), p.size) {
                self.triangles.push(Triangle {
                    part,
                    layer: (!front) as usize,
                    grazing: front && grazing(tri, p),
                    raster,
                });
            }
        }
    }

    /// Adds `entry` to the bins of the tiles its texel box touches;
    /// whether there were any.
    fn bin(&mut self, entry: u32, [x0, y0, x1, y1]: [f64; 4], size: u32) -> bool {
        let last = size as f64 - 1.0;
        if !(x1 >= 0.0 && y1 >= 0.0 && x0 <= last && y0 <= last) {
            return false;
        }
        let tile = |v: f64| (v.clamp(0.0, last) as u32) / TILE;
        for ty in tile(y0)..=tile(y1) {
            for tx in tile(x0)..=tile(x1) {
                self.bins[(ty * self.tiles_x + tx) as usize].push(entry);
            }
        }
        true
    }

    /// Rasterises every tile into `texels` (tile-major, `TILE * TILE`
    /// texels a tile).
    pub fn render(&self, size: u32, plain: bool, texels: &mut [Texel]) {
        texels
            .par_chunks_mut((TILE * TILE) as usize)
            .zip(&self.bins)
            .enumerate()
            .for_each(|(t, (out, bin))| {
                let (tx, ty) = (t as u32 % self.tiles_x, t as u32 / self.tiles_x);
                let bounds = [
                    tx * TILE,
                    ty * TILE,
                    ((tx + 1) * TILE).min(size) - 1,
                    ((ty + 1) * TILE).min(size) - 1,
                ];
                let mut tile = Tile::new(bounds);
                for &k in bin {
                    let (part, contour) = if k & CONTOUR_BIT != 0 {
                        let c = &self.contours[(k & !CONTOUR_BIT) as usize];
                        (c.part, Some(c))
                    } else {
                        (self.triangles[k as usize].part, None)
                    };
                    if part != tile.part {
                        tile.merge(out);
                        tile.part = part;
                    }
                    match contour {
                        Some(c) => tile.contour(c),
                        None => tile.triangle(&self.triangles[k as usize], plain, out),
                    }
                }
                tile.merge(out);
            });
    }
}

/// What one part's triangles of one facing (towards the light, or not)
/// leave in a texel: bounds on their inverse depth (`near` the largest,
/// `far` the smallest) and how many strictly contain the centre.
#[derive(Clone, Copy, Debug)]
struct Layer {
    near: f32,
    far: f32,
    inside: u8,
}

impl Layer {
    const EMPTY: Self = Self {
        near: 0.0,
        far: f32::INFINITY,
        inside: 0,
    };
}

/// A part's texel: its front (facing the light) and back layers, flags.
#[derive(Clone, Copy, Debug)]
struct Cell {
    layers: [Layer; 2],
    flags: u8,
}

impl Cell {
    const EMPTY: Self = Self {
        layers: [Layer::EMPTY; 2],
        flags: 0,
    };
}

/// One tile's scratch for the part being rasterised.
struct Tile {
    bounds: [u32; 4],
    part: u32,
    cells: Vec<Cell>,
    /// Rows touched, inclusive, relative to the tile.
    rows: (u32, u32),
}

impl Tile {
    fn new(bounds: [u32; 4]) -> Self {
        Self {
            bounds,
            part: NONE,
            cells: vec![Cell::EMPTY; (TILE * TILE) as usize],
            rows: (u32::MAX, 0),
        }
    }

    fn triangle(&mut self, t: &Triangle, plain: bool, out: &mut [Texel]) {
        let [bx, by, ..] = self.bounds;
        let r = &t.raster;
        conservative(r.corners(), r.margin, self.bounds, |y, x0, x1| {
            let row = ((y - by) * TILE) as usize;
            self.rows = (self.rows.0.min(y - by), self.rows.1.max(y - by));
            let cy = y as f64 + 0.5;
            for x in x0..=x1 {
                let i = row + (x - bx) as usize;
                let cx = x as f64 + 0.5;
                let d = r.centre_distance(cx, cy);
                if plain {
                    if d > -r.margin {
                        let at = r.inverse_depth_at(cx, cy);
                        out[i].centre = out[i].centre.max(at as f32);
                    }
                    continue;
                }
                let (near, far) = r.inverse_depths(cx, cy);
                let cell = &mut self.cells[i];
                if t.grazing {
                    cell.flags |= GRAZING;
                }
                let l = &mut cell.layers[t.layer];
                l.near = l.near.max(near);
                l.far = l.far.min(far);
                if d > r.margin {
                    l.inside = l.inside.saturating_add(1);
                } else if d > -r.margin {
                    cell.flags |= AMBIGUOUS;
                }
            }
        });
    }

    fn contour(&mut self, c: &Contour) {
        let [bx, by, ..] = self.bounds;
        conservative(&c.ends, c.margin, self.bounds, |y, x0, x1| {
            let row = ((y - by) * TILE) as usize;
            self.rows = (self.rows.0.min(y - by), self.rows.1.max(y - by));
            let cells = &mut self.cells[row + (x0 - bx) as usize..=row + (x1 - bx) as usize];
            for cell in cells {
                cell.flags |= CONTOUR;
            }
        });
    }

    /// Folds the current part into the tile's texels and clears it.
    fn merge(&mut self, out: &mut [Texel]) {
        if self.rows.0 == u32::MAX {
            return;
        }
        let range = (self.rows.0 * TILE) as usize..((self.rows.1 + 1) * TILE) as usize;
        for (cell, t) in self.cells[range.clone()].iter_mut().zip(&mut out[range]) {
            let c = std::mem::replace(cell, Cell::EMPTY);
            let [front, back] = c.layers;
            let near = front.near.max(back.near);
            if near == 0.0 {
                continue;
            }
            // Away from contours each layer that holds the centre covers
            // the whole texel.
            if c.flags & CONTOUR == 0 {
                for l in c.layers {
                    if l.inside >= 1 && l.far > t.cover_far {
                        t.cover_far = l.far;
                        t.cover_near = l.near;
                    }
                }
            }
            if near > t.first {
                t.second = t.first;
                t.first = near;
                t.first_part = self.part;
                t.first_sheet = c.flags == 0 && front.inside == 1;
                t.first_back = back.near;
            } else if near > t.second {
                t.second = near;
            }
        }
        self.rows = (u32::MAX, 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shadows::light_map::face::{Face, View};

    #[test]
    fn a_triangle_with_the_light_within_rounding_reach_of_its_plane_is_grazing() {
        // Rounding reach at scale 10: 2 * 4e-6 * 10 / 1e-4 = 0.8 m.
        let tri = [
            DVec3::new(-5.0, -5.0, 0.0),
            DVec3::new(5.0, -5.0, 0.0),
            DVec3::new(0.0, 5.0, 0.0),
        ];
        let at = |height: f64| Projection {
            view: View::Cube {
                light: DVec3::new(1.0, 2.0, height),
                face: Face::new(5),
            },
            size: 64,
            near: 1e-5,
            scale: 10.0,
        };
        assert!(grazing(&tri, &at(0.5)));
        assert!(grazing(&tri, &at(-0.79)));
        assert!(!grazing(&tri, &at(0.81)));
        assert!(!grazing(&tri, &at(3.0)));
    }
}
