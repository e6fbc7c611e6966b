//! Discrete collision: which triangles of two objects, in their current
//! poses, intersect or come within a distance, and which non-adjacent
//! triangles of one object intersect.

use std::ops::ControlFlow;

use glam::{DVec3, Vec3, Vec3A};

use super::contact::contact_points;
use super::distance::triangle_distance;
use super::mesh_pairs::{contact_slots, self_contact_slots, Placed};
use super::{world_corners, world_point};
use crate::bvh::{Instance, SceneBvh};
use crate::deadline::{Deadline, CLOCK_PERIOD};
use crate::Result;

/// Two intersecting triangles, as (object, mesh-order triangle) each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Contact {
    pub a: (u32, u32),
    pub b: (u32, u32),
}

/// Calls `visit(contact, triangle of a, triangle of b)` with world
/// coordinates for every candidate pair of the pair walk of `a` and `b`
/// (boxes grown by `margin`). A leaf of `b` is moved to the world once per
/// leaf pair, not once per triangle of `a` it is paired with.
fn for_each_candidate(
    world: &SceneBvh,
    a: u32,
    b: u32,
    margin: f32,
    stop: &Deadline,
    mut visit: impl FnMut(Contact, &[DVec3; 3], &[DVec3; 3]),
) -> Result<()> {
    let instances = world.instances();
    let mut moved_b: Vec<[DVec3; 3]> = Vec::new();
    let mut leaf_pairs = 0u64;
    let mut late = Ok(());
    world.leaves_within(a, b, margin, |la, lb| {
        leaf_pairs += 1;
        if leaf_pairs % CLOCK_PERIOD == 1 {
            late = stop.check();
            if late.is_err() {
                return ControlFlow::Break(());
            }
        }
        let (ia, ib) = (&instances[a as usize], &instances[b as usize]);
        let (to_a, to_b) = (world_corners(ia.to_world()), world_corners(ib.to_world()));
        let (ta, tb) = (ia.bvh().leaf_triangles(), ib.bvh().leaf_triangles());
        let (ida, idb) = (ia.bvh().prim_ids(), ib.bvh().prim_ids());
        moved_b.clear();
        moved_b.extend(tb[lb.slots()].iter().map(&to_b));
        for x in la.slots() {
            let wa = to_a(&ta[x]);
            for (y, wb) in lb.slots().zip(&moved_b) {
                let contact = Contact {
                    a: (a, ida[x]),
                    b: (b, idb[y]),
                };
                visit(contact, &wa, wb);
            }
        }
        ControlFlow::Continue(())
    })?;
    late
}

/// Every pair of intersecting triangles between objects `a` and `b`,
/// sorted: the pair walk of their trees finds the candidates, and each is
/// decided exactly ([`triangles_intersect`]) on the world coordinates.
pub fn object_contacts(world: &SceneBvh, a: u32, b: u32) -> Result<Vec<Contact>> {
    Ok(object_contacts_at(world, a, b, &Deadline::none())?
        .into_iter()
        .map(|(c, _)| c)
        .collect())
}

/// [`object_contacts`] with where each pair meets, in the world
/// ([`contact_points`]).
pub(crate) fn object_contacts_at(
    world: &SceneBvh,
    a: u32,
    b: u32,
    stop: &Deadline,
) -> Result<Vec<(Contact, Vec<DVec3>)>> {
    let (ia, ib) = (instance(world, a)?, instance(world, b)?);
    let (to_a, to_b) = (world_corners(ia.to_world()), world_corners(ib.to_world()));
    let (ta, tb) = (ia.bvh().leaf_triangles(), ib.bvh().leaf_triangles());
    let (ida, idb) = (ia.bvh().prim_ids(), ib.bvh().prim_ids());
    let mut contacts: Vec<_> = contact_slots(placed(ia), placed(ib), None, stop)?
        .into_iter()
        .map(|(x, y)| {
            let (x, y) = (x as usize, y as usize);
            let contact = Contact {
                a: (a, ida[x]),
                b: (b, idb[y]),
            };
            (contact, contact_points(&to_a(&ta[x]), &to_b(&tb[y])))
        })
        .collect();
    contacts.sort_unstable_by_key(|c| c.0);
    Ok(contacts)
}

