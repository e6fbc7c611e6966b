//! `POST /v1/scenes/{id}/collisions`: discrete, proximity and continuous
//! collision queries on the scene's hierarchies, optionally with moves
//! applied in the same step (stored like object edits).

use axum::extract::{Path, State};
use axum::{Extension, Json};
use frusta_api::collisions::{CollisionRequest, CollisionResponse};
use frusta_engine::Cancel;

use crate::app::AppState;
use crate::auth::Caller;
use crate::collide;
use crate::error::{ApiError, JsonBody, Problem};
use crate::simulation::CancelOnDrop;

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
    let plan = collide::plan(&entry, &request)?;
    let edits = collide::edits(&entry, &request.moves)?;
    let lane = if edits.is_empty() {
        state.queries()
    } else {
        caller.may_change(&entry.meta)?;
        state.compute()
    };
    let cancel = Cancel::new();
    let _cancel_on_drop = CancelOnDrop(cancel.clone());
    let job_state = state.clone();
    let (reports, response) = lane
        .run(move || {
            let limits = job_state.limits();
            let deadline = limits.compute_deadline();
            let registry = job_state.registry();
            collide::run(
                registry,
                &entry,
                &plan,
                &edits,
                deadline,
                Some(&cancel),
                limits,
            )
        })
        .await??;
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
        // Where they meet lies in the panel's plane, x = 4.
        for c in out["contacts"].as_array().unwrap() {
            let points = c["points"].as_array().unwrap();
            assert!(!points.is_empty() && points.len() <= 2, "{c}");
            let on_panel = |p: &Value| (p[0].as_f64().unwrap() - 4.0).abs() < 1e-5;
            assert!(points.iter().all(on_panel), "{c}");
        }
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
    async fn a_query_past_the_compute_limit_is_refused_and_its_moves_not_stored() {
        let server = TestServer::with(|c| c.limits.max_compute_ms = 0);
        let (status, _, out) = server.send(post_json("/v1/scenes?id=s", DOC)).await;
        assert_eq!(status, StatusCode::CREATED, "{out}");
        let (status, problem) = collide(&server, json!({})).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{problem}");
        assert_eq!(problem["type"], "urn:frusta:problem:compute-limit");
        let body = json!({"kind": "continuous", "pairs": [["probe", "panel"]],
                          "moves": [{"object": "probe", "translation": [2, 0, 0]}]});
        let (status, problem) = collide(&server, body).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{problem}");
        let (_, _, detail) = server.send(get("/v1/scenes/s")).await;
        assert_eq!(detail["revision"], 0, "{detail}");
    }

    /// A client that left (its request dropped, or its stream closed)
    /// cancels a running query: it stops and stores none of its moves.
    /// And a query stopped by a deadline that began before it (a stream's
    /// collision query shares its update's limit with the simulation)
    /// names the configured limit, not what was left of it.
    #[tokio::test]
    async fn a_cancelled_query_stores_nothing_and_limits_name_the_configured_one() {
        use frusta_api::collisions::CollisionRequest;
        use frusta_engine::Cancel;
        use std::time::{Duration, Instant};

        use crate::collide;
        use crate::error::ApiError;

        let server = server().await;
        let state = &server.state;
        let entry = state.registry().get("s").expect("uploaded");
        let request: CollisionRequest =
            serde_json::from_value(json!({"kind": "continuous", "pairs": [["probe", "panel"]],
                   "moves": [{"object": "probe", "translation": [2, 0, 0]}]}))
            .expect("a request");
        let plan = collide::plan(&entry, &request).expect("plan");
        let edits = collide::edits(&entry, &request.moves).expect("edits");
        let (registry, limits) = (state.registry(), state.limits());
        let cancel = Cancel::new();
        cancel.cancel();
        let later = Instant::now() + Duration::from_secs(3600);
        let run = |deadline, cancel| {
            collide::run(registry, &entry, &plan, &edits, deadline, cancel, limits)
        };
        let left = run(later, Some(&cancel));
        assert!(matches!(left, Err(ApiError::Internal(_))), "{left:?}");
        let past = run(Instant::now() - Duration::from_millis(5), None);
        assert!(
            matches!(past, Err(ApiError::ComputeLimit { limit_ms }) if limit_ms == limits.max_compute_ms),
            "{past:?}"
        );
        let (_, _, detail) = server.send(get("/v1/scenes/s")).await;
        assert_eq!(detail["revision"], 0, "{detail}");
        let (reports, answer) = run(later, None).expect("runs");
        assert_eq!((reports.len(), answer.revision), (1, 1));
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
