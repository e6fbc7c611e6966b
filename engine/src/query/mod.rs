//! Scene-level queries on the two-level world of [`crate::bvh::world`]:
//! each is a visitor of its top-level walk that moves the query into an
//! object's frame and walks the object's own tree.

mod ray;

pub use crate::bvh::{ObjectStats, SceneBvh, SceneBvhStats};
pub(crate) use ray::local;
pub use ray::{NearestTriangle, SceneHit};
