//! The compact layout of a mesh's hierarchy (the ReduceM idea of the
//! dissertation, chapter 3, on today's wide trees): 64-byte nodes with
//! child boxes on an 8-bit grid ([`node`]), 96-byte 8-wide nodes on the
//! same grid that rays walk where the CPU has AVX ([`eight`]), and
//! triangles as 16-bit offsets
//! into shared vertices ([`geometry`]), about a third of the plain
//! layout's bytes per triangle.
//!
//! The topology is the plain tree's (same build, same leaves), so the same
//! rays visit leaves in nearly the same order and the watertight test sees
//! the same corners bit for bit: hits are the plain layout's. Boxes decode
//! a little larger (within a grid step), so a ray may test a few more
//! leaves. Refit keeps the topology: vertices are copied again from the
//! mesh and every box re-encoded from the exact boxes bottom-up.
//!
//! ```
//! use frusta_engine::bvh::{BuildOptions, CompactBvh, MeshBvh};
//! use frusta_engine::geometry::{shapes, Ray};
//! use glam::Vec3;
//!
//! let mesh = shapes::icosphere(1.0, 4);
//! let compact = CompactBvh::build(&mesh, &BuildOptions::default());
//! let plain = MeshBvh::build(&mesh, &BuildOptions::default());
//! let ray = Ray::new(Vec3::new(0.1, 0.2, -5.0), Vec3::Z);
//! assert_eq!(compact.closest_hit(&ray), plain.closest_hit(&ray));
//! assert!(compact.memory_bytes() * 3 < plain.memory_bytes());
//! ```

pub mod eight;
pub mod geometry;
pub mod node;
pub mod tree;

use glam::Vec3A;

use super::mesh_bvh::{leaf_box_and_area, wide_tree};
use super::ray_queries::{self, LeafTriangles, Tree8};
use super::{BuildOptions, MeshHit, RefitReport};
use crate::geometry::{Aabb, Ray, TriangleMesh};
use crate::{Error, Result};
pub use eight::{CompactBvh8, CompactNode8};
pub use geometry::SharedCorners;
pub use node::CompactNode4;
pub use tree::CompactBvh4;

/// A compact hierarchy over one triangle mesh.
#[derive(Clone, Debug)]
pub struct CompactBvh {
    tree: CompactBvh4,
    /// The tree rays walk where the CPU has AVX, over the same triangles.
    tree8: Option<CompactBvh8>,
    /// Slot order to mesh order: slot `i` holds triangle `prim_ids[i]`.
    prim_ids: Vec<u32>,
    triangles: SharedCorners,
    options: BuildOptions,
}

impl CompactBvh {
    /// Builds the hierarchy of `mesh` (leaves of at most
    /// [`node::MAX_LEAF`] triangles).
    pub fn build(mesh: &TriangleMesh, options: &BuildOptions) -> Self {
        let options = BuildOptions {
            max_leaf_size: options.max_leaf_size.min(node::MAX_LEAF),
            ..options.clone()
        };
        let (plain, plain8, plain_ids) = wide_tree(mesh, &options);
        let (tree, order) = CompactBvh4::from_plain(&plain);
        let prim_ids: Vec<u32> = order.iter().map(|&s| plain_ids[s as usize]).collect();
        let triangles = SharedCorners::new(mesh, &prim_ids);
        let mut bvh = Self {
            tree,
            tree8: None,
            prim_ids,
            triangles,
            options,
        };
        let mut tree = std::mem::take(&mut bvh.tree);
        let (bounds, areas) = bvh.leaf_measures();
        let boxes = tree.record_build_ratios(bounds, areas);
        bvh.tree8 = plain8.and_then(|plain8| {
            let mut compact_slot = vec![0; order.len()];
            for (i, &s) in order.iter().enumerate() {
                compact_slot[s as usize] = i as u32;
            }
            CompactBvh8::from_plain(&plain8, &compact_slot, &tree, &boxes)
        });
        bvh.tree = tree;
        bvh
    }

