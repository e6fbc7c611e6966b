//! The conservative light map of a point light (six cube faces of texels)
//! or of a directional light (one orthographic face across the scene),
//! each texel holding what every ray from the light through its square
//! can meet, as bounds that let a pixel be proved lit or shadowed.
//!
//! Every triangle is scan converted conservatively (every texel its
//! projection touches, with a margin for the `f32` rounding of the rays
//! the reference traces), with its depth bounds over the texel. Per *part*
//! (a connected surface: triangles joined by welded edges) and texel that
//! gives, for each of its two *layers* (the triangles facing the light,
//! and the rest), the nearest and farthest depth there and how many of
//! them strictly contain the texel's centre, and whether a *contour* edge
//! touches the texel: a boundary edge, or one between triangles facing the
//! light differently. Away from contours a layer's projection has no
//! boundary, so it covers the whole texel or none of it; that is what the
//! two proofs rest on:
//! - **shadowed**: some layer's contour-free projection contains the
//!   texel's centre, so every ray through the texel meets that layer, no
//!   farther than its farthest depth there. A receiver beyond it is in
//!   shadow (the far side of a solid, too: its near side covers it). The
//!   watertight ray test sees the same: a ray through an edge between two
//!   welded triangles hits one of them.
//! - **lit**: the receiver's own part is the nearest in the texel, with no
//!   contour there and exactly one triangle facing the light containing
//!   the centre, none near it (one light-facing sheet, crossed once by
//!   every ray through the texel: at the receiver), its triangles facing
//!   away (the sheets behind: a solid's far side) and every other part lie
//!   beyond the receiver, and no light-facing triangle there has the light
//!   so near its plane that rounding alone could make a ray cross it.
//!
//! Anything else (a contour nearby, two layers, a part partly in front)
//! is potentially incorrect and traced.

mod face;
mod tiles;

use glam::DVec3;
use rayon::prelude::*;

pub(crate) use face::locate;
use face::{Face, Projection, View};
use tiles::Binned;

use super::eye::Eye;
use super::occluders::{Occluders, Topology, NONE};
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
/// Side of the tiles a face is rendered in: a tile's scratch (28 bytes a
/// texel) stays in the core's cache.
const TILE: u32 = 32;

const CONTOUR: u8 = 1;
/// A triangle's edge passes within the margin of the texel's centre.
const AMBIGUOUS: u8 = 2;
/// A light-facing triangle nearly contains the light (see `tiles`).
const GRAZING: u8 = 4;

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

fn facing(t: &[DVec3; 3], eye: &Eye, scale: f64) -> Facing {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let to_light = eye.towards_light(t[0]);
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

/// One texel of a face, as inverse depths (0: nothing).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texel {
    /// Of the layers proved to cover the texel, the one whose farthest
    /// point is nearest: that point, and its nearest.
    pub cover_far: f32,
    pub cover_near: f32,
    /// Nearest point of any part touching the texel, and the nearest point
    /// of any other part.
    pub first: f32,
    pub second: f32,
    /// Nearest point of the first part's triangles that do not face the
    /// light.
    pub first_back: f32,
    /// Nearest point at the texel's centre: the plain shadow map.
    pub centre: f32,
    pub first_part: u32,
    /// Whether the first part's triangles facing the light form one sheet
    /// there.
    pub first_sheet: bool,
}

impl Texel {
    const EMPTY: Self = Self {
        cover_far: 0.0,
        cover_near: 0.0,
        first: 0.0,
        second: 0.0,
        first_back: 0.0,
        centre: 0.0,
        first_part: NONE,
        first_sheet: false,
    };
}

/// One face's texels, tile by tile.
pub struct FaceMap {
    size: u32,
    texels: Vec<Texel>,
}

impl FaceMap {
    /// The texel at `(x, y)`, both below the face's size.
    pub fn at(&self, x: u32, y: u32) -> &Texel {
        let tiles_x = self.size.div_ceil(TILE);
        let tile = (y / TILE) * tiles_x + x / TILE;
        &self.texels[(tile * TILE * TILE + (y % TILE) * TILE + x % TILE) as usize]
    }
}

/// A point light's cube map, or a directional light's one face.
pub struct LightMap {
    pub(in crate::shadows) eye: Eye,
    pub size: u32,
    /// Faces that were asked for (a directional light's is the first).
    pub faces: [Option<FaceMap>; 6],
    /// How points land on a directional light's face.
    parallel: Option<Projection>,
    /// Some triangle passes so close to the light that the faces cannot
    /// hold it: nothing is proved.
    pub unknown: bool,
    /// Largest coordinate magnitude of the scene and the light.
    pub scale: f64,
}

