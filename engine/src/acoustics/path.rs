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
use crate::query::SceneBvh;

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
/// past their end, as fractions of the leg, so the test is scale-free: a
/// leg never re-hits the surface it leaves, and still finds the one it ends
/// on when rounding puts the end point a hair behind it.
const LEG_START: f32 = 1e-5;
const LEG_END_SLACK: f32 = 1e-4;

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
        if let Some(e) = events.get(leg) {
            let hit = bvh.closest_hit(&ray.with_range(LEG_START, 1.0 + LEG_END_SLACK))?;
            if surfaces.group_of(hit.object, hit.triangle) != e.group() {
                return None;
            }
            vertices.push(PathVertex {
                event: *e,
                object: hit.object,
                triangle: hit.triangle,
                point: b,
            });
        } else if bvh.any_hit(&ray.with_range(LEG_START, 1.0 - LEG_START)) {
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
