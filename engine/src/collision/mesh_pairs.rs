//! Intersecting triangles of two mesh trees, or of one tree with itself,
//! on all threads: the pair walk over the trees' boxes or over oriented
//! boxes fitted on the same topology, restarted from a BVTT front where
//! the caller keeps one, and the exact triangle test on each candidate.

use glam::{DVec3, Vec3, Vec3A};
use rayon::prelude::*;

use super::near_pairs::NearPairs;
use super::triangle::triangles_intersect;
use super::world_corners;
use crate::bvh::obb::{ObbTree, ObbVolumes};
use crate::bvh::traverse::front::{par_leaf_pairs, Front};
use crate::bvh::traverse::pair::{BoxVolumes, Leaf, PairVolumes};
use crate::bvh::traverse::Flow;
use crate::bvh::MeshBvh;
use crate::deadline::{Deadline, CLOCK_PERIOD};
use crate::geometry::{Aabb, BoxMotion, RigidTransform};
use crate::Result;

/// A mesh placed in the world, with the oriented boxes to walk instead of
/// its tree's own boxes, if any (both sides of a pair need them).
#[derive(Clone, Copy, Debug)]
pub struct Placed<'a> {
    pub mesh: &'a MeshBvh,
    pub to_world: &'a RigidTransform,
    pub obbs: Option<&'a ObbTree>,
}

/// Runs the walk over `volumes`, from `front` when given, until `stop`.
fn walk<V: PairVolumes>(
    volumes: &V,
    same: bool,
    front: Option<&mut Front>,
    stop: &Deadline,
    visit: impl Fn(Leaf, Leaf, &mut Vec<(u32, u32)>) + Sync,
) -> Result<Vec<(u32, u32)>> {
    let visit = |la: Leaf, lb: Leaf, out: &mut Vec<(u32, u32)>| {
        // The clock is read for about one pair of leaves in CLOCK_PERIOD,
        // picked by their slots (the visits share no counter); the flag it
        // raises, for every pair.
        let read = (la.first.wrapping_mul(31) ^ lb.first) % CLOCK_PERIOD as u32 == 0;
        if (if read { stop.check() } else { stop.expired() }).is_err() {
            return Flow::Break(());
        }
        visit(la, lb, out);
        Flow::Continue(())
    };
    let found = match front {
        Some(f) => f.leaf_pairs(volumes, same, visit),
        None => par_leaf_pairs(volumes, same, visit),
    };
    stop.expired()?;
    Ok(found)
}

pub(super) fn triangle_box([a, b, c]: &[Vec3A; 3]) -> Aabb {
    Aabb::new(a.min(*b).min(*c), a.max(*b).max(*c))
}

/// Whether two triangles of one mesh, in its frame, share no corner and
/// intersect (decided exactly on their coordinates).
pub(super) fn distinct_and_touching(tx: &[Vec3A; 3], ty: &[Vec3A; 3]) -> bool {
    let exact = |t: &[Vec3A; 3]| t.map(|p| Vec3::from(p).as_dvec3());
    !tx.iter().any(|p| ty.contains(p)) && triangles_intersect(&exact(tx), &exact(ty))
}

