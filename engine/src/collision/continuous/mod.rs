//! Continuous collision of objects over one step: every vertex moves on a
//! straight line in the world from its pose at the start (the object as the
//! world holds it) to its pose at the end (a new transform, or new vertex
//! positions for a deforming mesh). The broad phase is the pair walk over
//! the object's own tree refitted to swept boxes; the narrow phase runs the
//! six vertex–face and nine edge–edge tests of every candidate triangle
//! pair ([`inclusion`]).

mod arithmetic;
mod inclusion;
mod memo;
mod sample_queries;

use std::ops::ControlFlow;

use glam::{DVec3, Vec3A};

pub use inclusion::{CcdOptions, CcdScratch, EdgeEdge, VertexFace};
pub use sample_queries::{read_sample_queries, SampleQuery};

use super::{for_each_self_candidate, world_corners, Contact};
use crate::bvh::traverse::pair::overlapping_leaves;
use crate::bvh::wide::Bvh4;
use crate::bvh::SceneBvh;
use crate::deadline::{Deadline, CLOCK_PERIOD};
use crate::geometry::{Aabb, RigidTransform, TriangleMesh};
use crate::{Error, Result};

/// Two triangles that touch during the step, and the earliest time (0 at
/// the start, 1 at the end) at which they do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweptContact {
    pub contact: Contact,
    pub time: f64,
}

/// One object over a step: its triangles in the world at the start and at
/// the end, in the leaf order of its tree, and that tree refitted to boxes
/// that hold each triangle's whole sweep.
#[derive(Clone, Debug)]
pub struct Sweep {
    object: u32,
    start: Vec<[DVec3; 3]>,
    end: Vec<[DVec3; 3]>,
    tree: Bvh4,
    prim_ids: Vec<u32>,
}

/// Where an object is at the end of a step.
#[derive(Clone, Copy, Debug)]
pub enum EndPose<'a> {
    /// Where it is now: it does not move.
    Stays,
    /// Moved rigidly to this object-to-world transform.
    Moved(&'a RigidTransform),
    /// Deformed to this mesh (the object's triangles, new positions) and
    /// placed by this transform.
    Deformed(&'a TriangleMesh, &'a RigidTransform),
}

impl Sweep {
    /// The sweep of `object` from its pose in `world` to `end`, its boxes
    /// grown by half of `options.tolerance` so that two boxes overlap where
    /// their contents come within the tolerance: sweeps queried together
    /// are made with the same options.
    pub fn new(world: &SceneBvh, object: u32, end: EndPose, options: &CcdOptions) -> Result<Self> {
        let count = world.object_count();
        let inst = world
            .instances()
            .get(object as usize)
            .ok_or_else(|| Error::UnknownObject(format!("#{object} (the scene has {count})")))?;
        let bvh = inst.bvh();
        let to_start = world_corners(inst.to_world());
        let start: Vec<[DVec3; 3]> = bvh.leaf_triangles().iter().map(&to_start).collect();
        let end = match end {
            EndPose::Stays => start.clone(),
            EndPose::Moved(t) => {
                let to_end = world_corners(t);
                bvh.leaf_triangles().iter().map(to_end).collect()
            }
            EndPose::Deformed(mesh, t) => {
                if mesh.triangle_count() != bvh.triangle_count() {
                    return Err(Error::TriangleCountMismatch {
                        expected: bvh.triangle_count(),
                        actual: mesh.triangle_count(),
                    });
                }
                let to_end = world_corners(t);
                bvh.prim_ids()
                    .iter()
                    .map(|&t| to_end(&mesh.corners(t as usize)))
                    .collect()
            }
        };
        let mut tree = bvh.wide().clone();
        tree.refit(|first, count| {
            let slots = first as usize..(first + count) as usize;
            swept_box(
                start[slots.clone()].iter().chain(&end[slots]).flatten(),
                0.5 * options.tolerance,
            )
        });
        Ok(Self {
            object,
            start,
            end,
            tree,
            prim_ids: bvh.prim_ids().to_vec(),
        })
    }

    /// The object swept.
    pub fn object(&self) -> u32 {
        self.object
    }

    /// Box of the whole sweep (with the tolerance margin).
    pub fn bounds(&self) -> Aabb {
        self.tree.bounds()
    }

    /// Triangle `slot`'s corners at the start and at the end.
    fn triangle(&self, slot: usize) -> MovingTriangle {
        std::array::from_fn(|i| [self.start[slot][i], self.end[slot][i]])
    }
}

/// The f32 box of f64 points grown by `margin`, rounded outward so that it
/// holds them.
fn swept_box<'a>(points: impl Iterator<Item = &'a DVec3>, margin: f64) -> Aabb {
    let (lo, hi) = points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(*p), hi.max(*p))
    });
    let pad =
        |v: DVec3| v.abs() * (4.0 * f32::EPSILON as f64) + DVec3::splat(f32::MIN_POSITIVE as f64);
    let (lo, hi) = (lo - pad(lo) - margin, hi + pad(hi) + margin);
    Aabb::new(Vec3A::from(lo.as_vec3()), Vec3A::from(hi.as_vec3()))
}

/// A triangle's corners, each at the start and at the end of the step.
type MovingTriangle = [[DVec3; 2]; 3];

