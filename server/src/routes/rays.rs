//! Batched ray queries against one scene. Directions are normalised, so
//! `t` and `max_distance` are distances in scene units (metres).

use axum::extract::{Path, State};
use axum::Json;
use frusta_api::rays::{HitOutput, LodInput, Mode, RayInput, RaysRequest, RaysResponse};
use frusta_engine::bvh::lod::{Cone, LodOptions};
use frusta_engine::geometry::Ray;
use frusta_engine::query::SceneHit;
use frusta_engine::scene::Scene;
use glam::Vec3;

use crate::app::AppState;
use crate::error::{ApiError, JsonBody, Problem};

/// Upper bound on rays per request, so one request cannot monopolise the
/// compute pool or memory.
pub const MAX_RAYS: usize = 100_000;

/// Room for [`MAX_RAYS`] rays written out verbosely; axum's 2 MB default
/// would reject batches well below the ray limit.
pub const BODY_LIMIT: usize = 32 * 1024 * 1024;

/// A hit with its object's and material's names, and the error of the
/// level of detail it met when the request asked for them.
fn hit_output(scene: &Scene, hit: &SceneHit, lod_error_m: Option<f32>) -> HitOutput {
    let name_of = |names: Option<&String>| names.cloned().unwrap_or_default();
    HitOutput {
        t: hit.t,
        object: hit.object,
        object_name: name_of(scene.objects.get(hit.object as usize).map(|o| &o.name)),
        triangle: hit.triangle,
        point: hit.point.to_array(),
        normal: hit.normal.to_array(),
        material: name_of(scene.materials.get(hit.material as usize).map(|m| &m.name)),
        lod_error_m,
    }
}

/// The engine's options for a request's `lod`; closest hits only.
fn lod_options(lod: &LodInput, mode: Mode) -> Result<LodOptions, ApiError> {
    let invalid = |field: &str, reason: &str| ApiError::Invalid(format!("lod.{field} {reason}"));
    if mode != Mode::Closest {
        return Err(ApiError::Invalid(
            "lod applies to closest hits: drop it or use \"mode\": \"closest\"".into(),
        ));
    }
    if !(lod.max_error_m.is_finite() && lod.max_error_m >= 0.0) {
        return Err(invalid("max_error_m", "must be finite and non-negative"));
    }
    let cone = match (lod.cone_angle, lod.cone_spread_m) {
        (None, None) => None,
        (angle, spread) => {
            let (angle, spread) = (angle.unwrap_or(0.0), spread.unwrap_or(0.0));
            if !(angle.is_finite() && (0.0..=1.0).contains(&angle)) {
                return Err(invalid("cone_angle", "must be between 0 and 1"));
            }
            if !(spread.is_finite() && spread >= 0.0) {
                return Err(invalid("cone_spread_m", "must be finite and non-negative"));
            }
            Some(Cone { spread, angle })
        }
    };
    Ok(LodOptions {
        max_error: lod.max_error_m,
        cone,
    })
}

/// The engine silently misses invalid rays; a client sending one has a
/// bug, so it is told which ray and why instead.
fn ray_of(input: &RayInput, index: usize) -> Result<Ray, ApiError> {
    let invalid = |reason| ApiError::InvalidRay { index, reason };
    let origin = Vec3::from_array(input.origin);
    if !origin.is_finite() {
        return Err(invalid("origin must be finite"));
    }
    let direction = Vec3::from_array(input.direction)
        .try_normalize()
        .ok_or_else(|| invalid("direction must be finite and non-zero"))?;
    let max_distance = match input.max_distance {
        None => f32::INFINITY,
        Some(d) if d > 0.0 && d.is_finite() => d,
        Some(_) => return Err(invalid("max_distance must be finite and positive")),
    };
    Ok(Ray::new(origin, direction).with_range(0.0, max_distance))
}

