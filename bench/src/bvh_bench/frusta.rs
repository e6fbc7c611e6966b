//! Ours: `frusta_engine::bvh::MeshBvh` (`frusta`) and its compact layout
//! `CompactBvh` (`frusta-compact`), both from the default (SAH) build.

use frusta_engine::bvh::{BuildOptions, CompactBvh, MeshBvh};
use frusta_engine::geometry::{Ray, TriangleMesh};
use glam::Vec3;

use super::Accel;
use crate::mesh::BenchMesh;

enum Layout {
    Plain(MeshBvh),
    Compact(CompactBvh),
}

/// Ours in the plain layout, or with `COMPACT` the compact one (a branch
/// per ray that the predictor never misses).
pub struct Frusta<const COMPACT: bool> {
    bvh: Layout,
}

impl<const COMPACT: bool> Accel for Frusta<COMPACT> {
    const NAME: &'static str = if COMPACT { "frusta-compact" } else { "frusta" };
    const NOTE: &'static str = if COMPACT {
        "the frusta build re-encoded: 8-bit child boxes in 64-byte 4-wide nodes and (rays, on CPUs with AVX) 96-byte 8-wide ones, 16-bit corners into welded vertices; refit: vertices and leaf boxes on rayon, inner boxes in one serial sweep per tree, nodes re-encoded on rayon"
    } else {
        "binned SAH on rayon, collapsed to 4-wide and (rays, on CPUs with AVX) 8-wide; refit: leaves of both trees on rayon, inner nodes in one serial sweep each"
    };
    type Prepared = TriangleMesh;
    type Ray = Ray;
    type RefitInput = TriangleMesh;

    fn prepare(mesh: &BenchMesh) -> TriangleMesh {
        mesh.mesh.clone()
    }

    fn build(mesh: TriangleMesh) -> Self {
        let options = BuildOptions::default();
        let bvh = if COMPACT {
            Layout::Compact(CompactBvh::build(&mesh, &options))
        } else {
            Layout::Plain(MeshBvh::build(&mesh, &options))
        };
        Self { bvh }
    }

    fn ray(&self, ray: &Ray) -> Ray {
        *ray
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<f32> {
        let hit = match &self.bvh {
            Layout::Plain(b) => b.closest_hit(ray),
            Layout::Compact(b) => b.closest_hit(ray),
        };
        hit.map(|h| h.t)
    }

    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        match &self.bvh {
            Layout::Plain(b) => b.any_hit(ray),
            Layout::Compact(b) => b.any_hit(ray),
        }
    }

    fn prepare_refit(&self, mesh: &BenchMesh, positions: &[Vec3]) -> Option<TriangleMesh> {
        let mut m = mesh.mesh.clone();
        m.set_positions(positions.to_vec()).ok()?;
        Some(m)
    }

    fn refit(&mut self, mesh: &TriangleMesh) {
        let report = match &mut self.bvh {
            Layout::Plain(b) => b.refit(mesh),
            Layout::Compact(b) => b.refit(mesh),
        };
        std::hint::black_box(report.ok());
    }

    /// The engine's own `sah_cost()`: the same formula (`C_t = C_i = 1`,
    /// normalised by the root's area), on the boxes as traced (decoded, in
    /// the compact layout).
    fn sah_cost(&self) -> Option<f64> {
        let cost = match &self.bvh {
            Layout::Plain(b) => b.sah_cost(),
            Layout::Compact(b) => b.sah_cost(),
        };
        Some(cost as f64)
    }

    /// The engine's own `memory_bytes()`: everything a query reads (nodes,
    /// slot order, triangle copies or vertices and corners).
    fn memory_bytes(&self) -> usize {
        match &self.bvh {
            Layout::Plain(b) => b.memory_bytes(),
            Layout::Compact(b) => b.memory_bytes(),
        }
    }
}
