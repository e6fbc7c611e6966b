//! What a receiver's view of an area light proves.
//!
//! Every shadow ray from a receiver `p` to a sample of the light runs
//! inside the hull: the pyramid from `p` over the parallelogram holding the
//! samples, cut to the traced range (the slab between the planes at
//! fractions `SHADOW_T_MIN` and `1 - SHADOW_T_MIN` of the way to the
//! light's plane). Walking the world with the hull's planes finds the
//! triangles that may meet it (the candidates):
//! - none: every sample is **lit**;
//! - a **cover**, the receiver is in the umbra: triangles of one part that
//!   all face `p` the same way, none of their edges inside the hull's cone
//!   unless the triangle across is one of them, and their pieces in the
//!   cone strictly inside the slab. Seen from `p` they form a sheet without
//!   rim across the whole cone (open and closed in it, and not empty), so
//!   every ray crosses it in its traced range, and the welded edges leave
//!   the watertight ray test no gap;
//! - otherwise the receiver is in the penumbra, or unproven: its samples
//!   are traced.
//!
//! Every plane is moved outward by a margin covering the `f32` rounding of
//! the traced rays (as for the light map's proofs), so a proof holds for
//! the rays as traced, not only for exact segments.

use glam::{DVec3, Vec3, Vec3A};

use super::light_map::RAY_ERROR;
use super::occluders::{Occluders, Topology, NONE};
use super::selective::SHADOW_T_MIN;
use crate::bvh::traverse::NodeTest;
use crate::bvh::traverse::{Flow, FrustumTest};
use crate::bvh::SceneBvh;
use crate::geometry::{Aabb, Ray, WatertightRay};
use crate::query::local;

/// What a receiver's hull proves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Cover {
    Lit,
    Umbra,
    /// Penumbra or unproven: trace the samples.
    Unknown,
}

/// More candidates than this and the receiver is traced: the proof would
/// cost more than its rays.
const MAX_CANDIDATES: usize = 96;

/// A triangle that may meet a hull.
#[derive(Clone, Copy, Debug)]
pub(super) struct Candidate {
    part: u32,
    /// 1 when the triangle faces the receiver, -1 when it faces away, 0
    /// when the receiver is within rounding of its plane.
    facing: i8,
    object: u32,
    slot: u32,
}

/// The receiver's hull over the light's parallelogram.
pub(super) struct Hull {
    apex: DVec3,
    /// Inward unit normals of the four sides, through the apex.
    sides: [DVec3; 4],
    /// Unit normal of the light's plane, away from the apex.
    normal: DVec3,
    /// The apex's distance to the light's plane.
    height: f64,
    /// The corners of the cut pyramid.
    corners: [DVec3; 8],
    /// The grown hull's planes `n · x + d >= 0` (see [`Self::side`]).
    planes: [(DVec3, f64); 6],
    /// How far a traced ray may stray from its exact segment.
    rounding: f64,
    /// The planes' margin: the rounding, and that of the ray's range.
    margin: f64,
}

