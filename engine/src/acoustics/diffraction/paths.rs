//! Diffracted paths from a source to a listener around one edge, or two:
//! the point on each edge where the path obeys Keller's law (equal angles
//! with the edge on both sides, which makes it the shortest path touching
//! the edges), its legs checked with ray queries, and its UTD gains.

use glam::DVec3;

use super::edges::{Edge, Edges};
use super::utd::{band_gains, WedgeEvent};
use crate::acoustics::surfaces::Surfaces;
use crate::deadline::Deadline;
use crate::geometry::Ray;
use crate::query::SceneBvh;
use crate::scene::{Bands, BAND_COUNT};
use crate::Result;

/// Where a path meets an edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgePoint {
    /// The triangle of the edge's first face, `(object, mesh-order
    /// triangle)`, and that face's plane group.
    pub object: u32,
    pub triangle: u32,
    pub group: u32,
    pub point: DVec3,
}

/// A validated diffracted path.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffractedPath {
    /// The edge points, from the source.
    pub points: Vec<EdgePoint>,
    pub length: f64,
    /// Signed pressure factor per band: the UTD coefficients and spreading,
    /// relative to the source at 1 m (no air).
    pub gain: Bands,
}

/// What a search needs of the scene.
#[derive(Clone, Copy)]
pub struct EdgeScene<'a> {
    pub bvh: &'a SceneBvh,
    pub surfaces: &'a Surfaces,
    pub edges: &'a Edges,
}

/// Closer than this to an edge's line (relative to the scene) a point has
/// no angle around it.
const ON_LINE: f64 = 1e-9;
/// Angles this close to a face count as on it (rounding of the points).
const ANGLE_TOL: f64 = 1e-9;
/// Legs are tested from and to this fraction of their length from their
/// ends, which lie on edges (or are the source and the listener).
const LEG_END: f32 = 1e-5;
/// Hits on an edge's own faces skipped per leg before it counts as blocked.
const MAX_SKIPS: usize = 8;
/// Newton steps for a two-edge path: it converges in a handful; one that
/// has not after this many is dropped.
const MAX_ROUNDS: usize = 50;

/// What a search looks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffractionSearch {
    /// Most edges a path bends around: 0, 1 or 2.
    pub order: u32,
    pub speed_of_sound: f64,
    /// Bands to compute gains in; the others are zero.
    pub active_bands: [bool; BAND_COUNT],
}

/// Every diffracted path from `source` to `listener`, sorted by length.
pub fn diffracted_paths(
    scene: EdgeScene<'_>,
    source: DVec3,
    listener: DVec3,
    search: &DiffractionSearch,
) -> Vec<DiffractedPath> {
    diffracted_paths_until(scene, source, listener, search, &Deadline::none())
        .expect("without a deadline, the search cannot fail")
}

/// [`diffracted_paths`], stopping with an error at the deadline.
pub(crate) fn diffracted_paths_until(
    scene: EdgeScene<'_>,
    source: DVec3,
    listener: DVec3,
    search: &DiffractionSearch,
    deadline: &Deadline,
) -> Result<Vec<DiffractedPath>> {
    let (order, speed, active) = (search.order, search.speed_of_sound, &search.active_bands);
    if order == 0 {
        return Ok(Vec::new());
    }
    let on_line = ON_LINE * scene.surfaces.scale();
    let edges: Vec<&Edge> = scene.edges.iter().collect();
    let mut out = Vec::new();
    // Edges whose air side holds the point, with its coordinates.
    let seen_from = |p: DVec3| -> Vec<(usize, f64)> {
        edges
            .iter()
            .enumerate()
            .filter_map(|(i, e)| {
                let a = e.around(p);
                (a.radius > on_line)
                    .then(|| air_angle(e, a.angle))
                    .flatten()
                    .map(|angle| (i, angle))
            })
            .collect()
    };
    let from_source = seen_from(source);
    let from_listener = seen_from(listener);
    let near_listener: Vec<bool> = {
        let mut v = vec![false; edges.len()];
        for &(i, _) in &from_listener {
            v[i] = true;
        }
        v
    };
    for &(i, incidence) in &from_source {
        if !near_listener[i] {
            continue;
        }
        if let Some(p) = first_order(scene, edges[i], source, listener, incidence, speed, active) {
            out.push(p);
        }
    }
    if order >= 2 {
        use rayon::prelude::*;
        let pairs: Vec<Vec<DiffractedPath>> = from_source
            .par_iter()
            .map(|&(i, incidence)| {
                deadline.check()?;
                Ok(from_listener
                    .iter()
                    .filter_map(|&(j, exit)| {
                        let pair = [edges[i], edges[j]];
                        if i == j || !sees(pair[0], pair[1]) || !sees(pair[1], pair[0]) {
                            return None;
                        }
                        let angles = [incidence, exit];
                        second_order(scene, pair, source, listener, angles, speed, active)
                    })
                    .collect())
            })
            .collect::<Result<_>>()?;
        out.extend(pairs.into_iter().flatten());
    }
    out.sort_by(|a, b| a.length.total_cmp(&b.length));
    dedup(&mut out, on_line);
    Ok(out)
}

