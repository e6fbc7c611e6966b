//! Collision queries on a served scene, for the collisions route and for
//! streams subscribed to collisions: the request checked and resolved to
//! object indices ([`Plan`]), then run on the scene as it is or atomically
//! with object moves ([`run`]).

use std::collections::HashSet;
use std::time::Instant;

use frusta_api::collisions::{CollisionKind, CollisionRequest, CollisionResponse};
use frusta_api::objects::{EditReport, ObjectMove};
use frusta_engine::collision::continuous::EndPose;
use frusta_engine::collision::{CollisionQuery, CollisionTest, Found};
use frusta_engine::Cancel;

use crate::config::Limits;
use crate::error::ApiError;
use crate::registry::{LiveScene, ObjectEdit, PreparedEdit, Registry, SceneEntry};
use crate::routes::objects::{edit_of, object_index};

/// Contacts listed when the request does not say.
const DEFAULT_MAX_CONTACTS: usize = 1_000;
/// Most contacts one answer lists.
pub const MAX_CONTACTS: usize = 100_000;
/// Most pairs, self objects or moves in one request.
const MAX_ITEMS: usize = 4096;

/// A request resolved to the engine's query, with objects by index.
#[derive(Clone, Debug)]
pub struct Plan {
    kind: CollisionKind,
    query: CollisionQuery,
    max_contacts: usize,
}

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
    let query = request
        .query(&entry.object_names)
        .map_err(ApiError::from_engine)?;
    Ok(Plan {
        kind: request.kind,
        query,
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

/// The prepared edits as the end poses of a step.
fn ends<'a>(live: &'a LiveScene, edits: &'a [PreparedEdit]) -> Vec<(u32, EndPose<'a>)> {
    edits
        .iter()
        .map(|e| {
            let now = &live.scene.objects[e.object].transform;
            let end = match (&e.mesh, &e.transform) {
                (Some(mesh), t) => EndPose::Deformed(mesh, t.as_ref().unwrap_or(now)),
                (None, Some(t)) => EndPose::Moved(t),
                (None, None) => EndPose::Stays,
            };
            (e.object as u32, end)
        })
        .collect()
}

fn answer(
    entry: &SceneEntry,
    live: &LiveScene,
    plan: &Plan,
    found: Vec<Found>,
) -> CollisionResponse {
    let revision = live.acoustic.revision();
    CollisionResponse::new(
        revision,
        plan.kind,
        found,
        &entry.object_names,
        plan.max_contacts,
    )
}

/// Runs `plan` on the scene as it is, or with `edits` applied and stored
/// in the same step (a continuous query sweeps from before them to after).
/// One report per edit. Blocking.
///
/// `deadline` (the compute limit of `limits` from when the request's work
/// began) and `cancel` (its client left) stop a query on the scene as it
/// is and a continuous query, which runs before the edits are stored:
/// stopped, it stores nothing. A discrete or proximity query with edits
/// runs after they are stored and is not stopped, so an answer never
/// reports an error for edits that were kept (such a query costs one pair
/// walk).
pub fn run(
    registry: &Registry,
    entry: &SceneEntry,
    plan: &Plan,
    edits: &[(usize, ObjectEdit)],
    deadline: Instant,
    cancel: Option<&Cancel>,
    limits: &Limits,
) -> Result<(Vec<EditReport>, CollisionResponse), ApiError> {
    let engine = |e| ApiError::from_engine_within(e, limits);
    let deadline = Some(deadline);
    if edits.is_empty() {
        let live = entry.read();
        let found = plan
            .query
            .run(live.acoustic.bvh(), deadline, cancel)
            .map_err(engine)?;
        return Ok((Vec::new(), answer(entry, &live, plan, found)));
    }
    // A continuous query runs before the edits (over the step they make),
    // the others after them.
    let continuous = matches!(plan.query.test, CollisionTest::Continuous { .. });
    let (reports, answered) = registry.edit_objects_around(
        entry,
        edits,
        |before, prepared| {
            continuous
                .then(|| {
                    let ends = ends(before, prepared);
                    plan.query
                        .run_during(before.acoustic.bvh(), &ends, deadline, cancel)
                })
                .transpose()
                .map_err(engine)
        },
        |after, during| {
            let found = match during {
                Some(found) => Ok(found),
                None => plan.query.run(after.acoustic.bvh(), None, None),
            };
            found.map(|found| answer(entry, after, plan, found))
        },
    )?;
    // The query was checked with the plan, so it cannot fail once the
    // edits are applied.
    Ok((reports, answered.map_err(engine)?))
}
