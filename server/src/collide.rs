//! Collision queries on a served scene, for the collisions route and for
//! streams subscribed to collisions: the request checked and resolved to
//! object indices ([`Plan`]), then run on the scene as it is or atomically
//! with object moves ([`run`]).

use std::collections::HashSet;

use frusta_api::collisions::{
    CollisionKind, CollisionRequest, CollisionResponse, TriangleContact, TriangleRef,
};
use frusta_api::objects::{EditReport, ObjectMove};
use frusta_engine::bvh::SceneBvh;
use frusta_engine::collision::continuous::{
    self_sweep_contacts, sweep_contacts, CcdOptions, EndPose, Sweep,
};
use frusta_engine::collision::{object_contacts, object_proximity, self_contacts, Contact};

use crate::error::ApiError;
use crate::registry::{LiveScene, ObjectEdit, PreparedEdit, Registry, SceneEntry};
use crate::routes::objects::{edit_of, object_index};

/// Contacts listed when the request does not say.
const DEFAULT_MAX_CONTACTS: usize = 1_000;
/// Most contacts one answer lists.
pub const MAX_CONTACTS: usize = 100_000;
/// Most pairs, self objects or moves in one request.
const MAX_ITEMS: usize = 4096;

/// What to test, with objects resolved to indices.
#[derive(Clone, Debug)]
pub struct Plan {
    kind: CollisionKind,
    query: Query,
    pairs: Vec<(u32, u32)>,
    selves: Vec<u32>,
    max_contacts: usize,
}

#[derive(Clone, Copy, Debug)]
enum Query {
    Discrete,
    Proximity(f64),
    Continuous(Option<f64>),
}

/// A contact found, with its distance (proximity) or time (continuous).
type Found = (Contact, Option<f64>, Option<f64>);

fn invalid(field: &str, reason: impl Into<String>) -> ApiError {
    ApiError::from_engine(frusta_engine::Error::InvalidOption {
        field: field.into(),
        reason: reason.into(),
    })
}

/// Checks `request` (but its moves) against the scene's objects.
pub fn plan(entry: &SceneEntry, request: &CollisionRequest) -> Result<Plan, ApiError> {
    let max_contacts = request.max_contacts.unwrap_or(DEFAULT_MAX_CONTACTS);
    if max_contacts > MAX_CONTACTS {
        return Err(invalid(
            "max_contacts",
            format!("{max_contacts} is more than {MAX_CONTACTS}"),
        ));
    }
    let query = match request.kind {
        CollisionKind::Discrete => Query::Discrete,
        CollisionKind::Proximity => match request.distance {
            Some(d) if d.is_finite() && d >= 0.0 => Query::Proximity(d),
            Some(d) => {
                return Err(invalid(
                    "distance",
                    format!("{d} is not a distance of at least 0"),
                ))
            }
            None => return Err(invalid("distance", "a proximity query needs a distance")),
        },
        CollisionKind::Continuous => match request.tolerance {
            Some(t) if !(t.is_finite() && t > 0.0) => {
                return Err(invalid(
                    "tolerance",
                    format!("{t} is not a positive distance"),
                ))
            }
            t => Query::Continuous(t),
        },
    };
    if request.distance.is_some() && !matches!(query, Query::Proximity(_)) {
        return Err(invalid(
            "distance",
            "only a proximity query takes a distance",
        ));
    }
    if request.tolerance.is_some() && !matches!(query, Query::Continuous(_)) {
        return Err(invalid(
            "tolerance",
            "only a continuous query takes a tolerance",
        ));
    }
    if matches!(query, Query::Proximity(_)) && !request.self_objects.is_empty() {
        return Err(invalid(
            "self",
            "proximity has no self form: neighbouring triangles always touch",
        ));
    }
    let pairs_given = request.pairs.as_ref().map_or(0, Vec::len);
    for (field, count) in [
        ("pairs", pairs_given),
        ("self", request.self_objects.len()),
        ("moves", request.moves.len()),
    ] {
        if count > MAX_ITEMS {
            return Err(invalid(
                field,
                format!("{count} given, at most {MAX_ITEMS}"),
            ));
        }
    }
    let index = |name: &str| object_index(entry, name).map(|i| i as u32);
    let pairs = match &request.pairs {
        Some(pairs) => pairs
            .iter()
            .map(|[a, b]| {
                let (a, b) = (index(a)?, index(b)?);
                if a == b {
                    return Err(invalid(
                        "pairs",
                        format!("object #{a} paired with itself: ask for it in `self`"),
                    ));
                }
                Ok((a.min(b), a.max(b)))
            })
            .collect::<Result<Vec<_>, _>>()?,
        None if request.self_objects.is_empty() => {
            let n = entry.object_names.len() as u32;
            (0..n)
                .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
                .collect()
        }
        None => Vec::new(),
    };
    let selves = request
        .self_objects
        .iter()
        .map(|name| index(name))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Plan {
        kind: request.kind,
        query,
        pairs,
        selves,
        max_contacts,
    })
}

/// The moves as object edits, each object at most once.
pub fn edits(
    entry: &SceneEntry,
    moves: &[ObjectMove],
) -> Result<Vec<(usize, ObjectEdit)>, ApiError> {
    let mut seen = HashSet::new();
    moves
        .iter()
        .map(|m| {
            let object = object_index(entry, &m.object)?;
            if !seen.insert(object) {
                return Err(invalid(
                    "moves",
                    format!("object `{}` is moved twice", m.object),
                ));
            }
            Ok((object, edit_of(&m.patch)?))
        })
        .collect()
}