impl Hull {
    /// The hull from `apex` over the parallelogram `[centre, u, v]`
    /// (half edges), for coordinates up to `scale`; `None` when the apex
    /// lies too near the light's plane to bound the rays by one.
    pub fn new(apex: Vec3, [c, u, v]: [DVec3; 3], scale: f64) -> Option<Self> {
        let apex = apex.as_dvec3();
        let reach = (c - apex).length() + u.length() + v.length();
        let scale = scale
            .max(apex.abs().max_element())
            .max(c.abs().max_element() + reach);
        let rounding = RAY_ERROR * scale;
        let margin = rounding + 1e-5 * reach;
        let mut normal = u.cross(v).normalize();
        let mut height = normal.dot(c - apex);
        if height < 0.0 {
            normal = -normal;
            height = -height;
        }
        if height.is_nan() || height <= 4.0 * margin {
            return None;
        }
        // Grown by twice the margin: the samples, rounded to f32, stay
        // inside by far.
        let (u, v) = (grow(u, 2.0 * margin), grow(v, 2.0 * margin));
        let q = [c - u - v, c + u - v, c + u + v, c - u + v];
        let mut sides = [DVec3::ZERO; 4];
        for i in 0..4 {
            let n = (q[i] - apex).cross(q[(i + 1) % 4] - apex);
            let n = n.normalize();
            if !n.is_finite() {
                return None;
            }
            sides[i] = if n.dot(c - apex) < 0.0 { -n } else { n };
        }
        let (t0, t1) = (SHADOW_T_MIN as f64, 1.0 - SHADOW_T_MIN as f64);
        let corners = std::array::from_fn(|k| {
            let t = if k < 4 { t0 } else { t1 };
            apex + (q[k % 4] - apex) * t
        });
        let mut planes = [(DVec3::ZERO, 0.0); 6];
        for (plane, n) in planes.iter_mut().zip(sides) {
            *plane = (n, margin - n.dot(apex));
        }
        planes[4] = (normal, margin - t0 * height - normal.dot(apex));
        planes[5] = (-normal, margin + t1 * height + normal.dot(apex));
        Some(Self {
            apex,
            sides,
            normal,
            height,
            corners,
            planes,
            rounding,
            margin,
        })
    }

    /// Plane `k` of the grown hull: the sides `0..4`, the slab's near and
    /// far planes `4` and `5`; positive inside.
    #[inline]
    fn side(&self, x: DVec3, k: usize) -> f64 {
        let (n, d) = self.planes[k];
        n.dot(x) + d
    }

    /// The hull's planes as a box test, in `f32` with slack for the
    /// rounding of the test itself, and the bound on its depth key.
    pub fn box_test(&self) -> (FrustumTest, f32) {
        let p = self.apex;
        let mut planes = [(Vec3A::ZERO, 0.0f32); 5];
        for (plane, n) in planes.iter_mut().zip(self.sides) {
            *plane = (n.as_vec3a(), (n.dot(p) - self.margin) as f32);
        }
        let t0 = SHADOW_T_MIN as f64;
        planes[4] = (
            self.normal.as_vec3a(),
            (self.normal.dot(p) + t0 * self.height - self.margin) as f32,
        );
        let scale = self
            .corners
            .iter()
            .fold(p.abs().max_element(), |m, c| m.max(c.abs().max_element()));
        let slack = (2.0 * self.margin + 1e-6 * scale) as f32;
        let depth = (self.normal.as_vec3a(), self.normal.dot(p) as f32);
        let bound = (self.height + 2.0 * self.margin + 1e-6 * scale) as f32;
        (FrustumTest::new(&planes, depth, slack), bound)
    }

    /// Whether triangle `t` may meet the grown hull (false only when it
    /// surely does not): outside one of its planes, or its own plane
    /// separating the cut pyramid's corners from it by more than a ray's
    /// rounding (which settles the receiver's own surface and its
    /// coplanar neighbours), or else clipped away.
    fn meets(&self, t: &[DVec3; 3]) -> bool {
        let sides: [[f64; 3]; 6] = std::array::from_fn(|k| t.map(|c| self.side(c, k)));
        if sides.iter().any(|s| s.iter().all(|&v| v < 0.0)) {
            return false;
        }
        if sides.iter().all(|s| s.iter().all(|&v| v >= 0.0)) {
            return true;
        }
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let len = n.length();
        if len > 0.0 {
            let reach = self.rounding * len;
            let d = self.corners.map(|c| n.dot(c - t[0]));
            if d.iter().all(|&d| d > reach) || d.iter().all(|&d| d < -reach) {
                return false;
            }
        }
        self.depths(t, &sides).is_some()
    }