/// Earliest time at which two moving triangles touch: the six vertex–face
/// and nine edge–edge tests, each skipped where its primitives' sweeps are
/// apart, and where `shared` says a vertex or edge end is common to both
/// (adjacent triangles of one mesh touch there by construction).
fn triangles_time_of_impact(
    a: &MovingTriangle,
    b: &MovingTriangle,
    shared: impl Fn(&[DVec3; 2], &[DVec3; 2]) -> bool,
    options: &CcdOptions,
    scratch: &mut CcdScratch,
) -> Option<f64> {
    let apart = |x: &[&[DVec3; 2]], y: &[&[DVec3; 2]]| {
        let hull = |s: &[&[DVec3; 2]]| {
            s.iter()
                .flat_map(|p| p.iter())
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(*p), hi.max(*p))
                })
        };
        let ((xl, xh), (yl, yh)) = (hull(x), hull(y));
        let tol = DVec3::splat(options.tolerance);
        (xl - tol).cmpgt(yh).any() || (yl - tol).cmpgt(xh).any()
    };
    let mut best: Option<f64> = None;
    let mut consider = |t: Option<f64>| {
        if let Some(t) = t {
            best = Some(best.map_or(t, |b| b.min(t)));
        }
    };
    for (vertices, face) in [(a, b), (b, a)] {
        let f = [&face[0], &face[1], &face[2]];
        for v in vertices {
            if f.iter().any(|c| shared(v, c)) || apart(&[v], &f) {
                continue;
            }
            let query = VertexFace {
                vertex: *v,
                face: *face,
            };
            consider(query.time_of_impact(options, scratch));
        }
    }
    for i in 0..3 {
        let ea = [&a[i], &a[(i + 1) % 3]];
        for j in 0..3 {
            let eb = [&b[j], &b[(j + 1) % 3]];
            let common = ea.iter().any(|p| eb.iter().any(|q| shared(p, q)));
            if common || apart(&ea, &eb) {
                continue;
            }
            let query = EdgeEdge {
                a: [*ea[0], *ea[1]],
                b: [*eb[0], *eb[1]],
            };
            consider(query.time_of_impact(options, scratch));
        }
    }
    best
}

fn sort_by_time(contacts: &mut [SweptContact]) {
    contacts.sort_unstable_by(|x, y| x.time.total_cmp(&y.time).then(x.contact.cmp(&y.contact)));
}

/// Every pair of triangles of two different objects that touch during the
/// step, with the earliest time each pair does, earliest first.
pub fn sweep_contacts(a: &Sweep, b: &Sweep, options: &CcdOptions) -> Vec<SweptContact> {
    sweep_contacts_until(a, b, options, &Deadline::none()).unwrap_or_default()
}

/// A clock read on the first call and every [`CLOCK_PERIOD`] after, for
/// the sequential sweeps.
struct Ticker<'d> {
    stop: &'d Deadline,
    calls: u64,
}

impl Ticker<'_> {
    fn late(&mut self) -> bool {
        self.calls += 1;
        self.calls % CLOCK_PERIOD == 1 && self.stop.check().is_err()
    }
}

/// [`sweep_contacts`] until `stop`.
pub(crate) fn sweep_contacts_until(
    a: &Sweep,
    b: &Sweep,
    options: &CcdOptions,
    stop: &Deadline,
) -> Result<Vec<SweptContact>> {
    let mut scratch = CcdScratch::default();
    let mut found = Vec::new();
    let mut ticker = Ticker { stop, calls: 0 };
    overlapping_leaves(&a.tree, &b.tree, None, |la, lb| {
        if ticker.late() {
            return ControlFlow::Break(());
        }
        for x in la.slots() {
            let ta = a.triangle(x);
            for y in lb.slots() {
                let tb = b.triangle(y);
                if let Some(time) =
                    triangles_time_of_impact(&ta, &tb, |_, _| false, options, &mut scratch)
                {
                    found.push(SweptContact {
                        contact: Contact {
                            a: (a.object, a.prim_ids[x]),
                            b: (b.object, b.prim_ids[y]),
                        },
                        time,
                    });
                }
            }
        }
        ControlFlow::Continue(())
    });
    stop.expired()?;
    sort_by_time(&mut found);
    Ok(found)
}

/// Every pair of triangles of one object that touch during the step,
/// earliest first, `a` before `b` in mesh order. Vertices and edge ends the
/// two triangles share at the start (by position) are not tested against
/// each other, so adjacent triangles count only where other parts meet.
pub fn self_sweep_contacts(sweep: &Sweep, options: &CcdOptions) -> Vec<SweptContact> {
    self_sweep_contacts_until(sweep, options, &Deadline::none()).unwrap_or_default()
}

/// [`self_sweep_contacts`] until `stop`.
pub(crate) fn self_sweep_contacts_until(
    sweep: &Sweep,
    options: &CcdOptions,
    stop: &Deadline,
) -> Result<Vec<SweptContact>> {
    let mut ticker = Ticker { stop, calls: 0 };
    let mut scratch = CcdScratch::default();
    let mut found = Vec::new();
    let shared = |p: &[DVec3; 2], q: &[DVec3; 2]| p[0] == q[0];
    let mut test = |x: usize, y: usize| {
        // Candidates go on after the deadline, but are no longer tested.
        if ticker.late() || stop.expired().is_err() {
            return;
        }
        let (ta, tb) = (sweep.triangle(x), sweep.triangle(y));
        if let Some(time) = triangles_time_of_impact(&ta, &tb, shared, options, &mut scratch) {
            let (p, q) = (sweep.prim_ids[x], sweep.prim_ids[y]);
            found.push(SweptContact {
                contact: Contact {
                    a: (sweep.object, p.min(q)),
                    b: (sweep.object, p.max(q)),
                },
                time,
            });
        }
    };
    for_each_self_candidate(&sweep.tree, &mut test);
    stop.expired()?;
    sort_by_time(&mut found);
    Ok(found)
}