    /// A leaf's exact box and its triangles' box areas, from slot ranges.
    fn leaf_measures(
        &self,
    ) -> (
        impl Fn(u32, u32) -> Aabb + Sync + '_,
        impl Fn(u32, u32) -> f32 + '_,
    ) {
        let corners = |s: u32| self.triangles.corners(s as usize);
        let bounds = move |first, count| leaf_box_and_area(corners, first, count).0;
        let areas = move |first, count| leaf_box_and_area(corners, first, count).1;
        (bounds, areas)
    }

    pub fn tree(&self) -> &CompactBvh4 {
        &self.tree
    }

    /// The 8-wide tree rays walk, where there is one (see [`eight`]).
    pub fn eight(&self) -> Option<&CompactBvh8> {
        self.tree8.as_ref()
    }

    /// Slot order to mesh order.
    pub fn prim_ids(&self) -> &[u32] {
        &self.prim_ids
    }

    pub fn options(&self) -> &BuildOptions {
        &self.options
    }

    pub fn triangle_count(&self) -> usize {
        self.prim_ids.len()
    }

    /// Distinct vertices stored (welded, plus the few copies far corners
    /// need).
    pub fn vertex_count(&self) -> usize {
        self.triangles.vertex_count()
    }

    pub fn sah_cost(&self) -> f32 {
        self.tree.sah_cost()
    }

    /// Bytes held: nodes of both trees (the 4-wide one's with their build
    /// ratios), slot order, vertices, corners and block starts. Everything a query needs; the mesh itself
    /// is not needed.
    pub fn memory_bytes(&self) -> usize {
        self.tree.memory_bytes()
            + self.tree8.as_ref().map_or(0, CompactBvh8::memory_bytes)
            + self.prim_ids.capacity() * 4
            + self.triangles.memory_bytes()
    }

    /// Refits to new vertex positions of the same mesh (same triangles).
    /// Where two vertices that had the same position have parted, the
    /// corners are laid out again (same tree) before the boxes are.
    pub fn refit(&mut self, mesh: &TriangleMesh) -> Result<RefitReport> {
        if mesh.triangle_count() != self.prim_ids.len() {
            return Err(Error::TriangleCountMismatch {
                expected: self.prim_ids.len(),
                actual: mesh.triangle_count(),
            });
        }
        if !self.triangles.refit(mesh, &self.prim_ids) {
            self.triangles = SharedCorners::new(mesh, &self.prim_ids);
        }
        let mut tree = std::mem::take(&mut self.tree);
        let mut tree8 = self.tree8.take();
        let (bounds, areas) = self.leaf_measures();
        let (degradation, boxes) = tree.refit(bounds, areas);
        if let Some(tree8) = &mut tree8 {
            tree8.refit_from(&tree, &boxes);
        }
        self.tree = tree;
        self.tree8 = tree8;
        Ok(RefitReport { degradation })
    }

    /// The nearest hit within the ray's range.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Option<MeshHit> {
        ray_queries::closest_hit(self, ray)
    }

    /// Whether anything lies on the ray within its range (occlusion).
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        ray_queries::any_hit(self, ray)
    }

    /// Calls `visit(triangle, t)` for every triangle the ray crosses within
    /// its range, in no particular order.
    pub fn for_each_hit(&self, ray: &Ray, visit: impl FnMut(u32, f32)) {
        ray_queries::for_each_hit(self, ray, visit)
    }
}

impl LeafTriangles for CompactBvh {
    type Tree = CompactBvh4;

    #[inline(always)]
    fn tree(&self) -> &CompactBvh4 {
        &self.tree
    }

    #[inline(always)]
    fn corners(&self, slot: u32) -> [Vec3A; 3] {
        self.triangles.corners(slot as usize)
    }

    #[inline(always)]
    fn prim_id(&self, slot: u32) -> u32 {
        self.prim_ids[slot as usize]
    }

    fn tree8(&self) -> Option<Tree8<'_>> {
        self.tree8.as_ref().map(Tree8::Compact)
    }
}
