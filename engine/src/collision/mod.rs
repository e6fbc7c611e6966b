//! Collision queries on the world's hierarchies: the pair walk of
//! [`crate::bvh::traverse::pair`] for the broad phase, exact
//! triangle–triangle decisions for the narrow one; continuous queries over
//! a step of motion in [`continuous`].

mod contact;
pub mod continuous;
mod discrete;
mod distance;
mod mesh_pairs;
mod near_pairs;
mod query;
mod triangle;

use std::ops::ControlFlow;

use glam::{DQuat, DVec3, Vec3, Vec3A};

pub use contact::contact_points;
pub use discrete::{object_contacts, object_proximity, self_contacts, world_contacts, Contact};
pub(crate) use distance::closest_on_triangle;
pub use distance::triangle_distance;
pub use mesh_pairs::{mesh_contacts, mesh_self_contacts, Placed};
pub use near_pairs::NearPairs;
pub use query::{all_pairs, CollisionQuery, CollisionTest, Found};
pub use triangle::triangles_intersect;

use crate::bvh::traverse::pair::self_overlapping_leaves;
use crate::bvh::wide::Bvh4;
use crate::geometry::RigidTransform;

/// An object-to-world motion in f64, so that two objects' triangles meet
/// in one frame with rounding far below the broad phase's padding.
pub(crate) fn world_point(to_world: &RigidTransform) -> impl Fn(DVec3) -> DVec3 {
    let q = to_world.rotation;
    let rotation = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize();
    let shift = to_world.translation.as_dvec3();
    let identity = to_world.is_identity();
    move |p| if identity { p } else { rotation * p + shift }
}

/// [`world_point`] for the corners of a triangle as the trees store them.
pub(crate) fn world_corners(to_world: &RigidTransform) -> impl Fn(&[Vec3A; 3]) -> [DVec3; 3] {
    let moved = world_point(to_world);
    move |t: &[Vec3A; 3]| t.map(|p| moved(Vec3::from(p).as_dvec3()))
}

/// Calls `test(x, y)` for every pair of distinct leaf slots `x < y` of
/// `tree` whose leaves' boxes overlap (each pair once): the candidates of
/// self-collision.
pub(crate) fn for_each_self_candidate(tree: &Bvh4, mut test: impl FnMut(usize, usize)) {
    self_overlapping_leaves(tree, |la, lb| {
        if la == lb {
            for x in la.slots() {
                for y in x + 1..la.slots().end {
                    test(x, y);
                }
            }
        } else {
            for x in la.slots() {
                for y in lb.slots() {
                    test(x, y);
                }
            }
        }
        ControlFlow::Continue(())
    });
}
