//! Specular paths: a sequence of surface events (reflect off or pass through
//! a plane group), the image source it defines, and its exact validation.
//!
//! A frustum or the reference solver only proposes event sequences; this
//! module decides, exactly, whether a sequence is a real path from source to
//! listener: the reflection points are constructed backwards from the
//! listener through the image sources, and every leg is checked with a ray
//! query. A proposal that fails is dropped, so no approximate path is ever
//! reported.

use glam::DVec3;

use super::surfaces::Surfaces;
use crate::geometry::Ray;
use crate::query::{NearestTriangle, SceneBvh};

/// One surface event, packed as `group << 1 | transmitted`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Event(u32);

impl Event {
    pub fn reflection(group: u32) -> Self {
        Self(group << 1)
    }

    pub fn transmission(group: u32) -> Self {
        Self(group << 1 | 1)
    }

    pub fn group(self) -> u32 {
        self.0 >> 1
    }

    pub fn is_transmission(self) -> bool {
        self.0 & 1 == 1
    }
}

/// Where a valid path meets a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathVertex {
    pub event: Event,
    /// The object and (mesh-order) triangle hit.
    pub object: u32,
    pub triangle: u32,
    pub point: DVec3,
}

/// A validated specular path.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidPath {
    /// The source mirrored in every reflecting plane, in order.
    pub image_source: DVec3,
    pub vertices: Vec<PathVertex>,
    /// Total length in metres (equal to the image source's distance to the
    /// listener).
    pub length: f64,
}

impl ValidPath {
    pub fn order(&self) -> usize {
        self.vertices.len()
    }
}

/// Legs are traced from just after their start (a surface point) to just
/// past their end, as fractions of the leg, so the test is scale-free, and
/// still finds the surface a leg ends on when rounding puts the end point a
/// hair behind it. Hits on the plane group a leg leaves are skipped (a
/// straight leg cannot cross its starting plane again: such a hit is
/// rounding), so grazing legs are not rejected.
const LEG_START: f32 = 1e-5;
const LEG_END_SLACK: f32 = 1e-4;
/// Rounding tolerance of a leg: this many single-precision ulps of the
/// coordinates' magnitude. Ray-triangle distances are computed in `f32`, so
/// on a leg of a few millimetres far from the origin the relative error of
/// `t` exceeds [`LEG_END_SLACK`].
const LEG_END_ULPS: f64 = 64.0;
/// A point this close to a plane (relative to the coordinates' magnitude)
/// lies on it: f64 rounding of the constructed points.
const ON_PLANE: f64 = 1e-12;
/// Bound on the hits skipped on the group a leg leaves (coplanar duplicates).
const MAX_SKIPPED_HITS: usize = 8;

