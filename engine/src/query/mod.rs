//! Scene-level queries on a two-level acceleration structure: one
//! [`MeshBvh`](crate::bvh::MeshBvh) per object in the object's own frame,
//! and a small top-level BVH over the objects' world boxes. Moving an object
//! rigidly changes only its transform and the top level; deforming it
//! refits only its own tree.

mod ray;
mod scene_bvh;

pub use ray::SceneHit;
pub use scene_bvh::{ObjectStats, SceneBvh, SceneBvhStats};
