//! Per-cell classification of one triangle against a frustum, in the
//! frustum's window space, where the triangle projects to a polygon and a
//! cell to a square: the sign of a triangle edge's 2D line function at a
//! cell corner is the sign of the Plücker product of that corner ray with
//! the edge, so "all corners inside" is the fully-inside case (no sample
//! rays needed), "all corners outside one edge" is a miss, and only cells
//! inside the triangle's window bounds are looked at.

use glam::{DVec2, DVec3};

use super::frustum::Frustum;
use super::surfaces::{Plane, Surfaces, NO_GROUP};

/// Per slot (a cell, or a sample ray), the nearest depth found so far and
/// the group found there, with the farthest of those depths kept at hand:
/// it is where the cull may stop, and it is asked for after every leaf.
#[derive(Default)]
pub(super) struct NearestDepths {
    pub depth: Vec<f64>,
    pub group: Vec<u32>,
    /// Slots still at infinity: while any is, there is no stop depth.
    unset: usize,
    farthest: f64,
    /// A slot at the farthest depth came nearer: `farthest` must be redone.
    stale: bool,
}

impl NearestDepths {
    pub fn reset(&mut self, len: usize) {
        self.depth.clear();
        self.depth.resize(len, f64::INFINITY);
        self.group.clear();
        self.group.resize(len, NO_GROUP);
        self.unset = len;
        self.farthest = f64::INFINITY;
        self.stale = false;
    }

    /// Records `depth` at slot `k` if it is nearer than what is there.
    #[inline]
    fn lower(&mut self, k: usize, depth: f64, group: u32) {
        let old = self.depth[k];
        if depth.is_nan() || depth >= old {
            return;
        }
        self.depth[k] = depth;
        self.group[k] = group;
        if old == f64::INFINITY {
            self.unset -= 1;
            self.stale |= self.unset == 0;
        } else {
            self.stale |= old >= self.farthest;
        }
    }

    /// The farthest nearest depth over all slots; infinity while a slot
    /// has none.
    pub fn farthest(&mut self) -> f64 {
        if self.unset > 0 {
            return f64::INFINITY;
        }
        if self.stale {
            self.farthest = self.depth.iter().copied().fold(0.0, f64::max);
            self.stale = false;
        }
        self.farthest
    }
}

/// The cells of a frustum the triangles it meets touch
/// ([`CellAssignment::Conservative`](super::tracer::CellAssignment)).
#[derive(Default)]
pub(super) struct Contacts {
    /// `(cell, group, the triangle's nearest depth, its footprint)` per
    /// cell a triangle touches.
    pub touches: Vec<(u32, u32, f64, u32)>,
    /// Each triangle's window bounds `[x0, y0, x1, y1]` (of the part in
    /// front of the apex), widened by [`FOOTPRINT_SLACK`] and by how far
    /// they may shift as seen from a moved apex.
    pub footprints: Vec<[f64; 4]>,
    /// [`Frustum::window_shift`] for the apex moves the frusta must serve.
    shift: DVec3,
}

impl Contacts {
    /// Empties the contacts for a frustum whose apex may move by
    /// `apex_reach` metres while its children serve it.
    pub fn reset(&mut self, f: &Frustum, apex_reach: f64) {
        self.touches.clear();
        self.footprints.clear();
        self.shift = f.window_shift(apex_reach);
    }

    /// How far the window bounds of a triangle whose nearest depth is
    /// `depth` may move, along x and y. A window point `u = x / s` of a
    /// point seen from an apex moved by `d` (window offset `(dx, dy, ds)`
    /// of at most `shift`) is `u' = (x - dx) / (s - ds)`, so
    /// `u - u' = (dx - u' ds) / s`: within `(|dx| + |ds|) / s` where the
    /// point lies in the window (`|u'| <= 1`). A triangle reaching the
    /// apex's depth may move anywhere.
    fn growth(&self, depth: f64) -> (f64, f64) {
        let DVec3 { x, y, z: s } = self.shift;
        if x == 0.0 && y == 0.0 && s == 0.0 {
            return (0.0, 0.0);
        }
        if depth > 0.0 {
            ((x + s) / depth, (y + s) / depth)
        } else {
            (f64::INFINITY, f64::INFINITY)
        }
    }
}

