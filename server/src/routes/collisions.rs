//! `POST /v1/scenes/{id}/collisions`: discrete, proximity and continuous
//! collision queries on the scene's hierarchies, optionally with moves
//! applied in the same step (stored like object edits).

use std::collections::HashSet;

use axum::extract::{Path, State};
use axum::{Extension, Json};
use frusta_api::collisions::{
    CollisionKind, CollisionRequest, CollisionResponse, ObjectMove, TriangleContact, TriangleRef,
};
use frusta_api::objects::ObjectPatch;
use frusta_engine::bvh::SceneBvh;
use frusta_engine::collision::continuous::{
    self_sweep_contacts, sweep_contacts, CcdOptions, EndPose, Sweep,
};
use frusta_engine::collision::{object_contacts, object_proximity, self_contacts, Contact};

use crate::app::AppState;
use crate::auth::Caller;
use crate::error::{ApiError, JsonBody, Problem};
use crate::registry::{LiveScene, ObjectEdit, PreparedEdit, SceneEntry};
use crate::routes::objects::{edit_of, object_index};

/// Contacts listed when the request does not say.
const DEFAULT_MAX_CONTACTS: usize = 1_000;
/// Most contacts one answer lists.
pub const MAX_CONTACTS: usize = 100_000;
/// Most pairs, self objects or moves in one request.
const MAX_ITEMS: usize = 4096;

/// What to test, with objects resolved to indices.
struct Plan {
    query: Query,
    pairs: Vec<(u32, u32)>,
    selves: Vec<u32>,
}

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

fn plan(entry: &SceneEntry, request: &CollisionRequest) -> Result<Plan, ApiError> {
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
        query,
        pairs,
        selves,
    })
}