/// Drops, from paths sorted by length, those equal to an earlier one (the
/// same points to within `tol`): a path through the point where two
/// pieces of one edge touch is found on both.
fn dedup(paths: &mut Vec<DiffractedPath>, tol: f64) {
    let mut kept: Vec<DiffractedPath> = Vec::with_capacity(paths.len());
    for p in paths.drain(..) {
        let same = |k: &DiffractedPath| {
            k.points.len() == p.points.len()
                && k.points
                    .iter()
                    .zip(&p.points)
                    .all(|(a, b)| a.point.distance(b.point) <= tol)
        };
        let duplicate = kept
            .iter()
            .rev()
            .take_while(|k| p.length - k.length <= tol)
            .any(same);
        if !duplicate {
            kept.push(p);
        }
    }
    *paths = kept;
}

/// Whether some point of `other` may lie on `e`'s air side: not if both
/// its ends lie strictly inside the solid wedge, which is convex (its
/// angle is below π), so that the whole of `other` does.
fn sees(e: &Edge, other: &Edge) -> bool {
    let inside = |p: DVec3| {
        let a = e.around(p);
        a.angle > e.wedge + ANGLE_TOL && a.angle < std::f64::consts::TAU - ANGLE_TOL
    };
    !(inside(other.start) && inside(other.end))
}

/// `angle` if it lies on the air's side of `e`, faces included (within
/// rounding: an angle a hair below 2π is face 0 seen from below it).
fn air_angle(e: &Edge, angle: f64) -> Option<f64> {
    let angle = if angle > std::f64::consts::TAU - ANGLE_TOL {
        0.0
    } else {
        angle
    };
    (angle <= e.wedge + ANGLE_TOL).then(|| angle.min(e.wedge))
}

/// The point of `e`'s line (as distance along it) where a path from `p`
/// to `q` bends by Keller's law: it divides the axial gap in the ratio of
/// the two points' distances from the line.
fn keller(e: &Edge, p: DVec3, q: DVec3) -> Option<f64> {
    let (a, b) = (e.around(p), e.around(q));
    let r = a.radius + b.radius;
    (r > 0.0).then(|| a.along + (b.along - a.along) * a.radius / r)
}

fn edge_point(e: &Edge, along: f64) -> EdgePoint {
    EdgePoint {
        object: e.object,
        triangle: e.triangle,
        group: e.groups[0],
        point: e.point(along),
    }
}

/// Whether `along` lies on the edge (within rounding of its ends).
fn on_edge(e: &Edge, along: f64, tol: f64) -> bool {
    (-tol..=e.length + tol).contains(&along)
}