/// The listeners that a frustum's children of the last order can propose
/// (they are visited, never expanded), for a trace that keeps no frusta.
///
/// A path that validates reflects off (or passes) one triangle, where the
/// line from the parent's apex to the listener's image in the triangle's
/// group plane (or to the listener) passes through it, to within the
/// rounding validation accepts. Triangles no such line passes through
/// (with [`LAST_ORDER_SLACK`] to spare) hand out no cells, and cover none:
/// the children left are those that can propose a valid path, occlusion
/// only weakens, and no path is lost. In a detailed hall nearly all frusta
/// are of the last order, and almost none of them holds a listener.
#[derive(Clone, Copy)]
pub(super) struct LastOrder<'a> {
    pub listeners: &'a [DVec3],
    /// Whether the triangle's material passes sound through.
    pub transmits: bool,
}

/// How far, as a fraction of the coordinates' magnitude, the line to a
/// listener's image may pass a triangle and still count as through it:
/// validation accepts a leg's end within 64 f32 ulps of its coordinates
/// (7.6e-6 of them, `path::LEG_END_ULPS`).
const LAST_ORDER_SLACK: f64 = 1e-5;

impl LastOrder<'_> {
    /// Whether a listener can be reached through the triangle `p` of a
    /// group of `plane`, `apex_distance` from the apex: by reflection,
    /// where the line from the apex to the listener's image in the plane
    /// passes through the triangle, or passing through, where the line to
    /// the listener does. The triangle is taken as it is, not as its
    /// group's plane, which its own may miss by the grouping's tolerance
    /// (far more than the slack, along a grazing line).
    fn reached(
        &self,
        apex: DVec3,
        apex_distance: f64,
        plane: Plane,
        p: &[DVec3; 3],
        scale: f64,
    ) -> bool {
        // The planes through the apex and each edge: a line's direction
        // `d` against edge k's gives `|e_k| h / t` times the distance from
        // the edge's line at which the line crosses the triangle (h the
        // apex's distance from the plane, t the fraction of the segment
        // where it crosses), positive on one side of every edge inside.
        let q = p.map(|c| c - apex);
        let sides = [q[0].cross(q[1]), q[1].cross(q[2]), q[2].cross(q[0])];
        let edges = [p[1] - p[0], p[2] - p[1], p[0] - p[2]].map(|e| e.abs().element_sum());
        let magnitude = p
            .iter()
            .map(|c| c.abs().max_element())
            .fold(scale, f64::max);
        let slack = LAST_ORDER_SLACK * magnitude * apex_distance.abs();
        // The line from the apex to `to`, `to_distance` from the plane on
        // its other side.
        let through = |to: DVec3, to_distance: f64| {
            // As `!(>= 0)`, so that NaN is kept.
            if apex_distance * to_distance >= 0.0 {
                return false;
            }
            let t = apex_distance / (apex_distance - to_distance);
            let d = to - apex;
            let s = sides.map(|n| n.dot(d));
            let b = edges.map(|e| slack * e / t);
            // Inside with either orientation; NaN is kept.
            let outside_one_way = (s[0] < -b[0]) | (s[1] < -b[1]) | (s[2] < -b[2]);
            let outside_other_way = (s[0] > b[0]) | (s[1] > b[1]) | (s[2] > b[2]);
            !outside_one_way || !outside_other_way
        };
        self.listeners.iter().any(|&l| {
            let d = plane.distance(l);
            through(plane.mirror(l), -d) || (self.transmits && through(l, d))
        })
    }
}

/// What [`classify`] records a triangle into.
pub(super) enum Target<'a> {
    /// Cover depths per cell and the contacts
    /// ([`CellAssignment::Conservative`](super::tracer::CellAssignment)),
    /// only of triangles that show a listener if `LastOrder` is given.
    Cells(
        &'a mut NearestDepths,
        &'a mut Contacts,
        Option<LastOrder<'a>>,
    ),
    /// Nearest hit per sample ray: `(N+1)^2` cell corners, then `N^2` cell
    /// centres ([`CellAssignment::Sampled`](super::tracer::CellAssignment)).
    Samples(&'a mut NearestDepths),
}

/// Window distance within which a point counts as on a line.
const MARGIN: f64 = 1e-9;