    /// The range of depths along the light's normal of the part of `t`
    /// inside the grown cone (planes `0..4`, whose values at the corners
    /// `sides` holds), and inside the slab too when `sides` has six rows;
    /// `None` when nothing is left.
    fn depths<const K: usize>(&self, t: &[DVec3; 3], sides: &[[f64; 3]; K]) -> Option<(f64, f64)> {
        // A triangle clipped by six planes keeps at most nine corners;
        // rounding may add a few, and past the buffer the piece is taken
        // whole, which holds the clipped part.
        const MAX: usize = 16;
        let mut corners = [DVec3::ZERO; MAX];
        corners[..3].copy_from_slice(t);
        let mut count = 3;
        for (k, s) in sides.iter().enumerate() {
            if s.iter().all(|&v| v >= 0.0) {
                continue;
            }
            let mut next = [DVec3::ZERO; MAX];
            let mut n = 0;
            for i in 0..count {
                let (a, b) = (corners[i], corners[(i + 1) % count]);
                let (sa, sb) = (self.side(a, k), self.side(b, k));
                if sa >= 0.0 && n < MAX {
                    next[n] = a;
                    n += 1;
                }
                if (sa >= 0.0) != (sb >= 0.0) && n < MAX {
                    next[n] = a + (b - a) * (sa / (sa - sb));
                    n += 1;
                }
            }
            if n == 0 {
                return None;
            }
            if n == MAX {
                corners[..3].copy_from_slice(t);
                count = 3;
                continue;
            }
            corners = next;
            count = n;
        }
        let h = |x: DVec3| self.normal.dot(x - self.apex);
        Some(
            corners[..count]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(h(x)), hi.max(h(x)))
                }),
        )
    }

    /// Whether segment `[a, b]` may meet the grown cone (no slab).
    fn segment_meets_cone(&self, [a, b]: [DVec3; 2]) -> bool {
        let (mut s0, mut s1) = (0.0f64, 1.0f64);
        for k in 0..4 {
            let (sa, sb) = (self.side(a, k), self.side(b, k));
            if sa < 0.0 && sb < 0.0 {
                return false;
            }
            if sa < 0.0 {
                s0 = s0.max(sa / (sa - sb));
            } else if sb < 0.0 {
                s1 = s1.min(sa / (sa - sb));
            }
        }
        s0 <= s1
    }

    /// Whether the depths `(lo, hi)` lie strictly inside the slab shrunk
    /// by the margin.
    fn inside_slab(&self, (lo, hi): (f64, f64)) -> bool {
        let (t0, t1) = (SHADOW_T_MIN as f64, 1.0 - SHADOW_T_MIN as f64);
        lo > t0 * self.height + self.margin && hi < t1 * self.height - self.margin
    }

    /// The candidates among `pool` into `out`; false when there are more
    /// than [`MAX_CANDIDATES`].
    pub fn candidates(
        &self,
        pool: &Pool,
        occluders: &Occluders,
        topology: &Topology,
        out: &mut Vec<Candidate>,
    ) -> bool {
        out.clear();
        // Most of the pool lies wholly outside one of the hull's planes:
        // their boxes say so for a few f32 operations.
        let (test, bound) = self.box_test();
        for (&(object, slot), b) in pool.triangles.iter().zip(&pool.boxes) {
            if test.test(b, bound).is_none() {
                continue;
            }
            let t = &occluders.objects[object as usize].tris[slot as usize];
            if !self.meets(t) {
                continue;
            }
            if out.len() == MAX_CANDIDATES {
                return false;
            }
            out.push(Candidate {
                part: topology.objects[object as usize].part[slot as usize],
                facing: self.facing(t),
                object,
                slot,
            });
        }
        true
    }

    fn facing(&self, t: &[DVec3; 3]) -> i8 {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let d = n.dot(self.apex - t[0]);
        let reach = self.margin * n.length();
        if d > reach {
            1
        } else if d < -reach {
            -1
        } else {
            0
        }
    }

    /// What the candidates (all of them, from [`Self::candidates`]) prove.
    pub fn prove(
        &self,
        candidates: &mut [Candidate],
        occluders: &Occluders,
        topology: &Topology,
    ) -> Cover {
        if candidates.is_empty() {
            return Cover::Lit;
        }
        candidates.sort_unstable_by_key(|c| (c.part, c.facing, c.slot));
        let covered = candidates
            .chunk_by(|a, b| (a.part, a.facing) == (b.part, b.facing))
            .any(|sheet| sheet[0].facing != 0 && self.covers(sheet, occluders, topology));
        if covered {
            Cover::Umbra
        } else {
            Cover::Unknown
        }
    }

    /// Whether `sheet` (one part's candidates facing one way, sorted by
    /// slot) is a cover.
    fn covers(&self, sheet: &[Candidate], occluders: &Occluders, topology: &Topology) -> bool {
        let object = sheet[0].object as usize;
        let tris = &occluders.objects[object].tris;
        let topo = &topology.objects[object];
        let in_sheet = |slot: u32| sheet.binary_search_by_key(&slot, |c| c.slot).is_ok();
        let mut seen = false;
        for c in sheet {
            let t = &tris[c.slot as usize];
            let sides: [[f64; 3]; 4] = std::array::from_fn(|k| t.map(|c| self.side(c, k)));
            if let Some(piece) = self.depths(t, &sides) {
                if !self.inside_slab(piece) {
                    return false;
                }
                seen = true;
            }
            for &e in &topo.edges_of[c.slot as usize] {
                if e == NONE {
                    return false;
                }
                let edge = &topo.edges[e as usize];
                let across = if edge.tris[0] == c.slot {
                    edge.tris[1]
                } else {
                    edge.tris[0]
                };
                if (across == NONE || !in_sheet(across)) && self.segment_meets_cone(edge.ends) {
                    return false;
                }
            }
        }
        seen
    }
}