#[allow(clippy::too_many_arguments)]
fn first_order(
    scene: EdgeScene<'_>,
    e: &Edge,
    source: DVec3,
    listener: DVec3,
    incidence: f64,
    speed: f64,
    active: &[bool; BAND_COUNT],
) -> Option<DiffractedPath> {
    let tol = ON_LINE * scene.surfaces.scale();
    let along = keller(e, source, listener)?;
    if !on_edge(e, along, tol) {
        return None;
    }
    let exit = air_angle(e, e.around(listener).angle)?;
    let d = e.point(along.clamp(0.0, e.length));
    let (r, s) = (source.distance(d), d.distance(listener));
    if r <= tol || s <= tol {
        return None;
    }
    let sin_skew = (e.around(source).radius / r).min(1.0);
    if !leg_clear(scene, source, d, &e.groups) || !leg_clear(scene, listener, d, &e.groups) {
        return None;
    }
    let event = WedgeEvent {
        n: e.wedge / std::f64::consts::PI,
        incidence,
        exit,
        distance: r * s * sin_skew * sin_skew / (r + s),
        sin_skew,
        grazing: 1.0,
    };
    let spreading = 1.0 / (r * s * (r + s)).sqrt();
    Some(DiffractedPath {
        points: vec![edge_point(e, along.clamp(0.0, e.length))],
        length: r + s,
        gain: band_gains(&[event], speed, active).map(|g| (f64::from(g) * spreading) as f32),
    })
}

/// The path around `edges[0]` then `edges[1]`: the edge points where the
/// path length, convex in the two positions, is least (Newton's method
/// from the middle of both edges; a path that does not converge is
/// dropped), then checked as in [`first_order`], the middle leg halved
/// where it runs along a face both edges share.
#[allow(clippy::too_many_arguments)]
fn second_order(
    scene: EdgeScene<'_>,
    edges: [&Edge; 2],
    source: DVec3,
    listener: DVec3,
    [incidence, exit]: [f64; 2],
    speed: f64,
    active: &[bool; BAND_COUNT],
) -> Option<DiffractedPath> {
    let tol = ON_LINE * scene.surfaces.scale();
    let [e1, e2] = edges;
    let at = shortest_touching(e1, e2, source, listener, tol)?;
    if !on_edge(e1, at[0], tol) || !on_edge(e2, at[1], tol) {
        return None;
    }
    let d1 = e1.point(at[0].clamp(0.0, e1.length));
    let d2 = e2.point(at[1].clamp(0.0, e2.length));
    let (r0, r1, r2) = (source.distance(d1), d1.distance(d2), d2.distance(listener));
    if r0 <= tol || r1 <= tol || r2 <= tol {
        return None;
    }
    let out1 = e1.around(d2);
    let in2 = e2.around(d1);
    if out1.radius <= tol || in2.radius <= tol {
        return None;
    }
    let exit1 = air_angle(e1, out1.angle)?;
    let incidence2 = air_angle(e2, in2.angle)?;
    // Along a face the two edges share, the first edge's wave already
    // holds that face's reflection, which the second would add again.
    let on_face = |e: &Edge, a: f64| a <= 1e-6 || a >= e.wedge - 1e-6;
    let shared = e1.groups.iter().any(|g| e2.groups.contains(g));
    let grazing = if shared && on_face(e1, exit1) && on_face(e2, incidence2) {
        0.5
    } else {
        1.0
    };
    let skip = [e1.groups[0], e1.groups[1], e2.groups[0], e2.groups[1]];
    if !leg_clear(scene, source, d1, &e1.groups)
        || !leg_clear(scene, listener, d2, &e2.groups)
        || !leg_clear(scene, d1, d2, &skip)
    {
        return None;
    }
    let sin1 = (e1.around(source).radius / r0).min(1.0);
    let sin2 = (e2.around(listener).radius / r2).min(1.0);
    let pi = std::f64::consts::PI;
    let events = [
        WedgeEvent {
            n: e1.wedge / pi,
            incidence,
            exit: exit1,
            distance: r0 * r1 * sin1 * sin1 / (r0 + r1),
            sin_skew: sin1,
            grazing: 1.0,
        },
        WedgeEvent {
            n: e2.wedge / pi,
            incidence: incidence2,
            exit,
            // The first edge's wave reaches the second with a line
            // caustic on the first edge: across it, its radius is `r1`
            // (exact for parallel edges, a door's jambs).
            distance: r1 * r2 * sin2 * sin2 / (r1 + r2),
            sin_skew: sin2,
            grazing,
        },
    ];
    let spreading = 1.0 / (r0 * r1 * r2 * (r0 + r1 + r2)).sqrt();
    Some(DiffractedPath {
        points: vec![
            edge_point(e1, at[0].clamp(0.0, e1.length)),
            edge_point(e2, at[1].clamp(0.0, e2.length)),
        ],
        length: r0 + r1 + r2,
        gain: band_gains(&events, speed, active).map(|g| (f64::from(g) * spreading) as f32),
    })
}

