//! Bounding volume hierarchies over boxes, and [`MeshBvh`], a hierarchy bound
//! to one triangle mesh.
//!
//! - [`node`]: the 32-byte node layout;
//! - [`build`]: binned SAH, Morton (LBVH) and hybrid builders;
//! - [`compact`]: the same trees in a quarter of the bytes (quantised
//!   boxes, shared vertices);
//! - [`refit`]: bottom-up box updates after geometry moves, with the rebuild
//!   heuristic of Lauterbach's dissertation (section 4.1.5);
//! - [`traverse`]: the traversal core: one ordered walk per tree width
//!   driven by a node test per query kind (ray, frustum, box), and the
//!   pair walk of two trees;
//! - [`wide`]: the 4-wide tree collapsed from a binary build, which meshes
//!   are traced with, refitted and judged by the rebuild heuristic;
//! - [`world`]: the two-level world of a scene, instances with transforms
//!   over per-object trees, and the walk over its top level.

pub mod build;
pub mod compact;
pub mod lod;
mod mesh_bvh;
mod moments;
pub mod node;
pub mod obb;
mod ray_queries;
pub mod refit;
pub mod traverse;
pub mod wide;
pub mod world;

pub use build::{BuildMethod, BuildOptions};
pub use compact::CompactBvh;
pub use mesh_bvh::{MeshBvh, MeshHit, RefitReport, UpdateAction, UpdateReport};
pub use node::Node;
pub use refit::DEFAULT_REBUILD_THRESHOLD;
pub use world::{Instance, ObjectStats, SceneBvh, SceneBvhStats};

/// A binary BVH over a set of primitives given by their boxes.
///
/// Nodes are stored depth first with the root at index 0; the two children
/// of an inner node are adjacent, so a node needs only one link, and every
/// child comes after its parent, so a reverse sweep is a bottom-up pass.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub(crate) nodes: Vec<Node>,
    /// Leaf order to caller order: leaf slot `i` holds primitive `prim_ids[i]`.
    pub(crate) prim_ids: Vec<u32>,
}

impl Bvh {
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Primitive indices in leaf order.
    pub fn prim_ids(&self) -> &[u32] {
        &self.prim_ids
    }

    pub fn bounds(&self) -> crate::geometry::Aabb {
        self.nodes
            .first()
            .map(Node::aabb)
            .unwrap_or(crate::geometry::Aabb::EMPTY)
    }

    /// Bytes held by the hierarchy itself (nodes and leaf order).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>() + self.prim_ids.capacity() * 4
    }

    /// Depth of the deepest leaf (the root has depth 0).
    pub fn depth(&self) -> usize {
        fn walk(nodes: &[Node], i: usize) -> usize {
            let n = &nodes[i];
            if n.is_leaf() {
                0
            } else {
                let l = n.first() as usize;
                1 + walk(nodes, l).max(walk(nodes, l + 1))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(&self.nodes, 0)
        }
    }
}