/// Discrete and proximity contacts in the world as it is.
fn contacts_now(world: &SceneBvh, plan: &Plan) -> Vec<Found> {
    let mut found = Vec::new();
    for &(a, b) in &plan.pairs {
        match plan.query {
            Query::Proximity(d) => found.extend(
                object_proximity(world, a, b, d)
                    .expect("planned objects exist")
                    .into_iter()
                    .map(|(c, d)| (c, Some(d), None)),
            ),
            _ => found.extend(
                object_contacts(world, a, b)
                    .expect("planned objects exist")
                    .into_iter()
                    .map(|c| (c, None, None)),
            ),
        }
    }
    for &o in &plan.selves {
        found.extend(
            self_contacts(world, o)
                .expect("planned objects exist")
                .into_iter()
                .map(|c| (c, None, None)),
        );
    }
    found
}

/// Continuous contacts over the motion from the scene as it is to the
/// prepared edits, earliest first.
fn contacts_during(
    live: &LiveScene,
    edits: &[PreparedEdit],
    plan: &Plan,
    tolerance: Option<f64>,
) -> Result<Vec<Found>, ApiError> {
    let world = live.acoustic.bvh();
    let size = world.bounds().extent().max_element() as f64;
    let options = CcdOptions {
        tolerance: tolerance.unwrap_or(1e-6 * size.max(f64::from(f32::MIN_POSITIVE))),
        ..CcdOptions::default()
    };
    let mut involved: Vec<u32> = plan
        .pairs
        .iter()
        .flat_map(|&(a, b)| [a, b])
        .chain(plan.selves.iter().copied())
        .collect();
    involved.sort_unstable();
    involved.dedup();
    let sweeps = involved
        .iter()
        .map(|&o| {
            let edit = edits.iter().find(|e| e.object == o as usize);
            let now = &live.scene.objects[o as usize].transform;
            let end = match edit {
                Some(PreparedEdit {
                    mesh: Some(mesh),
                    transform,
                    ..
                }) => EndPose::Deformed(mesh, transform.as_ref().unwrap_or(now)),
                Some(PreparedEdit {
                    transform: Some(t), ..
                }) => EndPose::Moved(t),
                _ => EndPose::Stays,
            };
            Sweep::new(world, o, end, &options)
        })
        .collect::<frusta_engine::Result<Vec<_>>>()
        .map_err(ApiError::from_engine)?;
    let sweep = |o: u32| &sweeps[involved.binary_search(&o).expect("swept")];
    let mut found: Vec<Found> = Vec::new();
    for &(a, b) in &plan.pairs {
        let (sa, sb) = (sweep(a), sweep(b));
        if sa.bounds().overlaps(&sb.bounds()) {
            found.extend(
                sweep_contacts(sa, sb, &options)
                    .into_iter()
                    .map(|c| (c.contact, None, Some(c.time))),
            );
        }
    }
    for &o in &plan.selves {
        found.extend(
            self_sweep_contacts(sweep(o), &options)
                .into_iter()
                .map(|c| (c.contact, None, Some(c.time))),
        );
    }
    found.sort_by(|x, y| {
        let time = |f: &Found| f.2.unwrap_or(0.0);
        time(x).total_cmp(&time(y)).then(x.0.cmp(&y.0))
    });
    Ok(found)
}

fn answer(
    entry: &SceneEntry,
    live: &LiveScene,
    plan: &Plan,
    mut found: Vec<Found>,
) -> CollisionResponse {
    let max = plan.max_contacts;
    let total = found.len();
    let earliest_time = found.iter().filter_map(|f| f.2).reduce(f64::min);
    found.truncate(max);
    let name = |(object, triangle): (u32, u32)| TriangleRef {
        object: entry.object_names[object as usize].clone(),
        triangle,
    };
    CollisionResponse {
        revision: live.acoustic.revision(),
        kind: plan.kind,
        contacts: found
            .into_iter()
            .map(|(c, distance, time)| TriangleContact {
                a: name(c.a),
                b: name(c.b),
                distance,
                time,
            })
            .collect(),
        total,
        truncated: total > max,
        earliest_time,
    }
}

/// Runs `plan` on the scene as it is, or with `edits` applied and stored
/// in the same step (a continuous query sweeps from before them to after).
/// One report per edit. Blocking.
pub fn run(
    registry: &Registry,
    entry: &SceneEntry,
    plan: &Plan,
    edits: &[(usize, ObjectEdit)],
) -> Result<(Vec<EditReport>, CollisionResponse), ApiError> {
    if edits.is_empty() {
        let live = entry.read();
        let found = match plan.query {
            Query::Continuous(tolerance) => contacts_during(&live, &[], plan, tolerance)?,
            _ => contacts_now(live.acoustic.bvh(), plan),
        };
        return Ok((Vec::new(), answer(entry, &live, plan, found)));
    }
    registry.edit_objects_around(
        entry,
        edits,
        |before, prepared| match plan.query {
            Query::Continuous(tolerance) => {
                contacts_during(before, prepared, plan, tolerance).map(Some)
            }
            _ => Ok(None),
        },
        |after, during| {
            let found = during.unwrap_or_else(|| contacts_now(after.acoustic.bvh(), plan));
            answer(entry, after, plan, found)
        },
    )
}