/// Window distance by which a triangle's footprint is widened before it
/// bounds a secondary frustum: a path grazing the outer edge of a plane
/// group meets it to within the rounding that validation accepts (f32
/// corners), far above [`MARGIN`]; a millionth of the window costs nothing.
const FOOTPRINT_SLACK: f64 = 1e-6;

/// Classifies one triangle against the cells of frustum `f`: records a
/// contact for every cell it touches and lowers the cover depth of every
/// cell it fully covers, or, sampling, records it where it is the nearest
/// hit of a sample ray.
pub(super) fn classify(
    f: &Frustum,
    surfaces: &Surfaces,
    corners: &[glam::Vec3A; 3],
    group: u32,
    n: usize,
    scale: f64,
    target: Target,
) {
    let plane = surfaces.group(group).plane;
    let apex_distance = plane.distance(f.apex);
    // A plane through the apex is seen edge-on: it neither reflects nor
    // hides anything.
    if apex_distance.abs() <= 1e-12 * scale {
        return;
    }
    let p = corners.map(|c| c.as_dvec3());
    if let Target::Cells(_, _, Some(last)) = &target {
        if !last.reached(f.apex, apex_distance, plane, &p, scale) {
            return;
        }
    }
    let mut wholly_valid = true;
    if let Some(near) = &f.near {
        let d = p.map(|q| near.distance(q));
        let tol = 1e-9 * scale;
        if d.iter().all(|&x| x < tol) {
            return;
        }
        wholly_valid = d.iter().all(|&x| x > tol);
    }
    let w = p.map(|q| f.window_coords(q));
    let s_min = 1e-12 * scale;
    let mut poly = [DVec2::ZERO; 4];
    let (count, clipped) = project(&w, s_min, &mut poly);
    if count < 3 {
        return;
    }
    let poly = &poly[..count];
    let (lo, hi) = poly.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    );
    if hi.x < -MARGIN || hi.y < -MARGIN || lo.x > 1.0 + MARGIN || lo.y > 1.0 + MARGIN {
        return;
    }
    let nf = n as f64;
    // Truncation is the floor here (the value is clamped non-negative
    // first), without a call to libm's floor on baseline x86-64.
    let cell_range = |a: f64, b: f64| {
        let first = ((a - MARGIN) * nf).clamp(0.0, nf - 1.0) as usize;
        let last = ((b + MARGIN) * nf).clamp(0.0, nf - 1.0) as usize;
        (first, last)
    };
    let (i0, i1) = cell_range(lo.x, hi.x);
    let (j0, j1) = cell_range(lo.y, hi.y);
    let area2: f64 = (0..count)
        .map(|k| poly[k].perp_dot(poly[(k + 1) % count]))
        .sum();
    if area2 == 0.0 || !area2.is_finite() {
        return;
    }
    let orient = area2.signum();
    let mut edges = [Edge::default(); 4];
    for k in 0..count {
        edges[k] = Edge::new(poly[k], poly[(k + 1) % count], orient);
    }
    let edges = &edges[..count];
    let step = 1.0 / n as f64;
    let plane_offset = -apex_distance;
    let (cover, contacts) = match target {
        Target::Cells(cover, contacts, _) => (cover, contacts),
        Target::Samples(samples) => {
            let footprint = Footprint {
                edges,
                cells: [i0, i1, j0, j1],
                n,
                wholly_valid,
            };
            record_samples(f, plane, scale, group, &footprint, samples);
            return;
        }
    };
    let depth = w.iter().map(|q| q.z).fold(f64::INFINITY, f64::min).max(0.0);
    let can_cover = wholly_valid && !clipped;
    let footprint = contacts.footprints.len() as u32;
    let (gx, gy) = contacts.growth(depth);
    let (gx, gy) = (gx + FOOTPRINT_SLACK, gy + FOOTPRINT_SLACK);
    contacts
        .footprints
        .push([lo.x - gx, lo.y - gy, hi.x + gx, hi.y + gy]);
    for i in i0..=i1 {
        for j in j0..=j1 {
            let c = [
                DVec2::new(i as f64 * step, j as f64 * step),
                DVec2::new((i + 1) as f64 * step, j as f64 * step),
                DVec2::new((i + 1) as f64 * step, (j + 1) as f64 * step),
                DVec2::new(i as f64 * step, (j + 1) as f64 * step),
            ];
            // Every edge's four tests, without a branch per test: which
            // way they go does not predict.
            let mut inside_all = true;
            let mut separated = false;
            for edge in edges {
                let [e0, e1, e2, e3] = c.map(|q| edge.value(q));
                let m = edge.margin;
                separated |= (e0 < -m) & (e1 < -m) & (e2 < -m) & (e3 < -m);
                inside_all &= (e0 > m) & (e1 > m) & (e2 > m) & (e3 > m);
            }
            if separated {
                continue;
            }
            let cell = (i * n + j) as u32;
            contacts.touches.push((cell, group, depth, footprint));
            if can_cover && inside_all {
                // Depth of the plane along each corner direction; the
                // farthest bounds the plane over the whole cell.
                let far = c
                    .iter()
                    .map(|q| plane_offset / plane.normal.dot(f.direction(q.x, q.y)))
                    .fold(0.0f64, f64::max);
                cover.lower(cell as usize, far, group);
            }
        }
    }
}