fn f64_box(t: &[DVec3; 3]) -> (DVec3, DVec3) {
    (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
}

fn boxes_meet((alo, ahi): (DVec3, DVec3), (blo, bhi): (DVec3, DVec3)) -> bool {
    alo.cmple(bhi).all() && ahi.cmpge(blo).all()
}

/// Triangles of `b`'s leaves moved to the world at a time, so each is
/// moved once per leaf pair rather than once per triangle it meets.
const BLOCK: usize = 16;

/// The leaf slots `(x of a, y of b)` of every pair of intersecting
/// triangles, decided exactly on world coordinates, in no order.
pub(crate) fn contact_slots(
    a: Placed,
    b: Placed,
    front: Option<&mut Front>,
    stop: &Deadline,
) -> Result<Vec<(u32, u32)>> {
    let moved = !a.to_world.is_identity() || !b.to_world.is_identity();
    let reach = b
        .mesh
        .bounds()
        .min
        .abs()
        .max(b.mesh.bounds().max.abs())
        .max_element();
    let (b_to_a, slack) = match moved {
        true => {
            let (motion, slack) = RigidTransform::relative(a.to_world, b.to_world, reach);
            (Some(motion), slack)
        }
        false => (None, 0.0),
    };
    let (to_a, to_b) = (world_corners(a.to_world), world_corners(b.to_world));
    let (ta, tb) = (a.mesh.leaf_triangles(), b.mesh.leaf_triangles());
    let visit = |la: Leaf, lb: Leaf, out: &mut Vec<(u32, u32)>| {
        let mut moved = [([DVec3::ZERO; 3], (DVec3::ZERO, DVec3::ZERO)); BLOCK];
        for start in lb.slots().step_by(BLOCK) {
            let ys = start..(start + BLOCK).min(lb.slots().end);
            for (m, y) in moved.iter_mut().zip(ys.clone()) {
                let w = to_b(&tb[y]);
                *m = (w, f64_box(&w));
            }
            for x in la.slots() {
                let wa = to_a(&ta[x]);
                let box_a = f64_box(&wa);
                for (y, (wb, box_b)) in ys.clone().zip(&moved) {
                    if boxes_meet(box_a, *box_b) && triangles_intersect(&wa, wb) {
                        out.push((x as u32, y as u32));
                    }
                }
            }
        }
    };
    Ok(match (a.obbs, b.obbs) {
        (Some(oa), Some(ob)) => {
            let volumes = ObbVolumes::new((a.mesh, oa), (b.mesh, ob), b_to_a, slack)?;
            walk(&volumes, false, front, stop, visit)?
        }
        _ => {
            let volumes = BoxVolumes {
                a: a.mesh.wide(),
                b: b.mesh.wide(),
                b_to_a: b_to_a.as_ref().map(BoxMotion::new),
                margin: slack,
            };
            walk(&volumes, false, front, stop, visit)?
        }
    })
}

/// The leaf slots `(x, y)`, `x < y`, of every pair of intersecting
/// triangles of one mesh that share no corner, in no order. Decided in the
/// mesh's own frame, where its coordinates are exact.
pub(crate) fn self_contact_slots(
    mesh: &MeshBvh,
    obbs: Option<&ObbTree>,
    stop: &Deadline,
) -> Result<Vec<(u32, u32)>> {
    let tris = mesh.leaf_triangles();
    // Each triangle's box once, not once per leaf pair it is in (a cloth's
    // leaf meets about ten others).
    let boxes: Vec<Aabb> = tris
        .par_iter()
        .with_min_len(4096)
        .map(triangle_box)
        .collect();
    let visit = |la: Leaf, lb: Leaf, out: &mut Vec<(u32, u32)>| {
        let reach = boxes[lb.slots()]
            .iter()
            .fold(Aabb::EMPTY, |u, b| u.union(*b));
        for x in la.slots() {
            let bx = &boxes[x];
            // Most triangles of a leaf lie away from a neighbouring leaf:
            // one test against that leaf's box skips them.
            if !bx.overlaps(&reach) {
                continue;
            }
            let ys = if la == lb {
                x + 1..la.slots().end
            } else {
                lb.slots()
            };
            for y in ys {
                if bx.overlaps(&boxes[y]) {
                    let (tx, ty) = (&tris[x], &tris[y]);
                    if distinct_and_touching(tx, ty) {
                        out.push((x as u32, y as u32));
                    }
                }
            }
        }
    };
    Ok(match obbs {
        Some(o) => {
            let volumes = ObbVolumes::new((mesh, o), (mesh, o), None, 0.0)?;
            walk(&volumes, true, None, stop, visit)?
        }
        None => {
            let volumes = BoxVolumes {
                a: mesh.wide(),
                b: mesh.wide(),
                b_to_a: None,
                margin: 0.0,
            };
            walk(&volumes, true, None, stop, visit)?
        }
    })
}

/// Every pair of intersecting triangles of two placed meshes, as
/// mesh-order triangle indices `(of a, of b)`, sorted. With a `front`, the
/// walk restarts where the last call with it stopped (valid while both
/// trees keep their topology; otherwise it starts over).
///
/// ```
/// use frusta_engine::bvh::{BuildOptions, MeshBvh};
/// use frusta_engine::collision::{mesh_contacts, Placed};
/// use frusta_engine::geometry::{RigidTransform, TriangleMesh};
/// use glam::Vec3;
///
/// let tri = |z: f32| TriangleMesh::new(
///     vec![Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, -z), Vec3::new(0.0, 1.0, 0.0)],
///     vec![[0, 1, 2]],
/// ).unwrap();
/// let (a, b) = (MeshBvh::build(&tri(0.0), &BuildOptions::default()), MeshBvh::build(&tri(0.5), &BuildOptions::default()));
/// let at = RigidTransform::default();
/// let place = |mesh| Placed { mesh, to_world: &at, obbs: None };
/// assert_eq!(mesh_contacts(place(&a), place(&b), None).unwrap(), vec![(0, 0)]);
/// ```
pub fn mesh_contacts(a: Placed, b: Placed, front: Option<&mut Front>) -> Result<Vec<(u32, u32)>> {
    let (ia, ib) = (a.mesh.prim_ids(), b.mesh.prim_ids());
    let mut pairs: Vec<(u32, u32)> = contact_slots(a, b, front, &Deadline::none())?
        .into_iter()
        .map(|(x, y)| (ia[x as usize], ib[y as usize]))
        .collect();
    pairs.sort_unstable();
    Ok(pairs)
}

/// Every pair of intersecting triangles of one mesh that share no corner,
/// as mesh-order indices `(p, q)`, `p < q`, sorted. With `near`, the
/// pairs kept from the frames before answer while they hold every pair
/// that can touch (see [`NearPairs`]), and its walks, when it must be
/// taken again, use the tree's boxes; without, one walk over the boxes or
/// over `obbs`.
pub fn mesh_self_contacts(
    mesh: &MeshBvh,
    obbs: Option<&ObbTree>,
    near: Option<&mut NearPairs>,
) -> Result<Vec<(u32, u32)>> {
    let ids = mesh.prim_ids();
    let slots = match near {
        Some(near) => near.contact_slots(mesh, &Deadline::none())?,
        None => self_contact_slots(mesh, obbs, &Deadline::none())?,
    };
    let mut pairs: Vec<(u32, u32)> = slots
        .into_iter()
        .map(|(x, y)| {
            let (p, q) = (ids[x as usize], ids[y as usize]);
            (p.min(q), p.max(q))
        })
        .collect();
    pairs.sort_unstable();
    Ok(pairs)
}