/// Where on the lines of `e1` and `e2` (distances along them) a path from
/// `source` to `listener` touching both is shortest: Newton's method on
/// the length, whose gradient and Hessian are those of three distances.
fn shortest_touching(
    e1: &Edge,
    e2: &Edge,
    source: DVec3,
    listener: DVec3,
    tol: f64,
) -> Option<[f64; 2]> {
    let (a, b) = (e1.axis, e2.axis);
    let mut t = [0.5 * e1.length, 0.5 * e2.length];
    for _ in 0..MAX_ROUNDS {
        let (p1, p2) = (e1.point(t[0]), e2.point(t[1]));
        let (v0, v1, v2) = (p1 - source, p1 - p2, p2 - listener);
        let (r0, r1, r2) = (v0.length(), v1.length(), v2.length());
        if r0 <= tol || r1 <= tol || r2 <= tol {
            return None;
        }
        let (n0, n1, n2) = (v0 / r0, v1 / r1, v2 / r2);
        let g = [a.dot(n0) + a.dot(n1), -b.dot(n1) + b.dot(n2)];
        let h11 = (1.0 - a.dot(n0).powi(2)) / r0 + (1.0 - a.dot(n1).powi(2)) / r1;
        let h22 = (1.0 - b.dot(n1).powi(2)) / r1 + (1.0 - b.dot(n2).powi(2)) / r2;
        let h12 = (a.dot(n1) * b.dot(n1) - a.dot(b)) / r1;
        let det = h11 * h22 - h12 * h12;
        if !(det > 0.0 && det.is_finite()) {
            return None;
        }
        let mut step = [
            (h22 * g[0] - h12 * g[1]) / det,
            (h11 * g[1] - h12 * g[0]) / det,
        ];
        // Halved while it lengthens the path: far from the minimum the
        // quadratic model can overshoot.
        let length = |t: [f64; 2]| {
            let (p1, p2) = (e1.point(t[0]), e2.point(t[1]));
            source.distance(p1) + p1.distance(p2) + p2.distance(listener)
        };
        let now = r0 + r1 + r2;
        for _ in 0..32 {
            if length([t[0] - step[0], t[1] - step[1]]) <= now {
                break;
            }
            step = [0.5 * step[0], 0.5 * step[1]];
        }
        t = [t[0] - step[0], t[1] - step[1]];
        if step[0].abs().max(step[1].abs()) <= tol {
            return Some(t);
        }
    }
    None
}

/// Whether nothing blocks the leg from `from` to `to` (a point on an
/// edge). Hits on the edges' own faces' planes (`skip`) are rounding: a
/// straight leg in the air meets those planes only at the edge.
fn leg_clear(scene: EdgeScene<'_>, from: DVec3, to: DVec3, skip: &[u32]) -> bool {
    let ray = Ray::segment(from.as_vec3(), to.as_vec3());
    let mut t_min = LEG_END;
    for _ in 0..MAX_SKIPS {
        let Some(hit) = scene
            .bvh
            .closest_triangle(&ray.with_range(t_min, 1.0 - LEG_END))
        else {
            return true;
        };
        if !skip.contains(&scene.surfaces.group_of(hit.object, hit.triangle)) {
            return false;
        }
        t_min = f32::from_bits(hit.t.max(t_min).to_bits() + 1);
    }
    false
}
