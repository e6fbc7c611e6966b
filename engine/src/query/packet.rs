//! Closest hits of a packet: many rays from near one apex through one
//! window (a frustum's sample rays), traced together.
//!
//! One ray at a time, each ray walks the tree from the root; the packet
//! walks it once. Every box is projected into the window
//! ([`WindowTest`]) and reaches only the rays inside its rectangle, and
//! every triangle of a leaf only the rays inside its own; a box is dropped
//! once no ray in its rectangle can meet it before the hit that ray
//! already has (depths grow along each ray, so this is a comparison of
//! depths). The triangle test is the watertight one of single rays, so a
//! ray's hit is the one [`SceneBvh::closest_hit`] finds, up to which of
//! two triangles at exactly the same distance is reported.

use glam::{DMat3, DVec3};

use super::ray::local;
use super::SceneHit;
use crate::bvh::traverse::{Flow, Projection, WindowRect, WindowTest, WindowVisitor};
use crate::bvh::SceneBvh;
use crate::geometry::{Ray, TriangleHit, WatertightRay};

/// One ray of a packet and its progress.
#[derive(Clone, Copy, Debug)]
struct PacketRay {
    ray: Ray,
    u: f32,
    v: f32,
    /// Depth along the ray: `s0 + t ds`.
    s0: f64,
    ds: f64,
    /// The range end, lowered by every hit.
    t_max: f32,
    /// The depths the ray can still meet something at.
    depth: [f32; 2],
    hit: Option<(u32, u32, TriangleHit)>,
}

impl PacketRay {
    /// The depths between `t_min` and `t_max`, widened for the rounding of
    /// hits to `f32`.
    fn update_depth(&mut self) {
        let at = |t: f32| {
            if t.is_finite() {
                self.s0 + f64::from(t) * self.ds
            } else if self.ds == 0.0 {
                self.s0
            } else {
                self.ds.signum() * t as f64
            }
        };
        let (a, b) = (at(self.ray.t_min), at(self.t_max));
        let (lo, hi) = (a.min(b), a.max(b));
        self.depth = [(lo - 1e-5 * lo.abs()) as f32, (hi + 1e-5 * hi.abs()) as f32];
    }
}

/// The bucket of window coordinate `c` on a grid of `grid` per side; NaN
/// and points outside the window go to the edge buckets.
#[inline]
fn cell(grid: usize, c: f32) -> usize {
    ((c * grid as f32).floor().max(0.0) as usize).min(grid - 1)
}

/// Rays bucketed on a square grid over the window, so that the rays in a
/// rectangle are found without scanning them all.
#[derive(Clone, Debug, Default)]
struct Buckets {
    grid: usize,
    /// Ray indices with their window points, bucket by bucket.
    order: Vec<(u32, f32, f32)>,
    /// Where each bucket starts in `order`, and one past the last.
    start: Vec<u32>,
    /// Fill cursors.
    next: Vec<u32>,
}

impl Buckets {
    fn cell(&self, c: f32) -> usize {
        cell(self.grid, c)
    }

    fn fill(&mut self, rays: &[PacketRay], valid: impl Fn(&PacketRay) -> bool) {
        self.grid = ((rays.len() as f64).sqrt() / 1.5).ceil().max(1.0) as usize;
        let g = self.grid;
        let bucket = |r: &PacketRay| cell(g, r.u) * g + cell(g, r.v);
        self.start.clear();
        self.start.resize(g * g + 1, 0);
        for r in rays.iter().filter(|r| valid(r)) {
            self.start[bucket(r) + 1] += 1;
        }
        for b in 0..g * g {
            self.start[b + 1] += self.start[b];
        }
        self.next.clear();
        self.next.extend_from_slice(&self.start);
        self.order.clear();
        self.order.resize(self.start[g * g] as usize, (0, 0.0, 0.0));
        for (i, r) in rays.iter().enumerate().filter(|(_, r)| valid(r)) {
            let b = bucket(r);
            self.order[self.next[b] as usize] = (i as u32, r.u, r.v);
            self.next[b] += 1;
        }
    }

    /// Indices of the rays inside `rect`.
    fn within<'a>(&'a self, rect: &'a WindowRect) -> impl Iterator<Item = usize> + 'a {
        let (i0, i1) = (self.cell(rect.u[0]), self.cell(rect.u[1]));
        let (j0, j1) = (self.cell(rect.v[0]), self.cell(rect.v[1]));
        (i0..=i1)
            .flat_map(move |i| {
                let (a, b) = (i * self.grid + j0, i * self.grid + j1 + 1);
                &self.order[self.start[a] as usize..self.start[b] as usize]
            })
            .filter(move |&&(_, u, v)| rect.contains(u, v))
            .map(|&(r, _, _)| r as usize)
    }
}

