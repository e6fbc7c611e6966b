//! Embree 3 (3.13.5, system library) through the `embree3` crate; only with
//! the `embree` feature. Two configurations, since Embree refits only a
//! scene made for it and that scene is not its fastest static one:
//!
//! - `embree`: a static scene (default flags, quality medium), one triangle
//!   geometry (quality medium). No refit: changing a static scene's vertices
//!   means a rebuild, so the refit columns are empty;
//! - `embree-refit`: what Embree documents for refitting: scene flag
//!   `DYNAMIC`, scene quality `LOW` (the two-level mode, the only one in
//!   which a geometry's quality is used) and geometry quality `REFIT`.
//!   The first commit builds the geometry's BVH with SAH; a refit writes the
//!   new vertices into the live vertex buffer, `rtcUpdateGeometryBuffer`,
//!   `rtcCommitGeometry`, `rtcCommitScene`, and Embree refits that BVH in
//!   place (and rebuilds the one-instance top level);
//!
//! In both:
//! - build, timed: creating the geometry, copying vertices and indices into
//!   Embree-owned buffers, committing, attaching and `rtcCommitScene`
//!   (Embree builds on its own TBB pool, sized to rayon's thread count);
//! - closest hit: `Scene::intersect` (`rtcIntersect1`), any hit:
//!   `Scene::occluded` (`rtcOccluded1`), one ray at a time from the same
//!   rayon chunks as every other implementation;
//! - SAH: Embree's BVH is opaque: null;
//! - memory: the net bytes Embree reports through its device memory
//!   monitor while the scene is built (BVH and its triangle copies plus the
//!   vertex and index buffers).

use std::sync::atomic::{AtomicIsize, Ordering};
use std::sync::{Arc, OnceLock};

use embree3::{
    BufferUsage, BuildQuality, Config, Device, Format, GeometryKind, IntersectContext, Ray, RayHit,
    Scene, SceneFlags,
};
use frusta_engine::geometry::Ray as FRay;
use glam::Vec3;

use super::Accel;
use crate::mesh::BenchMesh;

/// One device for the process, with its allocation counter. Its build
/// threads are as many as rayon's, so `--threads` holds for Embree too.
fn device() -> &'static (Device, Arc<AtomicIsize>) {
    static DEVICE: OnceLock<(Device, Arc<AtomicIsize>)> = OnceLock::new();
    DEVICE.get_or_init(|| {
        let config = Config {
            threads: rayon::current_num_threads() as u32,
            ..Config::default()
        };
        let device = Device::with_config(config).expect("embree device (is libembree3 installed?)");
        let bytes = Arc::new(AtomicIsize::new(0));
        let counter = bytes.clone();
        device.set_memory_monitor_function(move |b, post| {
            // Count an allocation once (before it happens), a free once.
            if !post || b < 0 {
                counter.fetch_add(b, Ordering::Relaxed);
            }
            true
        });
        (device, bytes)
    })
}

/// `REFIT`: the scene made for refitting (`embree-refit`), else static.
pub struct Embree<const REFIT: bool> {
    scene: Scene<'static>,
    geom_id: u32,
    bytes: usize,
}

pub struct Prepared {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

impl<const REFIT: bool> Accel for Embree<REFIT> {
    const NAME: &'static str = if REFIT { "embree-refit" } else { "embree" };
    const NOTE: &'static str = if REFIT {
        "DYNAMIC scene, quality LOW (two-level), geometry REFIT; refit: new vertex buffer, rtcCommitGeometry + rtcCommitScene (TBB)"
    } else {
        "static scene, quality medium (TBB); no refit (a static scene is rebuilt)"
    };
    type Prepared = Prepared;
    type Ray = Ray;
    type RefitInput = Vec<[f32; 3]>;

    fn prepare(mesh: &BenchMesh) -> Prepared {
        Prepared {
            positions: mesh.positions().iter().map(|p| p.to_array()).collect(),
            triangles: mesh.triangles().to_vec(),
        }
    }

    fn build(p: Prepared) -> Self {
        let (device, counter) = device();
        let before = counter.load(Ordering::Relaxed);
        let mut geom = device.create_geometry(GeometryKind::TRIANGLE).unwrap();
        geom.set_new_buffer::<[f32; 3]>(
            BufferUsage::VERTEX,
            0,
            Format::FLOAT3,
            12,
            p.positions.len(),
        )
        .unwrap()
        .copy_from_slice(&p.positions);
        geom.set_new_buffer::<[u32; 3]>(
            BufferUsage::INDEX,
            0,
            Format::UINT3,
            12,
            p.triangles.len(),
        )
        .unwrap()
        .copy_from_slice(&p.triangles);
        let mut scene = device.create_scene().unwrap();
        if REFIT {
            geom.set_build_quality(BuildQuality::REFIT);
            scene.set_flags(SceneFlags::DYNAMIC);
            scene.set_build_quality(BuildQuality::LOW);
        }
        let geom = geom.commit();
        let geom_id = scene.attach_geometry(&geom);
        scene.commit();
        let bytes = (counter.load(Ordering::Relaxed) - before).max(0) as usize;
        Self {
            scene,
            geom_id,
            bytes,
        }
    }

    fn ray(&self, r: &FRay) -> Ray {
        Ray::segment(r.origin.to_array(), r.dir.to_array(), r.t_min, r.t_max)
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<f32> {
        let mut ctx = IntersectContext::coherent();
        let mut hit = RayHit::from(*ray);
        self.scene.intersect(&mut ctx, &mut hit);
        hit.hit.is_valid().then_some(hit.ray.tfar)
    }

    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        let mut ctx = IntersectContext::coherent();
        let mut r = *ray;
        self.scene.occluded(&mut ctx, &mut r)
    }

    fn prepare_refit(&self, _: &BenchMesh, positions: &[Vec3]) -> Option<Vec<[f32; 3]>> {
        REFIT.then(|| positions.iter().map(|p| p.to_array()).collect())
    }

    fn refit(&mut self, positions: &Vec<[f32; 3]>) {
        let id = self.geom_id;
        self.scene
            .with_geometry_buffer_mut::<[f32; 3], _>(id, BufferUsage::VERTEX, 0, |v| {
                v.copy_from_slice(positions)
            })
            .expect("embree vertex buffer");
        self.scene
            .update_geometry_buffer(id, BufferUsage::VERTEX, 0);
        self.scene.commit_geometry(id);
        self.scene.commit();
    }

    fn sah_cost(&self) -> Option<f64> {
        None
    }

    fn memory_bytes(&self) -> usize {
        self.bytes
    }
}
