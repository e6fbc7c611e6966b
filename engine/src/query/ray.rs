use glam::Vec3;

use crate::bvh::lod::{self, LodOptions, LodTree};
use crate::bvh::traverse::{Flow, RayTest};
use crate::bvh::{Instance, MeshBvh, MeshHit, SceneBvh};
use crate::geometry::{trace_batch, Ray};
use crate::scene::MaterialId;

/// A ray's nearest hit in a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// Distance along the ray, in units of the ray direction's length.
    pub t: f32,
    /// Index of the object in the scene.
    pub object: u32,
    /// Index of the triangle in the object's mesh.
    pub triangle: u32,
    /// Barycentric weight of the triangle's second corner.
    pub u: f32,
    /// Barycentric weight of the triangle's third corner.
    pub v: f32,
    /// Unit geometric normal in world space (counter-clockwise winding).
    pub normal: Vec3,
    /// The triangle's material.
    pub material: MaterialId,
    /// The hit point in world space.
    pub point: Vec3,
}

/// A ray's nearest triangle in a scene (see [`SceneBvh::closest_triangle`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearestTriangle {
    /// Distance along the ray, in units of the ray direction's length.
    pub t: f32,
    /// Index of the object in the scene.
    pub object: u32,
    /// Index of the triangle in the object's mesh.
    pub triangle: u32,
}

/// The ray in an object's frame with range end `t_max`; rigid, so `t` is
/// unchanged.
#[inline]
pub(crate) fn local(inst: &Instance, ray: &Ray, t_max: f32) -> Ray {
    if inst.is_identity() {
        return Ray { t_max, ..*ray };
    }
    let to_object = inst.to_object();
    Ray {
        origin: to_object.transform_point(ray.origin),
        dir: to_object.transform_vector(ray.dir),
        t_min: ray.t_min,
        t_max,
    }
}

impl SceneBvh {
    /// The nearest hit within the ray's range; invalid rays hit nothing.
    pub fn closest_hit(&self, ray: &Ray) -> Option<SceneHit> {
        self.nearest(ray, MeshBvh::closest_hit, |h| h.t)
            .map(|(object, hit)| self.scene_hit(ray, object, hit))
    }

    /// The nearest hit's distance, object and triangle: [`Self::closest_hit`]
    /// without the point, barycentrics, normal and material, for callers
    /// that keep their own per-triangle data (the stochastic tail reads its
    /// surfaces' planes, which are already in world space).
    pub fn closest_triangle(&self, ray: &Ray) -> Option<NearestTriangle> {
        self.nearest(ray, MeshBvh::closest_triangle, |h| h.0)
            .map(|(object, (t, triangle))| NearestTriangle {
                t,
                object,
                triangle,
            })
    }

    /// The nearest of the objects' hits `hit` finds, `t(hit)` its distance,
    /// with its object.
    #[inline(always)]
    fn nearest<H>(
        &self,
        ray: &Ray,
        hit: impl Fn(&MeshBvh, &Ray) -> Option<H>,
        t: impl Fn(&H) -> f32,
    ) -> Option<(u32, H)> {
        if let [inst] = self.instances() {
            // One object: its own walk tests the boxes the top level would,
            // and rejects the rays the check below would (a rigid motion
            // keeps a ray's non-finite or zero parts so).
            return hit(inst.bvh(), &local(inst, ray, ray.t_max)).map(|h| (0, h));
        }
        if !ray.is_valid() {
            return None;
        }
        let mut best = None;
        self.walk_objects(&RayTest::new(ray), ray.t_max, |object, inst, t_max| {
            if let Some(h) = hit(inst.bvh(), &local(inst, ray, *t_max)) {
                *t_max = t(&h);
                best = Some((object, h));
            }
            Flow::Continue(())
        });
        best
    }

    /// `hit`, found on `object` by `ray`, in world terms.
    pub(super) fn scene_hit(&self, ray: &Ray, object: u32, hit: MeshHit) -> SceneHit {
        let inst = &self.instances()[object as usize];
        SceneHit {
            t: hit.t,
            object,
            triangle: hit.triangle,
            u: hit.u,
            v: hit.v,
            normal: inst.to_world().rotation * hit.normal,
            material: inst
                .materials()
                .get(hit.triangle as usize)
                .copied()
                .unwrap_or(0),
            point: ray.at(hit.t).into(),
        }
    }

    /// Whether anything lies on the ray within its range (occlusion).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        if !ray.is_valid() {
            return false;
        }
        if let [inst] = self.instances() {
            return inst.bvh().any_hit(&local(inst, ray, ray.t_max));
        }
        let mut hit = false;
        self.walk_objects(&RayTest::new(ray), ray.t_max, |_, inst, t_max| {
            hit = inst.bvh().any_hit(&local(inst, ray, *t_max));
            if hit {
                Flow::Break(())
            } else {
                Flow::Continue(())
            }
        });
        hit
    }

    /// Calls `visit(object, triangle, t)` for every triangle the ray
    /// crosses within its range, in no particular order. Where the ray runs
    /// through an edge or vertex shared within one object, exactly one of
    /// the triangles there is reported (the watertight test).
    pub fn for_each_hit(&self, ray: &Ray, mut visit: impl FnMut(u32, u32, f32)) {
        if !ray.is_valid() {
            return;
        }
        self.walk_objects(&RayTest::new(ray), ray.t_max, |object, inst, _| {
            inst.bvh()
                .for_each_hit(&local(inst, ray, ray.t_max), |triangle, t| {
                    visit(object, triangle, t)
                });
            Flow::Continue(())
        });
    }

    /// [`closest_hit`](Self::closest_hit) on levels of detail
    /// ([`crate::bvh::lod`]) where `options` allows them, for many rays in
    /// parallel: each hit with the error of the plane it met (0 on a
    /// triangle). The objects' planes are fitted on first use. Rigid
    /// transforms keep distances, so cones and errors mean the same in
    /// every object's frame.
    pub fn closest_hits_lod(
        &self,
        rays: &[Ray],
        options: &LodOptions,
    ) -> Vec<Option<(SceneHit, f32)>> {
        let some_plane_allowed = options.max_error > 0.0;
        if !some_plane_allowed {
            return trace_batch(rays, |r| self.closest_hit(r).map(|h| (h, 0.0)));
        }
        let lods: Vec<std::sync::Arc<LodTree>> =
            self.instances().iter().map(Instance::lods).collect();
        trace_batch(rays, |ray| {
            if !ray.is_valid() {
                return None;
            }
            let mut best: Option<(u32, lod::LodHit)> = None;
            self.walk_objects(&RayTest::new(ray), ray.t_max, |object, inst, t_max| {
                let local = local(inst, ray, *t_max);
                // The planes were fitted to these very trees above, so the
                // staleness error cannot arise here.
                if let Ok(Some(hit)) =
                    lod::closest_hit(inst.bvh(), &lods[object as usize], &local, options)
                {
                    *t_max = hit.hit.t;
                    best = Some((object, hit));
                }
                Flow::Continue(())
            });
            best.map(|(object, h)| (self.scene_hit(ray, object, h.hit), h.error))
        })
    }

    /// [`closest_hit`](Self::closest_hit) for many rays, in parallel.
    pub fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<SceneHit>> {
        trace_batch(rays, |r| self.closest_hit(r))
    }

    /// [`any_hit`](Self::any_hit) for many rays, in parallel.
    pub fn any_hits(&self, rays: &[Ray]) -> Vec<bool> {
        trace_batch(rays, |r| self.any_hit(r))
    }
}