/// A packet of rays and the state its queries reuse, so that tracing one
/// allocates nothing once the buffers have grown.
#[derive(Clone, Debug, Default)]
pub struct RayPacket {
    rays: Vec<PacketRay>,
    buckets: Buckets,
    /// Each ray in the frame of the object being walked.
    local: Vec<WatertightRay>,
    hits: Vec<Option<SceneHit>>,
}

impl RayPacket {
    pub fn clear(&mut self) {
        self.rays.clear();
    }

    /// Adds the ray through window point `(u, v)`; `None` (a sample point
    /// with no ray) or an invalid ray meets nothing.
    pub fn push(&mut self, ray: Option<Ray>, u: f32, v: f32) {
        let ray = ray
            .filter(Ray::is_valid)
            .unwrap_or(Ray::new(glam::Vec3::ZERO, glam::Vec3::ZERO));
        self.rays.push(PacketRay {
            ray,
            u,
            v,
            s0: 0.0,
            ds: 0.0,
            t_max: ray.t_max,
            depth: [0.0; 2],
            hit: None,
        });
    }

    pub fn len(&self) -> usize {
        self.rays.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }

    /// The nearest hit of every ray pushed, in push order, among the
    /// triangles `accept(object, triangle)` takes. The rays must run from
    /// (near) `apex` through the window points they were pushed with, where
    /// window coordinates are `(x, y, s) = to_window (p - apex)`,
    /// `(u, v) = (x / s, y / s)`; to within what single precision costs a
    /// ray built from them. A ray that does not is still answered, more
    /// slowly, and its hit may be missed.
    pub fn closest_hits(
        &mut self,
        bvh: &SceneBvh,
        apex: DVec3,
        to_window: DMat3,
        mut accept: impl FnMut(u32, u32) -> bool,
    ) -> &[Option<SceneHit>] {
        let m_s = to_window.row(2);
        for r in &mut self.rays {
            r.s0 = m_s.dot(r.ray.origin.as_dvec3() - apex);
            r.ds = m_s.dot(r.ray.dir.as_dvec3());
            r.t_max = r.ray.t_max;
            r.hit = None;
            r.update_depth();
        }
        self.buckets.fill(&self.rays, |r| r.ray.is_valid());
        let bounds = bvh.bounds();
        let reach = bounds.min.abs().max(bounds.max.abs()).max_element();
        // Well above the rays' own rounding and that of the projection (a
        // few ulps of the distances involved).
        let slack = 1e-5 * (2.0 * reach + apex.abs().max_element() as f32);
        let world = WindowTest::new(apex, to_window, slack);
        let Self {
            rays,
            buckets,
            local: local_rays,
            hits,
        } = self;
        local_rays.resize(
            rays.len(),
            WatertightRay::new(&Ray::new(glam::Vec3::ZERO, glam::Vec3::X)),
        );
        bvh.walk_objects(&world, f32::INFINITY, |object, inst, _| {
            let test = if inst.is_identity() {
                world
            } else {
                world.in_frame(inst.to_world(), inst.to_object())
            };
            let Some(p) = test.project_box(&inst.bvh().bounds()) else {
                return Flow::Continue(());
            };
            for i in buckets.within(&p.rect) {
                let r = &rays[i];
                local_rays[i] = WatertightRay::new(&local(inst, &r.ray, r.t_max));
            }
            let mut visitor = Visitor {
                object,
                test: &test,
                triangles: inst.bvh().leaf_triangles(),
                prim_ids: inst.bvh().prim_ids(),
                rays,
                buckets,
                local: local_rays,
                accept: &mut accept,
            };
            inst.bvh().wide().walk_window(&test, p.rect, &mut visitor);
            Flow::Continue(())
        });
        hits.clear();
        hits.extend(rays.iter().map(|r| {
            r.hit.map(|(object, slot, h)| {
                let inst = &bvh.instances()[object as usize];
                bvh.scene_hit(&r.ray, object, inst.bvh().mesh_hit(slot, h))
            })
        }));
        hits
    }
}

/// The packet walking one object's tree.
struct Visitor<'a, A> {
    object: u32,
    test: &'a WindowTest,
    triangles: &'a [[glam::Vec3A; 3]],
    prim_ids: &'a [u32],
    rays: &'a mut [PacketRay],
    buckets: &'a Buckets,
    local: &'a [WatertightRay],
    accept: &'a mut A,
}