/// Triangles a group of hulls may meet: object and slot, and their boxes
/// in `f32` (rounded to nearest: the box tests' slack covers that).
#[derive(Default)]
pub(super) struct Pool {
    triangles: Vec<(u32, u32)>,
    boxes: Vec<Aabb>,
}

/// Planes bounding a group of hulls (neighbouring pixels): the first
/// hull's side and near planes moved out to hold every hull's corners, and
/// a bound on depth along its light normal. One walk with them finds
/// every triangle any of the hulls may meet.
pub(super) struct Bounds {
    normals: [DVec3; 5],
    /// `normals[k] · x >= lo[k]` holds over the group.
    lo: [f64; 5],
    /// `normals[4] · x <= far` too.
    far: f64,
    scale: f64,
}

impl Bounds {
    pub fn of<'h>(mut hulls: impl Iterator<Item = &'h Hull>) -> Option<Self> {
        let first = hulls.next()?;
        let normals = [
            first.sides[0],
            first.sides[1],
            first.sides[2],
            first.sides[3],
            first.normal,
        ];
        let mut lo = [f64::INFINITY; 5];
        let mut far = f64::NEG_INFINITY;
        let mut scale = 0.0f64;
        for h in std::iter::once(first).chain(hulls) {
            let grow = 3.0 * h.margin;
            for c in h.corners.iter().chain([&h.apex]) {
                for k in 0..5 {
                    lo[k] = lo[k].min(normals[k].dot(*c) - grow);
                }
                far = far.max(normals[4].dot(*c) + grow);
                scale = scale.max(c.abs().max_element());
            }
        }
        Some(Self {
            normals,
            lo,
            far,
            scale,
        })
    }

    /// Whether triangle `t` lies wholly outside one of the planes.
    fn excludes(&self, t: &[DVec3; 3]) -> bool {
        (0..5).any(|k| t.iter().all(|c| self.normals[k].dot(*c) < self.lo[k]))
            || t.iter().all(|c| self.normals[4].dot(*c) > self.far)
    }

    /// The triangles of `world` that may lie inside, into `out`; false
    /// when there are more than `limit`.
    pub fn triangles(
        &self,
        world: &SceneBvh,
        occluders: &Occluders,
        out: &mut Pool,
        limit: usize,
    ) -> bool {
        out.triangles.clear();
        out.boxes.clear();
        // In f32, with slack for the rounding of the test itself.
        let slack = (1e-6 * self.scale) as f32;
        let planes: [(Vec3A, f32); 5] =
            std::array::from_fn(|k| (self.normals[k].as_vec3a(), self.lo[k] as f32));
        let depth = (self.normals[4].as_vec3a(), self.lo[4] as f32);
        let bound = (self.far - self.lo[4] + 1e-6 * self.scale) as f32;
        let test = FrustumTest::new(&planes, depth, slack);
        let mut full = false;
        world.walk_objects(&test, bound, |object, inst, bound| {
            let local = if inst.is_identity() {
                test
            } else {
                test.in_frame(inst.to_object())
            };
            let tris = &occluders.objects[object as usize].tris;
            inst.bvh().wide().walk(&local, *bound, |first, count, _| {
                for slot in first..first + count {
                    let t = &tris[slot as usize];
                    if self.excludes(t) {
                        continue;
                    }
                    if out.triangles.len() == limit {
                        full = true;
                        return Flow::Break(());
                    }
                    out.triangles.push((object, slot));
                    let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                    out.boxes.push(Aabb::new(lo.as_vec3a(), hi.as_vec3a()));
                }
                Flow::Continue(())
            });
            if full {
                Flow::Break(())
            } else {
                Flow::Continue(())
            }
        });
        !full
    }
}

