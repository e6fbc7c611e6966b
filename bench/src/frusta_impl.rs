//! The only place that touches the engine's BVH API (`frusta_engine::bvh`),
//! so that API changes land in one file.

use frusta_engine::bvh::{BuildOptions, MeshBvh};
use frusta_engine::geometry::{Ray, TriangleMesh};

pub type Bvh = MeshBvh;

/// Builds with the default options (SAH).
pub fn build(mesh: &TriangleMesh) -> Bvh {
    MeshBvh::build(mesh, &BuildOptions::default())
}

#[inline]
pub fn closest_t(bvh: &Bvh, ray: &Ray) -> Option<f32> {
    bvh.closest_hit(ray).map(|h| h.t)
}

#[inline]
pub fn any_hit(bvh: &Bvh, ray: &Ray) -> bool {
    bvh.any_hit(ray)
}

/// Refits to the mesh's new positions; returns the reported degradation.
pub fn refit(bvh: &mut Bvh, mesh: &TriangleMesh) -> f32 {
    bvh.refit(mesh).degradation
}

pub fn sah_cost(bvh: &Bvh) -> f32 {
    bvh.sah_cost()
}

pub fn memory_bytes(bvh: &Bvh) -> usize {
    bvh.memory_bytes()
}