/// An edge line of a polygon in the window, the polygon on its positive
/// side.
///
/// Its normal is the edge turned, not normalised: its value at a point is
/// the distance times the edge's length, and [`MARGIN`] is scaled by the
/// edge's L1 length, at least the Euclidean one, so a point is within
/// `margin` where it is within at least `MARGIN` of the line (never less,
/// at most √2 times more). That keeps every test as conservative as with
/// a normalised edge, without a square root and a division per edge.
#[derive(Clone, Copy, Default)]
struct Edge {
    normal: DVec2,
    offset: f64,
    margin: f64,
}

impl Edge {
    /// The edge from `a` to `b` of a polygon of orientation `orient`
    /// (the sign of its area).
    #[inline]
    fn new(a: DVec2, b: DVec2, orient: f64) -> Self {
        let d = b - a;
        let normal = DVec2::new(-d.y, d.x) * orient;
        Self {
            normal,
            offset: normal.dot(a),
            margin: MARGIN * (d.x.abs() + d.y.abs()),
        }
    }

    /// The distance of `q` from the line, times the edge's length: positive
    /// on the polygon's side.
    #[inline]
    fn value(&self, q: DVec2) -> f64 {
        self.normal.x * q.x + self.normal.y * q.y - self.offset
    }
}

/// A triangle projected into a frustum's window.
struct Footprint<'a> {
    /// Edge lines, the triangle on their positive side.
    edges: &'a [Edge],
    /// The cells its window bounds span, `[i0, i1, j0, j1]` inclusive.
    cells: [usize; 4],
    n: usize,
    /// No part of it lies behind the frustum's near plane.
    wholly_valid: bool,
}

/// Records the triangle (of plane group `group`) at every sample ray of its
/// cells that meets it nearer than what that ray has met so far.
fn record_samples(
    f: &Frustum,
    plane: Plane,
    scale: f64,
    group: u32,
    footprint: &Footprint,
    samples: &mut NearestDepths,
) {
    let Footprint {
        edges,
        cells: [i0, i1, j0, j1],
        n,
        wholly_valid,
    } = *footprint;
    let step = 1.0 / n as f64;
    let plane_offset = -plane.distance(f.apex);
    // The plane's depth along window point (x, y) is `plane_offset` over
    // `normal · direction(x, y)`, and that denominator is linear in (x, y).
    let (d0, du, dv) = (
        plane.normal.dot(f.corner),
        plane.normal.dot(f.edge_u),
        plane.normal.dot(f.edge_v),
    );
    // As `!any(< -margin)`, so a zero-length edge (value and margin 0)
    // rejects nothing.
    let inside = |x: f64, y: f64| {
        !edges
            .iter()
            .any(|edge| edge.value(DVec2::new(x, y)) < -edge.margin)
    };
    let mut record = |k: usize, x: f64, y: f64| {
        let depth = plane_offset / (d0 + du * x + dv * y);
        if !(depth > 0.0 && depth < samples.depth[k]) {
            return;
        }
        // A triangle wholly on the valid side of the near plane needs no
        // test per hit point.
        let valid = wholly_valid
            || f.near.as_ref().is_none_or(|near| {
                near.distance(f.apex + f.direction(x, y) * depth) > 1e-9 * scale
            });
        if valid {
            samples.lower(k, depth, group);
        }
    };
    for i in i0..=i1 + 1 {
        let x = i as f64 * step;
        let y = |j: usize| j as f64 * step;
        for j in row_span(j0..=j1 + 1, |j| inside(x, y(j))) {
            record(i * (n + 1) + j, x, y(j));
        }
    }
    for i in i0..=i1 {
        let x = (i as f64 + 0.5) * step;
        let y = |j: usize| (j as f64 + 0.5) * step;
        for j in row_span(j0..=j1, |j| inside(x, y(j))) {
            record((n + 1) * (n + 1) + i * n + j, x, y(j));
        }
    }
}