/// Traces a batch of rays: the closest hit of each, or whether anything
/// blocks it (`"mode": "any"`).
#[utoipa::path(post, path = "/v1/scenes/{id}/rays", tag = "queries",
    params(("id" = String, Path, description = "Scene id")),
    request_body = RaysRequest,
    responses((status = 200, body = RaysResponse), (status = 413, body = Problem, content_type = "application/problem+json"),
        (status = 422, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn trace(
    State(state): State<AppState>,
    Path(id): Path<String>,
    JsonBody(request): JsonBody<RaysRequest>,
) -> Result<Json<RaysResponse>, ApiError> {
    let entry = state.registry().get(&id)?;
    if request.rays.len() > MAX_RAYS {
        return Err(ApiError::TooManyRays {
            count: request.rays.len(),
            max: MAX_RAYS,
        });
    }
    let rays = request
        .rays
        .iter()
        .enumerate()
        .map(|(i, r)| ray_of(r, i))
        .collect::<Result<Vec<_>, _>>()?;
    let lod = request
        .lod
        .as_ref()
        .map(|l| lod_options(l, request.mode))
        .transpose()?;
    let response = state
        .queries()
        .run(move || {
            let live = entry.read();
            let bvh = live.acoustic.bvh();
            match (request.mode, lod) {
                (Mode::Closest, None) => RaysResponse::Hits(
                    bvh.closest_hits(&rays)
                        .iter()
                        .map(|h| h.as_ref().map(|h| hit_output(&live.scene, h, None)))
                        .collect(),
                ),
                (_, Some(lod)) => RaysResponse::Hits(
                    bvh.closest_hits_lod(&rays, &lod)
                        .iter()
                        .map(|h| {
                            h.as_ref()
                                .map(|(h, error)| hit_output(&live.scene, h, Some(*error)))
                        })
                        .collect(),
                ),
                (Mode::Any, None) => RaysResponse::Occluded(bvh.any_hits(&rays)),
            }
        })
        .await?;
    Ok(Json(response))
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;
    use serde_json::json;

    const SHOEBOX_RAYS: &str = "/v1/scenes/shoebox/rays";

    #[tokio::test]
    async fn ray_from_inside_the_shoebox_hits_the_far_wall() {
        // The room spans x in [0, 10]; from x = 2 along +x (unnormalised)
        // the wall at x = 10 is 8 m away.
        let body = r#"{"rays":[{"origin":[2,3,1.5],"direction":[5,0,0]}]}"#;
        let server = TestServer::new();
        let (status, _, body) = server.send(post_json(SHOEBOX_RAYS, body)).await;
        assert_eq!(status, StatusCode::OK);
        let hit = &body["hits"][0];
        assert!((hit["t"].as_f64().expect("t") - 8.0).abs() < 1e-4, "{hit}");
        assert_eq!(hit["object_name"], "room");
        assert_eq!(hit["material"], "walls");
        assert!((hit["point"][0].as_f64().expect("x") - 10.0).abs() < 1e-4);
        // Room surfaces face into the air, so back towards the origin.
        assert!((hit["normal"][0].as_f64().expect("nx") + 1.0).abs() < 1e-4);
    }

    #[tokio::test]
    async fn max_distance_and_any_mode() {
        let body = json!({
            "mode": "any",
            "rays": [
                { "origin": [2, 3, 1.5], "direction": [1, 0, 0], "max_distance": 5 },
                { "origin": [2, 3, 1.5], "direction": [1, 0, 0], "max_distance": 9 },
            ]
        });
        let server = TestServer::new();
        let (status, _, body) = server
            .send(post_json(SHOEBOX_RAYS, &body.to_string()))
            .await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(body, json!({ "occluded": [false, true] }));
    }

    #[tokio::test]
    async fn levels_of_detail_report_their_error_and_bound_zero_is_exact() {
        // Walls of 16 x 16 quads: flat, so their planes are the walls.
        let server = TestServer::new();
        let room = r#"{"objects": [{"name": "room", "material": "plaster",
            "mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3], "subdivisions": 16}}}]}"#;
        let (status, _, body) = server.send(post_json("/v1/scenes?id=room", room)).await;
        assert_eq!(status, StatusCode::CREATED, "{body}");
        let rays = json!([
            { "origin": [2, 3, 1.5], "direction": [1, 0.1, 0.05] },
            { "origin": [2, 3, 1.5], "direction": [0.3, 1, 0.0] },
        ]);
        let ask = |lod: serde_json::Value| {
            let body = json!({ "rays": rays, "lod": lod }).to_string();
            server.send(post_json("/v1/scenes/room/rays", &body))
        };
        let (status, _, exact) = server
            .send(post_json(
                "/v1/scenes/room/rays",
                &json!({ "rays": rays }).to_string(),
            ))
            .await;
        assert_eq!(status, StatusCode::OK);
        assert!(exact["hits"][0].get("lod_error_m").is_none(), "{exact}");
        // Bound 0: the exact hits, each saying it took no error.
        let (status, _, zero) = ask(json!({ "max_error_m": 0 })).await;
        assert_eq!(status, StatusCode::OK, "{zero}");
        for (z, e) in zero["hits"]
            .as_array()
            .unwrap()
            .iter()
            .zip(exact["hits"].as_array().unwrap())
        {
            assert_eq!(z["t"], e["t"]);
            assert_eq!(z["triangle"], e["triangle"]);
            assert_eq!(z["lod_error_m"], 0.0);
        }
        // A coarse bound meets the wall's plane: the same distance, within
        // the error it reports.
        let (status, _, coarse) = ask(json!({ "max_error_m": 2, "cone_angle": 1 })).await;
        assert_eq!(status, StatusCode::OK, "{coarse}");
        for (c, e) in coarse["hits"]
            .as_array()
            .unwrap()
            .iter()
            .zip(exact["hits"].as_array().unwrap())
        {
            let error = c["lod_error_m"].as_f64().unwrap();
            assert!(error > 0.0 && error < 2.0, "{c}");
            let moved = (c["t"].as_f64().unwrap() - e["t"].as_f64().unwrap()).abs();
            assert!(moved <= 1e-3, "{c} against {e}");
        }
    }

    #[tokio::test]
    async fn bad_levels_of_detail_are_422_problems() {
        let server = TestServer::new();
        let ray = json!([{ "origin": [2, 3, 1.5], "direction": [1, 0, 0] }]);
        for (lod, mode) in [
            (json!({ "max_error_m": -1 }), "closest"),
            (json!({ "max_error_m": 0.1, "cone_angle": 2 }), "closest"),
            (json!({ "cone_spread_m": -0.5 }), "closest"),
            (json!({ "max_error_m": 0.1 }), "any"),
        ] {
            let body = json!({ "rays": ray, "lod": lod, "mode": mode }).to_string();
            let (status, content_type, problem) = server.send(post_json(SHOEBOX_RAYS, &body)).await;
            assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{lod}: {problem}");
            assert_eq!(content_type, "application/problem+json");
            assert!(
                problem["detail"].as_str().unwrap().contains("lod"),
                "{problem}"
            );
        }
    }

    #[tokio::test]
    async fn a_miss_is_null() {
        let body = r#"{"rays":[{"origin":[20,3,1.5],"direction":[1,0,0]}]}"#;
        let server = TestServer::new();
        let (status, _, body) = server.send(post_json(SHOEBOX_RAYS, body)).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(body, json!({ "hits": [null] }));
    }

    #[tokio::test]
    async fn zero_direction_is_rejected_with_its_index() {
        let body = json!({ "rays": [
            { "origin": [1, 1, 1], "direction": [1, 0, 0] },
            { "origin": [1, 1, 1], "direction": [0, 0, 0] },
        ]});
        let server = TestServer::new();
        let (status, content_type, body) = server
            .send(post_json(SHOEBOX_RAYS, &body.to_string()))
            .await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        assert_eq!(content_type, "application/problem+json");
        assert_eq!(body["ray_index"], 1);
        assert_eq!(body["status"], 422);
    }

    #[tokio::test]
    async fn overflowing_direction_is_rejected() {
        // 1e300 fits in JSON but is infinite as f32.
        let body = r#"{"rays":[{"origin":[1,1,1],"direction":[1e300,0,0]}]}"#;
        let server = TestServer::new();
        let (status, _, body) = server.send(post_json(SHOEBOX_RAYS, body)).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        assert_eq!(body["ray_index"], 0);
    }

    #[tokio::test]
    async fn malformed_json_is_a_400_problem() {
        let server = TestServer::new();
        let (status, content_type, body) =
            server.send(post_json(SHOEBOX_RAYS, "{\"rays\": [")).await;
        assert_eq!(status, StatusCode::BAD_REQUEST);
        assert_eq!(content_type, "application/problem+json");
        assert_eq!(body["type"], "urn:frusta:problem:bad-body");
    }

    #[tokio::test]
    async fn wrong_shape_is_a_422_problem() {
        let body = r#"{"rays":[{"origin":[1,1],"direction":[1,0,0]}]}"#;
        let server = TestServer::new();
        let (status, content_type, _) = server.send(post_json(SHOEBOX_RAYS, body)).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        assert_eq!(content_type, "application/problem+json");
    }

    #[tokio::test]
    async fn too_many_rays_is_a_413_problem() {
        let ray = r#"{"origin":[1,1,1],"direction":[1,0,0]}"#;
        let rays = vec![ray; super::MAX_RAYS + 1].join(",");
        let body = format!(r#"{{"rays":[{rays}]}}"#);
        let server = TestServer::new();
        let (status, content_type, body) = server.send(post_json(SHOEBOX_RAYS, &body)).await;
        assert_eq!(status, StatusCode::PAYLOAD_TOO_LARGE);
        assert_eq!(content_type, "application/problem+json");
        assert_eq!(body["type"], "urn:frusta:problem:too-many-rays");
    }

    #[tokio::test]
    async fn rays_into_an_unknown_scene_are_a_404() {
        let body = r#"{"rays":[]}"#;
        let server = TestServer::new();
        let (status, _, _) = server
            .send(post_json("/v1/scenes/atlantis/rays", body))
            .await;
        assert_eq!(status, StatusCode::NOT_FOUND);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn rays_are_answered_while_every_simulation_worker_is_busy() {
        let server = TestServer::new();
        // Long jobs hold every worker of the simulation lane (and queue).
        let mut release = Vec::new();
        let mut held = Vec::new();
        for _ in 0..8 {
            let (tx, rx) = std::sync::mpsc::channel::<()>();
            release.push(tx);
            let pool = server.state.compute().clone();
            held.push(tokio::spawn(async move {
                pool.run(move || rx.recv().is_ok()).await
            }));
        }
        while server.state.compute().idle_workers() > 0 {
            tokio::task::yield_now().await;
        }
        let body = r#"{"rays":[{"origin":[1,1,1],"direction":[1,0,0]}]}"#;
        let answer = tokio::time::timeout(
            std::time::Duration::from_secs(20),
            server.send(post_json(SHOEBOX_RAYS, body)),
        )
        .await;
        for tx in release {
            tx.send(()).unwrap();
        }
        for job in held {
            assert!(job.await.unwrap().unwrap());
        }
        let (status, _, _) = answer.expect("the ray query waited for the simulations");
        assert_eq!(status, StatusCode::OK);
    }
}