/// Every pair of intersecting triangles between any two objects of the
/// world, sorted.
pub fn world_contacts(world: &SceneBvh) -> Vec<Contact> {
    let mut pairs = Vec::new();
    world.overlapping_objects(|a, b| {
        pairs.push((a, b));
        ControlFlow::Continue(())
    });
    let mut contacts: Vec<Contact> = pairs
        .into_iter()
        .flat_map(|(a, b)| object_contacts(world, a, b).expect("objects of this world"))
        .collect();
    contacts.sort_unstable();
    contacts
}

/// Every pair of intersecting triangles of one object that share no corner
/// (triangles meeting at a shared vertex or edge touch by construction),
/// sorted, `a` before `b`. Adjacency is by corner position, so welded and
/// unwelded meshes are treated alike. Decided in the object's own frame,
/// where the coordinates are exact: self-intersection does not change when
/// an object moves rigidly.
pub fn self_contacts(world: &SceneBvh, object: u32) -> Result<Vec<Contact>> {
    Ok(self_contacts_at(world, object, &Deadline::none())?
        .into_iter()
        .map(|(c, _)| c)
        .collect())
}

/// [`self_contacts`] with where each pair meets, in the world
/// ([`contact_points`]).
pub(crate) fn self_contacts_at(
    world: &SceneBvh,
    object: u32,
    stop: &Deadline,
) -> Result<Vec<(Contact, Vec<DVec3>)>> {
    let inst = instance(world, object)?;
    let tris = inst.bvh().leaf_triangles();
    let ids = inst.bvh().prim_ids();
    let to_world = world_point(inst.to_world());
    let exact = |t: &[Vec3A; 3]| t.map(|p| Vec3::from(p).as_dvec3());
    let mut contacts: Vec<_> = self_contact_slots(inst.bvh(), None, stop)?
        .into_iter()
        .map(|(x, y)| {
            let (x, y) = (x as usize, y as usize);
            let (p, q) = (ids[x].min(ids[y]), ids[x].max(ids[y]));
            let contact = Contact {
                a: (object, p),
                b: (object, q),
            };
            let points = contact_points(&exact(&tris[x]), &exact(&tris[y]))
                .into_iter()
                .map(&to_world)
                .collect();
            (contact, points)
        })
        .collect();
    contacts.sort_unstable_by_key(|c| c.0);
    Ok(contacts)
}

fn placed(i: &Instance) -> Placed<'_> {
    Placed {
        mesh: i.bvh(),
        to_world: i.to_world(),
        obbs: None,
    }
}

/// Object `object` of the world, or an error naming it.
fn instance(world: &SceneBvh, object: u32) -> Result<&Instance> {
    let count = world.object_count();
    world
        .instances()
        .get(object as usize)
        .ok_or_else(|| crate::Error::UnknownObject(format!("#{object} (the scene has {count})")))
}

/// Every pair of triangles of objects `a` and `b` at most `distance`
/// apart in the world, with their distance (0 where they intersect),
/// sorted: the contacts a solver needs before objects touch.
pub fn object_proximity(
    world: &SceneBvh,
    a: u32,
    b: u32,
    distance: f64,
) -> Result<Vec<(Contact, f64)>> {
    proximity_until(world, a, b, distance, &Deadline::none())
}

/// [`object_proximity`] until `stop`.
pub(crate) fn proximity_until(
    world: &SceneBvh,
    a: u32,
    b: u32,
    distance: f64,
    stop: &Deadline,
) -> Result<Vec<(Contact, f64)>> {
    if !(distance >= 0.0 && distance.is_finite()) {
        return Err(crate::Error::InvalidOption {
            field: "distance".into(),
            reason: format!("{distance} must be a finite distance of at least 0"),
        });
    }
    let mut near = Vec::new();
    // The broad phase in f32, grown by rounding of the distance.
    let margin = (distance * (1.0 + 1e-6)) as f32 * (1.0 + 4.0 * f32::EPSILON);
    for_each_candidate(world, a, b, margin, stop, |contact, wa, wb| {
        let d = triangle_distance(wa, wb);
        if d <= distance {
            near.push((contact, d));
        }
    })?;
    near.sort_unstable_by_key(|n| n.0);
    Ok(near)
}