/// Whether `ray` meets one of `candidates` (grouped by object), by the
/// test and in the frames [`SceneBvh::any_hit`] uses: its answer when the
/// candidates hold every triangle the ray may meet, as a hull's complete
/// list does for a ray inside it (the tree's boxes only skip triangles
/// the test would miss).
pub(super) fn any_hit_among(world: &SceneBvh, candidates: &[Candidate], ray: &Ray) -> bool {
    if !ray.is_valid() {
        return false;
    }
    let mut current = None;
    for c in candidates {
        let object = c.object as usize;
        let inst = &world.instances()[object];
        if current.as_ref().is_none_or(|(o, _)| *o != object) {
            let local = local(inst, ray, ray.t_max);
            current = Some((
                object,
                local
                    .is_valid()
                    .then(|| (WatertightRay::new(&local), local)),
            ));
        }
        let Some((_, Some((test, local)))) = &current else {
            continue;
        };
        let [a, b, t] = inst.bvh().leaf_triangles()[c.slot as usize];
        if test.intersect(a, b, t, local.t_min, local.t_max).is_some() {
            return true;
        }
    }
    false
}

/// `v` longer by `by`.
fn grow(v: DVec3, by: f64) -> DVec3 {
    v * (1.0 + by / v.length())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hull from `(x, 0, 0)` to the square of half side 0.5 at height
    /// 3 above it.
    fn hull(x: f32) -> Hull {
        let frame = [
            DVec3::new(x as f64, 0.0, 3.0),
            DVec3::X * 0.5,
            DVec3::Y * 0.5,
        ];
        Hull::new(Vec3::new(x, 0.0, 0.0), frame, x.abs() as f64).unwrap()
    }

    /// A wall in the plane `x = at` across `y` in [-1, 1], `z` in [1.4, 1.6]:
    /// outside the hull's side `x - apex = z / 6` (0.25 at z = 1.5) when
    /// `at` exceeds it.
    fn wall(at: f64) -> [DVec3; 3] {
        [
            DVec3::new(at, -1.0, 1.4),
            DVec3::new(at, 1.0, 1.4),
            DVec3::new(at, 0.0, 1.6),
        ]
    }

    #[test]
    fn triangles_within_the_rays_rounding_meet_the_hull() {
        // Near the origin a millimetre outside is outside.
        let h = hull(0.0);
        assert!(h.meets(&wall(0.26)));
        assert!(!h.meets(&wall(0.268)));
        // 30 km away, f32 rays stray by millimetres: a wall a centimetre
        // outside may be hit, one a metre outside may not.
        let x = 3e4;
        let h = hull(x as f32);
        assert!(h.meets(&wall(x + 0.277)));
        assert!(!h.meets(&wall(x + 1.3)));
    }

    #[test]
    fn a_triangle_through_the_apex_faces_neither_way() {
        let h = hull(0.0);
        let through = [
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(1.0, -1.0, 1e-12),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        assert_eq!(h.facing(&through), 0);
        let above = through.map(|c| c + DVec3::Z * 0.1);
        // Wound counter-clockwise seen from above: the apex is behind it.
        assert_eq!(h.facing(&above), -1);
        assert_eq!(h.facing(&[above[0], above[2], above[1]]), 1);
    }
}