/// Whether depth ranges overlap.
#[inline]
fn overlaps(a: [f32; 2], b: [f32; 2]) -> bool {
    a[0] <= b[1] && b[0] <= a[1]
}

impl<A: FnMut(u32, u32) -> bool> WindowVisitor for Visitor<'_, A> {
    fn keep(&mut self, p: &Projection) -> bool {
        self.buckets
            .within(&p.rect)
            .any(|i| overlaps(self.rays[i].depth, p.depth))
    }

    fn leaf(&mut self, first: u32, count: u32, rect: &WindowRect) -> Flow {
        for slot in first..first + count {
            let [a, b, c] = self.triangles[slot as usize];
            let Some(p) = self.test.project_triangle(a, b, c) else {
                continue;
            };
            let within = p.rect.intersect(rect);
            if within.is_empty() {
                continue;
            }
            for i in self.buckets.within(&within) {
                let r = &mut self.rays[i];
                if !overlaps(r.depth, p.depth) {
                    continue;
                }
                let Some(h) = self.local[i].intersect(a, b, c, r.ray.t_min, r.t_max) else {
                    continue;
                };
                if (self.accept)(self.object, self.prim_ids[slot as usize]) {
                    r.t_max = h.t;
                    r.hit = Some((self.object, slot, h));
                    r.update_depth();
                }
            }
        }
        Flow::Continue(())
    }
}

#[cfg(test)]
mod tests {
    use glam::{Quat, Vec3, Vec3A};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::bvh::BuildOptions;
    use crate::geometry::{shapes, RigidTransform, TriangleMesh};
    use crate::scene::{Scene, SceneObject};

    fn object(name: &str, mesh: TriangleMesh, transform: RigidTransform) -> SceneObject {
        SceneObject {
            name: name.into(),
            materials: vec![0; mesh.triangle_count()],
            mesh,
            transform,
            dynamic: false,
        }
    }