/// The moves as object edits, each object at most once.
fn edits(entry: &SceneEntry, moves: &[ObjectMove]) -> Result<Vec<(usize, ObjectEdit)>, ApiError> {
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
            let patch = ObjectPatch {
                rotation: m.rotation,
                translation: m.translation,
                vertices: m.vertices.clone(),
            };
            Ok((object, edit_of(&patch)?))
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
    kind: CollisionKind,
    mut found: Vec<Found>,
    max: usize,
) -> CollisionResponse {
    let total = found.len();
    let earliest_time = found.iter().filter_map(|f| f.2).reduce(f64::min);
    found.truncate(max);
    let name = |(object, triangle): (u32, u32)| TriangleRef {
        object: entry.object_names[object as usize].clone(),
        triangle,
    };
    CollisionResponse {
        revision: live.acoustic.revision(),
        kind,
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

/// Which triangles touch, come within a distance, or meet during a
/// motion. With `moves`, the objects are moved first (and the change
/// stored), atomically with the query; a bad move changes nothing.
#[utoipa::path(post, path = "/v1/scenes/{id}/collisions", tag = "queries",
    params(("id" = String, Path, description = "Scene id")),
    request_body = CollisionRequest,
    responses((status = 200, body = CollisionResponse), (status = 404, body = Problem, content_type = "application/problem+json"),
        (status = 422, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn query(
    State(state): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
    JsonBody(request): JsonBody<CollisionRequest>,
) -> Result<Json<CollisionResponse>, ApiError> {
    let entry = state.registry().get(&id)?;
    let max = request.max_contacts.unwrap_or(DEFAULT_MAX_CONTACTS);
    if max > MAX_CONTACTS {
        return Err(invalid(
            "max_contacts",
            format!("{max} is more than {MAX_CONTACTS}"),
        ));
    }
    let plan = plan(&entry, &request)?;
    let edits = edits(&entry, &request.moves)?;
    let kind = request.kind;
    if edits.is_empty() {
        let response = state
            .queries()
            .run(move || {
                let live = entry.read();
                let found = match plan.query {
                    Query::Continuous(tolerance) => contacts_during(&live, &[], &plan, tolerance)?,
                    _ => contacts_now(live.acoustic.bvh(), &plan),
                };
                Ok::<_, ApiError>(answer(&entry, &live, kind, found, max))
            })
            .await??;
        return Ok(Json(response));
    }
    caller.may_change(&entry.meta)?;
    let job_state = state.clone();
    let response = state
        .compute()
        .run(move || {
            job_state.registry().edit_objects_around(
                &entry,
                &edits,
                |before, prepared| match plan.query {
                    Query::Continuous(tolerance) => {
                        contacts_during(before, prepared, &plan, tolerance).map(Some)
                    }
                    _ => Ok(None),
                },
                |after, during| {
                    let found = during.unwrap_or_else(|| contacts_now(after.acoustic.bvh(), &plan));
                    answer(&entry, after, kind, found, max)
                },
            )
        })
        .await??;
    let (reports, response) = response;
    for r in &reports {
        state.metrics().count_update(r.action.as_str());
    }
    Ok(Json(response))
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;
    use serde_json::{json, Value};

    /// The box room, a panel in the plane x = 4 and a small tetrahedron
    /// 0.8 m in front of it (x from 2.8 to 3.2).
    const DOC: &str = r#"{
      "materials": {"walls": {"absorption": 0.1}},
      "objects": [
        {"name": "room", "material": "walls",
         "mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3]}}},
        {"name": "panel", "material": "walls",
         "mesh": {"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2], [4, 1, 2]],
                  "triangles": [[0, 1, 2], [0, 2, 3]]}},
        {"name": "probe", "material": "walls",
         "mesh": {"vertices": [[2.8, 1.4, 1], [3.2, 1.4, 1], [3, 1.8, 1], [3, 1.5, 1.4]],
                  "triangles": [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]}}
      ]
    }"#;

    async fn server() -> TestServer {
        let server = TestServer::new();
        let (status, _, out) = server.send(post_json("/v1/scenes?id=s", DOC)).await;
        assert_eq!(status, StatusCode::CREATED, "{out}");
        server
    }

    async fn collide(server: &TestServer, body: Value) -> (StatusCode, Value) {
        let (status, _, out) = server
            .send(post_json("/v1/scenes/s/collisions", &body.to_string()))
            .await;
        (status, out)
    }

    fn objects(out: &Value) -> Vec<(String, String)> {
        out["contacts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                let name = |s: &str| c[s]["object"].as_str().unwrap().to_owned();
                (name("a"), name("b"))
            })
            .collect()
    }

    #[tokio::test]
    async fn a_move_into_the_panel_is_applied_with_the_query_and_stored() {
        let server = server().await;
        let pair = json!([["panel", "probe"]]);
        let (status, out) = collide(&server, json!({"pairs": pair})).await;
        assert_eq!(status, StatusCode::OK, "{out}");
        assert_eq!(
            (out["total"].as_u64(), out["revision"].as_u64()),
            (Some(0), Some(0))
        );
        let moved =
            json!({"pairs": pair, "moves": [{"object": "probe", "translation": [1, 0, 0]}]});
        let (status, out) = collide(&server, moved).await;
        assert_eq!(status, StatusCode::OK, "{out}");
        assert!(out["total"].as_u64().unwrap() > 0, "{out}");
        assert_eq!(out["revision"], 1);
        assert!(objects(&out)
            .iter()
            .all(|p| p == &("panel".into(), "probe".into())));
        let server = server.restart();
        let (_, _, detail) = server.send(get("/v1/scenes/s")).await;
        assert_eq!(detail["objects"][2]["translation"], json!([1.0, 0.0, 0.0]));
        // All pairs: the probe inside the room touches only the panel.
        let (_, out) = collide(&server, json!({"max_contacts": 1})).await;
        assert!(out["total"].as_u64().unwrap() > 1);
        assert_eq!(
            (out["contacts"].as_array().unwrap().len(), &out["truncated"]),
            (1, &json!(true))
        );
    }

    #[tokio::test]
    async fn a_motion_through_the_panel_meets_it_two_fifths_of_the_way() {
        let server = server().await;
        let body = json!({"kind": "continuous", "pairs": [["probe", "panel"]],
                          "moves": [{"object": "probe", "translation": [2, 0, 0]}]});
        let (status, out) = collide(&server, body).await;
        assert_eq!(status, StatusCode::OK, "{out}");
        // The probe's front (x = 3.2) reaches x = 4 after 0.8 of 2 m.
        let t = out["earliest_time"].as_f64().unwrap();
        assert!(t <= 0.4 && t > 0.4 - 1e-4, "{t}");
        assert_eq!(out["contacts"][0]["time"].as_f64(), Some(t));
        // Now past the panel: nothing touches, and staying put meets
        // nothing either.
        let (_, out) = collide(&server, json!({"pairs": [["probe", "panel"]]})).await;
        assert_eq!(out["total"], 0);
        let (_, out) = collide(&server, json!({"kind": "continuous"})).await;
        assert_eq!(
            (out["total"].as_u64(), out["revision"].as_u64()),
            (Some(0), Some(1))
        );
    }

    #[tokio::test]
    async fn proximity_reports_pairs_within_the_distance_with_it() {
        let server = server().await;
        let near = json!({"kind": "proximity", "distance": 0.9, "pairs": [["panel", "probe"]]});
        let (status, out) = collide(&server, near).await;
        assert_eq!(status, StatusCode::OK, "{out}");
        let distances: Vec<f64> = out["contacts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["distance"].as_f64().unwrap())
            .collect();
        assert!(!distances.is_empty());
        assert!(
            distances.iter().all(|d| (0.8 - 1e-6..=0.9).contains(d)),
            "{distances:?}"
        );
        let far = json!({"kind": "proximity", "distance": 0.5, "pairs": [["panel", "probe"]]});
        assert_eq!(collide(&server, far).await.1["total"], 0);
        let (_, out) = collide(&server, json!({"self": ["room", "probe"]})).await;
        assert_eq!(out["total"], 0, "closed meshes do not touch themselves");
    }

    #[tokio::test]
    async fn bad_requests_are_refused_and_change_nothing() {
        let server = server().await;
        let cases = [
            (
                json!({"kind": "proximity"}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                json!({"kind": "proximity", "distance": -1}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (json!({"distance": 1}), StatusCode::UNPROCESSABLE_ENTITY),
            (
                json!({"kind": "continuous", "tolerance": 0}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                json!({"kind": "proximity", "distance": 1, "self": ["room"]}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                json!({"pairs": [["panel", "panel"]]}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (json!({"pairs": [["panel", "door"]]}), StatusCode::NOT_FOUND),
            (
                json!({"max_contacts": 1_000_000}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                json!({"moves": [{"object": "probe"}]}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                json!({"moves": [{"object": "probe", "translation": [1e39, 0, 0]}]}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                json!({"moves": [{"object": "probe", "translation": [1, 0, 0]},
                              {"object": "probe", "translation": [2, 0, 0]}]}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            // A good move with a bad one: neither is applied.
            (
                json!({"kind": "continuous", "moves": [
                {"object": "panel", "translation": [0, 0, 1]},
                {"object": "probe", "vertices": [[0, 0, 0]]}]}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                json!({"kind": "sideways"}),
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
        ];
        for (body, expected) in cases {
            let (status, out) = collide(&server, body.clone()).await;
            assert_eq!(status, expected, "{body}: {out}");
            assert!(
                out["type"].is_string(),
                "{body}: not a problem document: {out}"
            );
        }
        let (_, _, detail) = server.send(get("/v1/scenes/s")).await;
        assert_eq!(detail["revision"], 0, "{detail}");
        assert_eq!(detail["objects"][1]["translation"], json!([0.0, 0.0, 0.0]));
    }
}