impl LightMap {
    /// The faces in `needed` of the light map of `eye`, `size` texels a
    /// side (a directional light has one face, always built); without
    /// `topology` only the plain shadow map (the depth at each texel's
    /// centre), which needs none.
    pub(in crate::shadows) fn build(
        occluders: &Occluders,
        topology: Option<&Topology>,
        eye: &Eye,
        size: u32,
        needed: [bool; 6],
    ) -> Self {
        let plain = topology.is_none();
        let (light, parallel) = match *eye {
            Eye::Point { light, .. } => (Some(light.as_dvec3()), None),
            Eye::Parallel { direction, reach } => (
                None,
                Some(parallel_view(
                    occluders,
                    direction.as_dvec3(),
                    f64::from(reach),
                )),
            ),
        };
        let scale = occluders
            .scale
            .max(light.map_or(0.0, |l| l.abs().max_element()));
        let near = 1e-6 * scale.max(1e-30);
        let needed = if parallel.is_some() {
            std::array::from_fn(|i| i == 0)
        } else {
            needed
        };
        // A point outside a face's guarded frustum at depth z reaches the
        // face only when its rounding, 3 e / z radians, spans the guard.
        let reach = (RAY_ERROR * scale * 3.0 * size as f64 / GUARD_TEXELS).max(near) * 2.0;
        let unknown = !plain
            && light.is_some_and(|light| {
                occluders.objects.par_iter().any(|o| {
                    o.tris.iter().any(|t| {
                        let lo = t[0].min(t[1]).min(t[2]);
                        let hi = t[0].max(t[1]).max(t[2]);
                        (lo - light).max_element() <= reach
                            && (light - hi).max_element() <= reach
                            && (!has_area(t)
                                || closest_on_triangle(light, *t).distance(light) <= reach)
                    })
                })
            });
        let view = |i: usize| match light {
            Some(light) => View::Cube {
                light,
                face: Face::new(i),
            },
            None => parallel.expect("an eye that is not a point is parallel"),
        };
        let facings: Vec<Vec<Facing>> = occluders
            .objects
            .par_iter()
            .map(|o| {
                let s = o.scale.max(scale);
                o.tris.iter().map(|t| facing(t, eye, s)).collect()
            })
            .collect();
        let mut faces: [Option<FaceMap>; 6] = Default::default();
        if !unknown {
            let built: Vec<(usize, FaceMap)> = (0..6)
                .into_par_iter()
                .filter(|&i| needed[i])
                .map(|i| {
                    let mut binned = Binned::new(size);
                    for (o, obj) in occluders.objects.iter().enumerate() {
                        let p = Projection {
                            view: view(i),
                            size,
                            near,
                            scale: obj.scale.max(scale),
                        };
                        match topology {
                            Some(t) => {
                                let t = &t.objects[o];
                                for part in &t.parts {
                                    binned.add_part(obj, t, part, &facings[o], &p);
                                }
                            }
                            None => {
                                let all = 0..obj.tris.len() as u32;
                                binned.add_triangles(obj, all, o as u32, &facings[o], &p);
                            }
                        }
                    }
                    let tiles = size.div_ceil(TILE) as usize;
                    let mut texels = vec![Texel::EMPTY; tiles * tiles * (TILE * TILE) as usize];
                    binned.render(size, plain, &mut texels);
                    (i, FaceMap { size, texels })
                })
                .collect();
            for (i, f) in built {
                faces[i] = Some(f);
            }
        }
        Self {
            eye: *eye,
            size,
            faces,
            parallel: parallel.map(|view| Projection {
                view,
                size,
                near,
                scale,
            }),
            unknown,
            scale,
        }
    }

    /// Where world point `x` falls on the map: face, continuous texel
    /// coordinates and depth; `None` off a directional light's face.
    pub(in crate::shadows) fn locate(&self, x: DVec3) -> Option<(usize, f64, f64, f64)> {
        match (&self.eye, &self.parallel) {
            (Eye::Point { light, .. }, _) => Some(locate(x - light.as_dvec3(), self.size)),
            (Eye::Parallel { .. }, Some(p)) => {
                let c = p.frame(x);
                let [tx, ty] = p.texel(c);
                let size = f64::from(self.size);
                ((0.0..size).contains(&tx) && (0.0..size).contains(&ty)).then_some((0, tx, ty, c.z))
            }
            (Eye::Parallel { .. }, None) => None,
        }
    }
}

/// The face of a directional light travelling along `direction` (unit):
/// a square across every occluder's shadow column, its depths starting
/// one scene depth (or width) in front of the nearest occluder, so that
/// depths over the scene stay within a factor of about two of each other
/// and the inverse depths the texels hold keep their precision.
fn parallel_view(occluders: &Occluders, direction: DVec3, reach: f64) -> View {
    let (e1, e2) = direction.any_orthonormal_pair();
    let axes = [e1, e2, direction];
    let (lo, hi) = occluders
        .objects
        .iter()
        .flat_map(|o| o.tris.iter().flatten())
        .map(|&v| DVec3::new(e1.dot(v), e2.dot(v), direction.dot(v)))
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(c), hi.max(c))
        });
    if !(lo.cmple(hi).all()) {
        // Nothing to cast a shadow: any face will do.
        return View::Ortho {
            origin: -direction,
            axes,
            half_width: 1.0,
            reach,
        };
    }
    let centre = (lo + hi) * 0.5;
    let extent = hi - lo;
    let tiny = 1e-9 * occluders.scale.max(1e-30);
    let half_width = (0.5 * extent.x.max(extent.y)).max(tiny) * (1.0 + 1e-6);
    let depth = extent.z.max(2.0 * half_width);
    View::Ortho {
        origin: e1 * centre.x + e2 * centre.y + direction * (lo.z - depth),
        axes,
        half_width,
        reach,
    }
}