    /// A finely tessellated cube (closed: rays through its shared edges and
    /// vertices), a rotated and moved sphere and a torus inside it.
    fn scene() -> SceneBvh {
        let moved = RigidTransform::new(
            Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1),
            Vec3::new(0.3, -0.2, 0.1),
        )
        .unwrap();
        let scene = Scene {
            materials: Vec::new(),
            objects: vec![
                object("cube", shapes::cube(1.0, 8), RigidTransform::IDENTITY),
                object("sphere", shapes::icosphere(0.3, 3), moved),
                object(
                    "torus",
                    shapes::torus(0.5, 0.1, 24, 12),
                    RigidTransform::IDENTITY,
                ),
            ],
        };
        SceneBvh::build(&scene, &BuildOptions::default())
    }

    /// The nearest accepted hit of `ray` over every triangle of every
    /// object: no tree, no culling.
    fn brute_force(
        bvh: &SceneBvh,
        ray: &Ray,
        accept: impl Fn(u32, u32) -> bool,
    ) -> Option<(u32, u32, f32)> {
        let mut best: Option<(u32, u32, f32)> = None;
        for (o, inst) in bvh.instances().iter().enumerate() {
            let local = local(inst, ray, ray.t_max);
            let test = WatertightRay::new(&local);
            let mesh = inst.bvh();
            for (slot, [a, b, c]) in mesh.leaf_triangles().iter().enumerate() {
                let triangle = mesh.prim_ids()[slot];
                let t_max = best.map_or(ray.t_max, |b| b.2);
                if let Some(h) = test.intersect(*a, *b, *c, ray.t_min, t_max) {
                    if accept(o as u32, triangle) && best.is_none_or(|b| h.t < b.2) {
                        best = Some((o as u32, triangle, h.t));
                    }
                }
            }
        }
        best
    }

    /// Traces `n x n` window points and the cell centres of the window
    /// `corner + u eu + v ev` from `apex` (from where each ray crosses the
    /// plane `near`, if given) as one packet, and checks every ray against
    /// brute force. Returns how many rays hit.
    fn check(
        bvh: &SceneBvh,
        apex: DVec3,
        [corner, eu, ev]: [DVec3; 3],
        near: Option<(DVec3, f64)>,
        n: usize,
        accept: impl Fn(u32, u32) -> bool + Copy,
    ) -> usize {
        let to_window = DMat3::from_cols(eu, ev, corner).inverse();
        let mut packet = RayPacket::default();
        let mut rays = Vec::new();
        for k in 0..(n + 1) * (n + 1) + n * n {
            let (u, v) = if k < (n + 1) * (n + 1) {
                (
                    (k / (n + 1)) as f64 / n as f64,
                    (k % (n + 1)) as f64 / n as f64,
                )
            } else {
                let c = k - (n + 1) * (n + 1);
                (
                    ((c / n) as f64 + 0.5) / n as f64,
                    ((c % n) as f64 + 0.5) / n as f64,
                )
            };
            let d = corner + eu * u + ev * v;
            let origin = match near {
                None => Some(apex),
                Some((normal, offset)) => {
                    let t = (offset - normal.dot(apex)) / normal.dot(d);
                    (t.is_finite() && t > 0.0).then(|| apex + d * t)
                }
            };
            let ray = origin.map(|o| Ray::new(o.as_vec3(), d.as_vec3()));
            rays.push(ray);
            packet.push(ray, u as f32, v as f32);
        }
        let hits = packet.closest_hits(bvh, apex, to_window, accept).to_vec();
        let mut hit_count = 0;
        for (k, (ray, hit)) in rays.iter().zip(&hits).enumerate() {
            let expected = ray.and_then(|r| brute_force(bvh, &r, accept));
            let got = hit.map(|h| (h.object, h.triangle, h.t));
            match (expected, got) {
                (None, None) => {}
                // Two triangles at exactly the same distance: either.
                (Some(e), Some(g)) if e == g || e.2 == g.2 => hit_count += 1,
                _ => panic!("ray {k} of {apex} n {n}: expected {expected:?}, got {got:?}"),
            }
        }
        hit_count
    }

    #[test]
    fn rays_through_the_cube_grids_edges_and_vertices_match_brute_force() {
        let bvh = scene();
        // From (0, 0, -4) the window points at u, v = i / 8 lie on the
        // lines x, y = 0.25 k of the face z = 1: every ray runs through an
        // edge or a vertex of the cube's tessellation there.
        let window = [
            DVec3::new(-1.25, -1.25, 5.0),
            DVec3::X * 2.5,
            DVec3::Y * 2.5,
        ];
        let near = Some((DVec3::Z, -1.0));
        let all = |_, _| true;
        let hits = check(&bvh, DVec3::new(0.0, 0.0, -4.0), window, near, 8, all);
        assert_eq!(
            hits,
            81 + 64,
            "every ray meets the cube's far side or what is inside"
        );
        // The same rays from the apex itself: all meet the near face.
        assert_eq!(
            check(&bvh, DVec3::new(0.0, 0.0, -4.0), window, None, 8, all),
            145
        );
    }

    #[test]
    fn random_windows_inside_and_outside_match_brute_force() {
        let bvh = scene();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut v = |r: f64| {
            DVec3::new(
                rng.random_range(-r..r),
                rng.random_range(-r..r),
                rng.random_range(-r..r),
            )
        };
        let mut hits = 0;
        for round in 0..60 {
            let apex = v(if round % 3 == 0 { 3.0 } else { 0.9 });
            let window = [v(1.0), v(0.6), v(0.6)];
            // The sphere's odd triangles and the torus are skipped in one
            // round out of two, as a frustum skips the group it leaves.
            let accept = move |o: u32, t: u32| round % 2 == 0 || (o == 0 || (o == 1 && t % 2 == 0));
            let near = (round % 4 == 1)
                .then(|| (window[0].normalize(), window[0].normalize().dot(apex) + 0.3));
            for n in [1, 3, 8] {
                hits += check(&bvh, apex, window, near, n, accept);
            }
        }
        assert!(hits > 2000, "most rays hit something: {hits}");
    }

    #[test]
    fn invalid_and_missing_rays_hit_nothing() {
        let bvh = scene();
        let mut packet = RayPacket::default();
        packet.push(None, 0.5, 0.5);
        packet.push(
            Some(Ray::new(Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0))),
            0.5,
            0.5,
        );
        packet.push(Some(Ray::new(Vec3::ZERO, Vec3::Z)), 0.5, 0.5);
        let window = DMat3::from_cols(DVec3::X, DVec3::Y, DVec3::new(-0.5, -0.5, 1.0)).inverse();
        let hits = packet.closest_hits(&bvh, DVec3::ZERO, window, |_, _| true);
        assert!(hits[0].is_none() && hits[1].is_none());
        let h = hits[2].expect("the straight-up ray meets the torus or the cube");
        assert!(h.point.z > 0.0 && Vec3A::from(h.point).is_finite());
    }
}