/// The `j` of `range` for which `inside(j)` holds, given that they form
/// one run: only the points outside it at either end are tested.
///
/// Along a row of sample points, an edge's test `a x + b y - c >= -margin`
/// is monotone in `y` even as rounded (every rounded operation is monotone
/// in its operand), so each edge keeps a run of the row and the convex
/// polygon's edges together keep one: the same points as testing each.
fn row_span(
    range: std::ops::RangeInclusive<usize>,
    inside: impl Fn(usize) -> bool,
) -> std::ops::Range<usize> {
    let (mut first, last) = range.into_inner();
    let mut end = last + 1;
    while first < end && !inside(first) {
        first += 1;
    }
    while end > first + 1 && !inside(end - 1) {
        end -= 1;
    }
    first..end
}

/// Projects a triangle given in window coordinates `(x, y, s)` onto the
/// window, first clipping away the part with `s < s_min` (behind or at the
/// apex). Returns the vertex count and whether anything was clipped.
fn project(w: &[DVec3; 3], s_min: f64, out: &mut [DVec2; 4]) -> (usize, bool) {
    let mut count = 0;
    let mut clipped = false;
    for k in 0..3 {
        let (a, b) = (w[k], w[(k + 1) % 3]);
        let a_in = a.z >= s_min;
        if a_in {
            out[count] = DVec2::new(a.x / a.z, a.y / a.z);
            count += 1;
        } else {
            clipped = true;
        }
        if a_in != (b.z >= s_min) && count < 4 {
            let t = (s_min - a.z) / (b.z - a.z);
            let q = a + (b - a) * t;
            out[count] = DVec2::new(q.x / q.z, q.y / q.z);
            count += 1;
        }
    }
    (count, clipped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn farthest_is_infinite_until_every_slot_is_set_then_follows_the_slots() {
        let mut d = NearestDepths::default();
        d.reset(3);
        d.lower(0, 5.0, 1);
        d.lower(1, 2.0, 1);
        assert_eq!(d.farthest(), f64::INFINITY);
        d.lower(2, 3.0, 2);
        assert_eq!(d.farthest(), 5.0);
        // Not nearer: ignored.
        d.lower(0, 6.0, 3);
        assert_eq!((d.farthest(), d.group[0]), (5.0, 1));
        // A slot below the farthest changes nothing of it.
        d.lower(1, 1.0, 3);
        assert_eq!(d.farthest(), 5.0);
        // The farthest slot comes nearer: the next farthest takes over.
        d.lower(0, 0.5, 3);
        assert_eq!(d.farthest(), 3.0);
        d.lower(2, f64::NAN, 3);
        assert_eq!(d.farthest(), 3.0);
        d.reset(2);
        assert_eq!(d.farthest(), f64::INFINITY);
    }

    #[test]
    fn clipping_at_the_apex_keeps_the_part_in_front() {
        let w = [
            DVec3::new(0.5, 0.5, 1.0),
            DVec3::new(1.0, 0.5, 1.0),
            DVec3::new(0.5, 0.5, -1.0),
        ];
        let mut out = [DVec2::ZERO; 4];
        let (count, clipped) = project(&w, 1e-3, &mut out);
        assert!(clipped);
        assert_eq!(count, 4);
        assert!(out[..count].iter().all(|q| q.is_finite()));
        let (count, clipped) = project(&[w[0], w[1], DVec3::new(0.0, 1.0, 2.0)], 1e-3, &mut out);
        assert_eq!((count, clipped), (3, false));
        assert_eq!(out[2], DVec2::new(0.0, 0.5));
    }
}
