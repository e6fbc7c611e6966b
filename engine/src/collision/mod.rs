//! Collision queries on the world's hierarchies: the pair walk of
//! [`crate::bvh::traverse::pair`] for the broad phase, exact
//! triangle–triangle decisions for the narrow one.

mod discrete;
mod distance;
mod triangle;

pub use discrete::{object_contacts, object_proximity, self_contacts, world_contacts, Contact};
pub use distance::triangle_distance;
pub use triangle::triangles_intersect;
