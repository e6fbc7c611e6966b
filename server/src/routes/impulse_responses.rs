//! `POST /v1/scenes/{id}/impulse-responses`: what each listener hears from
//! each source, as JSON (paths, ISO 3382-1 parameters) or, for one pair, as
//! a 32-bit float WAV file.

use axum::extract::{Path, State};
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use axum::Json;
use frusta_api::impulse_responses::{ImpulseResponseRequest, ImpulseResponses};
use frusta_api::schemas::Binary;
use frusta_engine::acoustics::signal::write_wav_to;
use frusta_engine::acoustics::Cancel;
use serde_json::Value;

use crate::app::AppState;
use crate::error::{ApiError, JsonBody, Problem};
use crate::simulation::{self, CancelOnDrop, IrRequest};

/// Body: `{"sources": [{"position": [x, y, z]}], "listeners": [...]}` plus
/// any simulation option (`max_order`, `sampling`, `cells`, `bands_hz`,
/// `air`, `sample_rate`, `channels`, ...), each with a default. Send
/// `Accept: audio/wav` for the samples of a single pair.
#[utoipa::path(post, path = "/v1/scenes/{id}/impulse-responses", tag = "acoustics",
    params(("id" = String, Path, description = "Scene id")),
    request_body(content = ImpulseResponseRequest),
    responses(
        (status = 200, description = "Every pair's paths, parameters and samples as JSON, or with `Accept: audio/wav` one pair's impulse response",
            content((ImpulseResponses = "application/json"), (Binary = "audio/wav"))),
        (status = 404, body = Problem, content_type = "application/problem+json"),
        (status = 422, body = Problem, content_type = "application/problem+json"),
        (status = 503, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn create(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    JsonBody(body): JsonBody<Value>,
) -> Result<Response, ApiError> {
    let entry = state.registry().get(&id)?;
    let request = IrRequest::from_json(body, state.limits())?;
    let wav = headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|a| a.contains("audio/wav") || a.contains("audio/x-wav"));
    if wav && request.sources.len() * request.listeners.len() != 1 {
        return Err(ApiError::NotAcceptable(
            "a WAV file holds one impulse response: ask for one source and one listener, or for JSON".into(),
        ));
    }
    let cancel = Cancel::new();
    let _cancel_on_drop = CancelOnDrop(cancel.clone());
    let job = state.clone();
    let (revision, responses) = state
        .compute()
        .run(move || {
            simulation::run(
                &entry,
                &request,
                None,
                job.limits().compute_deadline(),
                Some(&cancel),
                job.limits(),
                job.lod_cache(),
            )
        })
        .await??;
    let metrics = state.metrics();
    metrics.impulse_responses.inc_by(responses.len() as u64);
    if let Some(first) = responses.first() {
        metrics.frusta.inc_by(first.stats.frusta);
    }
    if wav {
        let mut bytes = std::io::Cursor::new(Vec::new());
        write_wav_to(&mut bytes, &responses[0].impulse_response).map_err(ApiError::from_engine)?;
        return Ok(([(header::CONTENT_TYPE, "audio/wav")], bytes.into_inner()).into_response());
    }
    Ok(Json(ImpulseResponses {
        scene: id,
        revision,
        responses: responses.iter().map(Into::into).collect(),
    })
    .into_response())
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;
    use serde_json::{json, Value};

    const URI: &str = "/v1/scenes/shoebox/impulse-responses";

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_request_that_times_out_frees_its_worker() {
        let server = TestServer::with(|c| {
            c.limits.request_timeout_s = 1;
            c.limits.max_compute_ms = 3_600_000;
            c.limits.max_order = 16;
        });
        // About 10k nearly rigid triangles: an order-16 conservative trace
        // takes far longer than this test waits.
        let room = r#"{"objects": [{"name": "room", "material": "rigid",
            "mesh": {"box_room": {"min": [0, 0, 0], "max": [9, 7, 4], "subdivisions": 30}}}]}"#;
        let (status, _, body) = server.send(post_json("/v1/scenes?id=big", room)).await;
        assert_eq!(status, StatusCode::CREATED, "{body}");
        let workers = server.state.compute().idle_workers();
        let heavy = json!({
            "sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}],
            "max_order": 16, "sampling": 32, "cells": "conservative", "sample_rate": 8000
        })
        .to_string();
        let mut requests = tokio::task::JoinSet::new();
        for _ in 0..workers {
            let app = crate::router(server.state.clone());
            let request = post_json("/v1/scenes/big/impulse-responses", &heavy);
            requests.spawn(async move { tower::ServiceExt::oneshot(app, request).await });
        }
        while let Some(response) = requests.join_next().await {
            assert_eq!(
                response.unwrap().unwrap().status(),
                StatusCode::GATEWAY_TIMEOUT
            );
        }
        // Every worker is free again soon after, not when the traces end.
        let started = std::time::Instant::now();
        while server.state.compute().idle_workers() < workers {
            assert!(
                started.elapsed() < std::time::Duration::from_secs(20),
                "the timed-out simulations still hold {} workers",
                workers - server.state.compute().idle_workers()
            );
            tokio::time::sleep(std::time::Duration::from_millis(20)).await;
        }
    }

    #[tokio::test]
    async fn the_bundled_shoebox_answers_with_defaults() {
        let server = TestServer::new();
        let body = json!({
            "sources": [{"position": [2, 3, 1.5]}],
            "listeners": [{"position": [7, 3, 1.2]}, {"position": [5, 2, 1.7]}],
            "max_order": 2, "sample_rate": 16000
        });
        let (status, _, body) = server.send(post_json(URI, &body.to_string())).await;
        assert_eq!(status, StatusCode::OK, "{body}");
        let responses = body["responses"].as_array().expect("responses");
        assert_eq!(responses.len(), 2);
        // A closed box to order 2 has 1 + 6 + 18 image sources.
        assert_eq!(responses[0]["paths"].as_array().map(Vec::len), Some(25));
        assert_eq!(responses[1]["listener"], 1);
        assert_eq!(responses[0]["sample_rate"], 16000);
        assert!(responses[0]["frames"].as_u64() > Some(1000));
        let direct = responses[0]["paths"][0]["distance_m"]
            .as_f64()
            .expect("distance");
        assert!((direct - (25.0f64 + 0.09).sqrt()).abs() < 1e-5, "{direct}");
    }

    #[tokio::test]
    async fn the_tail_is_on_by_default_and_none_turns_it_off() {
        let server = TestServer::new();
        let ask = |tail: Value| {
            let mut body = json!({
                "sources": [{"position": [2, 3, 1.5]}],
                "listeners": [{"position": [7, 3, 1.2]}],
                "max_order": 1, "sample_rate": 8000, "bands_hz": [1000]
            });
            if !tail.is_null() {
                body["tail"] = tail;
            }
            body.to_string()
        };
        let mut frames = Vec::new();
        for (tail, rays) in [
            (Value::Null, Some(8192)),
            (json!({"rays": 500, "max_length_s": 1.5}), Some(500)),
            (json!("none"), None),
        ] {
            let (status, _, body) = server.send(post_json(URI, &ask(tail))).await;
            assert_eq!(status, StatusCode::OK, "{body}");
            let response = &body["responses"][0];
            assert_eq!(response["stats"]["tail"]["rays"].as_u64(), rays);
            frames.push(response["frames"].as_u64().unwrap_or(0));
        }
        // With a tail the response lasts into the reverberation; without,
        // it ends after the last first-order path.
        assert!(frames[0] > 8000 && frames[1] > 8000, "{frames:?}");
        assert!(frames[2] < 2000, "{frames:?}");
    }

    /// With `lod_error_m` the answer is computed on the scene simplified
    /// within it and says so, or on the exact scene, saying 0, where the
    /// bound replaces nothing. A bound that is not a distance of at least
    /// 0 is a 422 naming it.
    #[tokio::test]
    async fn levels_of_detail_are_reported_and_bad_bounds_refused() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let post = |body: Value| post_json("/v1/scenes/box/impulse-responses", &body.to_string());
        let ask = |lod: Value| {
            let mut body = json!({
                "sources": [{"position": [2, 3, 1.5]}],
                "listeners": [{"position": [7, 3, 1.2]}],
                "max_order": 2, "sample_rate": 8000, "tail": "none"
            });
            if !lod.is_null() {
                body["lod_error_m"] = lod;
            }
            post(body)
        };
        let (status, _, exact) = server.send(ask(Value::Null)).await;
        assert_eq!(status, StatusCode::OK, "{exact}");
        // At 0.5 m nothing is replaced (the panel's one node has an error
        // of about 0.9 m, the room's 6.7 m): exact, and said so. At 8 m the
        // room is one rectangle.
        let (status, _, same) = server.send(ask(json!(0.5))).await;
        assert_eq!(status, StatusCode::OK, "{same}");
        let (status, _, lod) = server.send(ask(json!(8))).await;
        assert_eq!(status, StatusCode::OK, "{lod}");
        let exact = &exact["responses"][0];
        let (same, lod) = (&same["responses"][0], &lod["responses"][0]);
        assert_eq!(exact["stats"]["lod_error_m"], 0.0);
        assert_eq!(same["stats"]["lod_error_m"], 0.0);
        assert_eq!(same["paths"], exact["paths"]);
        assert_eq!(lod["stats"]["lod_error_m"], 8.0);
        assert_ne!(lod["paths"], exact["paths"]);
        for bad in [json!(-1), json!("far"), json!(null)] {
            let body = json!({
                "sources": [{"position": [2, 3, 1.5]}],
                "listeners": [{"position": [7, 3, 1.2]}],
                "lod_error_m": bad
            });
            let (status, _, problem) = server.send(post(body)).await;
            assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{bad}: {problem}");
            assert!(
                problem["detail"].as_str().unwrap().contains("lod_error_m"),
                "{problem}"
            );
        }
    }

    #[tokio::test]
    async fn wav_for_one_pair() {
        let server = TestServer::new();
        let body = r#"{"sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}], "max_order": 1, "channels": "binaural"}"#;
        let mut request = post_json(URI, body);
        request
            .headers_mut()
            .insert("accept", "audio/wav".parse().expect("header"));
        let (status, content_type, bytes) = server.send_raw(request).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(content_type, "audio/wav");
        let reader = hound::WavReader::new(std::io::Cursor::new(bytes)).expect("WAV");
        assert_eq!(reader.spec().channels, 2);
        assert_eq!(reader.spec().sample_rate, 48_000);
    }

    #[tokio::test]
    async fn bad_requests_are_4xx_problems() {
        let server = TestServer::with(|c| {
            c.limits.max_pairs = 2;
            c.limits.max_ir_mib = 64;
        });
        let s = r#"[{"position": [2, 3, 1.5]}]"#;
        let cases = [
            (
                json!({"listeners": [{"position": [1, 1, 1]}]}).to_string(),
                "sources",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": []}}"#),
                "listeners",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": [{{"position": [1e39, 0, 0]}}]}}"#),
                "must be finite",
            ),
            (
                format!(r#"{{"sources": [{{"position": [0, 2e15, 0]}}], "listeners": {s}}}"#),
                "within 1e15 m",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "max_order": 99}}"#),
                "max_order",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "sampling": 0}}"#),
                "sampling",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "bands_hz": [440]}}"#),
                "440",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "colour": "red"}}"#),
                "colour",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "tail": {{"rayz": 10}}}}"#),
                "rayz",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "tail": "some"}}"#),
                "none",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "tail": {{"rays": 1000000}}}}"#),
                "tail.rays",
            ),
            (
                format!(r#"{{"sources": {s}, "listeners": {s}, "tail": {{"max_length_s": 0}}}}"#),
                "tail.max_length_s",
            ),
            // Refused as the length it is, before any memory bound of it.
            (
                format!(
                    r#"{{"sources": {s}, "listeners": {s}, "tail": {{"max_length_s": 1e30}}}}"#
                ),
                "tail.max_length_s",
            ),
            (
                format!(
                    r#"{{"sources": {s}, "listeners": [{{"position": [1, 1, 1]}}, {{"position": [1, 2, 1]}}, {{"position": [1, 3, 1]}}]}}"#
                ),
                "pairs",
            ),
        ];
        for (body, word) in cases {
            let (status, content_type, problem) = server.send(post_json(URI, &body)).await;
            assert_eq!(
                status,
                StatusCode::UNPROCESSABLE_ENTITY,
                "{body}: {problem}"
            );
            assert_eq!(content_type, "application/problem+json");
            let detail = problem["detail"].as_str().unwrap_or_default();
            assert!(detail.contains(word), "{detail} should name {word}");
        }
        let two = format!(
            r#"{{"sources": {s}, "listeners": [{{"position": [1, 1, 1]}}, {{"position": [1, 2, 1]}}]}}"#
        );
        let mut request = post_json(URI, &two);
        request
            .headers_mut()
            .insert("accept", "audio/wav".parse().expect("header"));
        assert_eq!(server.send(request).await.0, StatusCode::NOT_ACCEPTABLE);
    }

    #[tokio::test]
    async fn the_request_timeout_is_a_problem() {
        let server = TestServer::with(|c| c.limits.request_timeout_s = 0);
        let body = r#"{"sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}], "max_order": 6}"#;
        let (status, _, problem) = server.send(post_json(URI, body)).await;
        assert_eq!(status, StatusCode::GATEWAY_TIMEOUT, "{problem}");
        assert_eq!(problem["type"], "urn:frusta:problem:timeout");
    }

    #[tokio::test]
    async fn the_compute_limit_is_a_problem() {
        let server = TestServer::with(|c| c.limits.max_compute_ms = 0);
        let body = r#"{"sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}], "max_order": 8, "sampling": 32}"#;
        let (status, _, problem) = server.send(post_json(URI, body)).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{problem}");
        assert_eq!(problem["type"], "urn:frusta:problem:compute-limit");
    }

    /// A shoebox answer with reflections and transmissions-free paths.
    async fn answer(server: &TestServer) -> Value {
        let body = json!({
            "sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}],
            "max_order": 2, "sample_rate": 8000
        });
        let uri = "/v1/scenes/shoebox/impulse-responses";
        let (status, _, body) = server.send(post_json(uri, &body.to_string())).await;
        assert_eq!(status, axum::http::StatusCode::OK, "{body}");
        body
    }

    /// The property names of component `name` in the OpenAPI document.
    fn properties(api: &Value, name: &str) -> Vec<String> {
        let mut names: Vec<String> = api["components"]["schemas"][name]["properties"]
            .as_object()
            .unwrap_or_else(|| panic!("no schema {name}"))
            .keys()
            .cloned()
            .collect();
        names.sort();
        names
    }

    fn keys(v: &Value) -> Vec<String> {
        let mut names: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
        names.sort();
        names
    }

    #[tokio::test]
    async fn openapi_shows_the_answer_field_by_field() {
        let server = TestServer::new();
        let (_, _, api) = server.send(get("/openapi.json")).await;
        let pair = &answer(&server).await["responses"][0];
        assert_eq!(properties(&api, "PairResponse"), keys(pair));
        assert_eq!(properties(&api, "PathOut"), keys(&pair["paths"][1]));
        assert_eq!(
            properties(&api, "SurfaceOut"),
            keys(&pair["paths"][1]["surfaces"][0])
        );
        assert_eq!(
            properties(&api, "BandParametersOut"),
            keys(&pair["parameters"][0])
        );
        assert_eq!(properties(&api, "StatsOut"), keys(&pair["stats"]));
        for field in ["sources", "listeners", "max_order", "bands_hz", "air"] {
            assert!(
                properties(&api, "ImpulseResponseRequest").contains(&field.to_owned()),
                "{field}"
            );
        }
    }
}