/// Checks whether `events` is a real specular path from `source` to
/// `listener` and, if so, builds it.
pub fn validate(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    source: DVec3,
    listener: DVec3,
    events: &[Event],
) -> Option<ValidPath> {
    // Image sources: images[i] is the source seen through events[..i].
    let mut images = Vec::with_capacity(events.len() + 1);
    images.push(source);
    for e in events {
        let last = *images.last()?;
        let plane = surfaces.group(e.group()).plane;
        images.push(if e.is_transmission() {
            last
        } else {
            plane.mirror(last)
        });
    }
    // Points, backwards from the listener: the surface point of event i is
    // where the line from images[i + 1] to the next point crosses its plane.
    let mut points = vec![listener; events.len() + 2];
    points[0] = source;
    for i in (0..events.len()).rev() {
        let plane = surfaces.group(events[i].group()).plane;
        let (from, to) = (images[i + 1], points[i + 2]);
        let (df, dt) = (plane.distance(from), plane.distance(to));
        // The next surface point already on this plane: both events at one
        // point, on the edge between two planes (checked by the legs
        // below). A listener on the plane is no such edge.
        if i + 1 < events.len()
            && dt.abs() <= ON_PLANE * surfaces.scale().max(to.abs().max_element())
        {
            points[i + 1] = to;
            continue;
        }
        // The plane must separate the image from the point: otherwise the
        // line never reaches the surface between them.
        if (df * dt).partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        let t = df / (df - dt);
        points[i + 1] = from + (to - from) * t;
    }
    let mut vertices = Vec::with_capacity(events.len());
    for leg in 0..=events.len() {
        let (a, b) = (points[leg], points[leg + 1]);
        let ray = Ray::segment(a.as_vec3(), b.as_vec3());
        // The group this leg leaves, if it starts on a surface.
        let leaving = leg.checked_sub(1).map(|i| events[i].group());
        let magnitude = a.abs().max_element().max(b.abs().max_element());
        // Rounding of the f32 ray queries, in metres and as a fraction of
        // the leg.
        let tol = LEG_END_ULPS * f64::from(f32::EPSILON) * magnitude;
        let len = a.distance(b);
        let tol_t = (tol / len.max(f64::MIN_POSITIVE)) as f32;
        // A leg leaving a surface ignores hits within rounding of its start
        // (the edge it may leave from).
        let start = if leaving.is_some() {
            LEG_START.max(tol_t)
        } else {
            LEG_START
        };
        if let Some(e) = events.get(leg) {
            // A leg ending on the edge between two planes (a path through a
            // corner reflector's edge, which then has a zero-length leg)
            // may hit either side there: it is checked against the
            // triangles of its own group instead.
            let (object, triangle) = if len <= tol {
                surfaces.triangle_at(bvh, e.group(), b, tol)?
            } else {
                let slack = LEG_END_SLACK.max(tol_t);
                let hit = first_hit(bvh, surfaces, &ray, start, 1.0 + slack, leaving)?;
                if surfaces.group_of(hit.object, hit.triangle) == e.group() {
                    (hit.object, hit.triangle)
                } else if (1.0 - f64::from(hit.t)) * len <= tol {
                    surfaces.triangle_at(bvh, e.group(), b, tol)?
                } else {
                    return None;
                }
            };
            vertices.push(PathVertex {
                event: *e,
                object,
                triangle,
                point: b,
            });
        } else if leaving.is_none() {
            if bvh.any_hit(&ray.with_range(LEG_START, 1.0 - LEG_START)) {
                return None;
            }
        } else if start < 1.0 - LEG_START
            && first_hit(bvh, surfaces, &ray, start, 1.0 - LEG_START, leaving).is_some()
        {
            return None;
        }
    }
    let length = points.windows(2).map(|w| w[0].distance(w[1])).sum();
    Some(ValidPath {
        image_source: *images.last()?,
        vertices,
        length,
    })
}

/// The closest hit on `ray` within `[t_min, t_max]` that is not on group
/// `skip`; after [`MAX_SKIPPED_HITS`] skipped hits, the last of them (so
/// the caller rejects the leg either way).
pub(super) fn first_hit(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    ray: &Ray,
    mut t_min: f32,
    t_max: f32,
    skip: Option<u32>,
) -> Option<NearestTriangle> {
    let mut last = None;
    for _ in 0..MAX_SKIPPED_HITS {
        let hit = bvh.closest_triangle(&ray.with_range(t_min, t_max))?;
        if Some(surfaces.group_of(hit.object, hit.triangle)) != skip {
            return Some(hit);
        }
        t_min = next_up(hit.t.max(t_min));
        last = Some(hit);
    }
    last
}

/// Removes, from paths sorted by length, every path that is another one
/// met in a different order: the same image source, length and points,
/// which happens only when a path runs through the edge between two planes
/// (both orders of the two reflections there are valid). Of each set, the
/// one with the smallest event sequence is kept, so the result does not
/// depend on which orders were proposed. Distinct paths may share an image
/// source and length (a room symmetric about a wall it reflects off twice);
/// their points differ, and both are kept.
pub fn dedup_paths(paths: &mut Vec<ValidPath>) {
    let mut kept: Vec<ValidPath> = Vec::with_capacity(paths.len());
    for p in paths.drain(..) {
        let tol = 1e-9 * p.length.max(1e-3);
        let same_points = |k: &ValidPath| {
            k.vertices.len() == p.vertices.len()
                && k.vertices
                    .iter()
                    .zip(&p.vertices)
                    .all(|(a, b)| a.point.distance(b.point) <= tol)
        };
        // Sorted by length: only the tail within `tol` can match.
        let same = kept
            .iter()
            .enumerate()
            .rev()
            .take_while(|(_, k)| p.length - k.length <= tol)
            .find(|(_, k)| k.image_source.distance(p.image_source) <= tol && same_points(k))
            .map(|(i, _)| i);
        match same {
            Some(i) => {
                let events = |q: &ValidPath| q.vertices.iter().map(|v| v.event).collect::<Vec<_>>();
                if events(&p) < events(&kept[i]) {
                    kept[i] = p;
                }
            }
            None => kept.push(p),
        }
    }
    *paths = kept;
}

/// The next `f32` above a positive `t` (`f32::next_up` needs Rust 1.86).
fn next_up(t: f32) -> f32 {
    if t > 0.0 && t.is_finite() {
        f32::from_bits(t.to_bits() + 1)
    } else {
        f32::MIN_POSITIVE
    }
}
