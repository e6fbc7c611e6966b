use glam::Vec3;

use super::scene_bvh::{Instance, SceneBvh};
use crate::bvh::traverse::RayBoxTest;
use crate::bvh::MeshHit;
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

impl Instance {
    /// The ray in this object's frame; rigid, so `t` is unchanged.
    #[inline]
    fn local(&self, ray: &Ray, t_max: f32) -> Ray {
        if self.identity {
            return Ray { t_max, ..*ray };
        }
        Ray {
            origin: self.to_object.transform_point(ray.origin),
            dir: self.to_object.transform_vector(ray.dir),
            t_min: ray.t_min,
            t_max,
        }
    }
}

impl SceneBvh {
    /// The nearest hit within the ray's range; invalid rays hit nothing.
    pub fn closest_hit(&self, ray: &Ray) -> Option<SceneHit> {
        if !ray.is_valid() {
            return None;
        }
        let mut best: Option<(u32, MeshHit)> = None;
        self.top.traverse(
            &RayBoxTest::new(ray),
            ray.t_min,
            ray.t_max,
            |first, count, t_max| {
                for slot in first..first + count {
                    let object = self.top.prim_ids[slot as usize];
                    let inst = &self.instances[object as usize];
                    if let Some(hit) = inst.bvh.closest_hit(&inst.local(ray, *t_max)) {
                        *t_max = hit.t;
                        best = Some((object, hit));
                    }
                }
                false
            },
        );
        best.map(|(object, hit)| {
            let inst = &self.instances[object as usize];
            SceneHit {
                t: hit.t,
                object,
                triangle: hit.triangle,
                u: hit.u,
                v: hit.v,
                normal: inst.to_world.rotation * hit.normal,
                material: inst
                    .materials
                    .get(hit.triangle as usize)
                    .copied()
                    .unwrap_or(0),
                point: ray.at(hit.t).into(),
            }
        })
    }

    /// Whether anything lies on the ray within its range (occlusion).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        if !ray.is_valid() {
            return false;
        }
        let mut hit = false;
        self.top.traverse(
            &RayBoxTest::new(ray),
            ray.t_min,
            ray.t_max,
            |first, count, t_max| {
                hit = self.top.prim_ids[first as usize..(first + count) as usize]
                    .iter()
                    .any(|&object| {
                        let inst = &self.instances[object as usize];
                        inst.bvh.any_hit(&inst.local(ray, *t_max))
                    });
                hit
            },
        );
        hit
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
