//! `POST /v1/scenes/{id}/visibility`: how much of a light (a point or an
//! area source) each of a list of points (seats, listeners, sensors) sees,
//! by selective ray tracing: the direct-sound coverage of a source.

use axum::extract::{Path, State};
use axum::Json;
use frusta_api::shadows::{VisibilityRequest, VisibilityResponse};

use crate::app::AppState;
use crate::error::{ApiError, JsonBody, Problem};
use crate::routes::rays::MAX_RAYS;
use crate::routes::shadows::{check_samples, MAX_SHADOW_MAP_SIZE};

/// Body: `{"light": {"position": [x, y, z][, "shape", ...]} (or {"shape":
/// "directional", "direction": [x, y, z]}), "points":
/// [[x, y, z], ...]}` (at most 100,000 points), optionally `method`,
/// `shadow_map_size`, `samples` and `seed`.
#[utoipa::path(post, path = "/v1/scenes/{id}/visibility", tag = "queries",
    params(("id" = String, Path, description = "Scene id")),
    request_body = VisibilityRequest,
    responses(
        (status = 200, body = VisibilityResponse),
        (status = 404, body = Problem, content_type = "application/problem+json"),
        (status = 413, body = Problem, content_type = "application/problem+json"),
        (status = 422, body = Problem, content_type = "application/problem+json"),
        (status = 503, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn check(
    State(state): State<AppState>,
    Path(id): Path<String>,
    JsonBody(request): JsonBody<VisibilityRequest>,
) -> Result<Json<VisibilityResponse>, ApiError> {
    let entry = state.registry().get(&id)?;
    if request.points.len() > MAX_RAYS {
        return Err(ApiError::TooManyRays {
            count: request.points.len(),
            max: MAX_RAYS,
        });
    }
    let (light, points, options) = request.engine().map_err(ApiError::Invalid)?;
    check_samples(&light, points.len() as u64, options.samples)?;
    if options.shadow_map_size > MAX_SHADOW_MAP_SIZE {
        return Err(ApiError::LimitExceeded(format!(
            "shadow_map_size {} exceeds {MAX_SHADOW_MAP_SIZE}",
            options.shadow_map_size
        )));
    }
    let cache = state.clone();
    let (revision, answer) = state
        .queries()
        .run(move || {
            let live = entry.read();
            let (world, revision) = (live.acoustic.bvh(), live.acoustic.revision());
            let shadows = cache.shadow_cache().get(&live.acoustic);
            (
                revision,
                shadows.visibility(world, &light, &points, &options),
            )
        })
        .await?;
    let answer = answer.map_err(ApiError::from_engine)?;
    Ok(Json(VisibilityResponse::new(revision, &answer)))
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;
    use serde_json::json;

    /// 40 points in a row behind the box scene's panel (it stands in
    /// x = 4, y 1..2, z 0.5..2) asked about `light` with 16 samples,
    /// selectively and by full ray tracing, which must agree.
    async fn behind_the_panel(light: serde_json::Value) -> (TestServer, serde_json::Value) {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let points: Vec<[f32; 3]> = (0..40).map(|i| [6.0, 0.05 + 0.1 * i as f32, 1.2]).collect();
        let body = |method: &str| {
            json!({"light": light, "points": points, "method": method, "samples": 4}).to_string()
        };
        let (status, _, selective) = server
            .send(post_json("/v1/scenes/box/visibility", &body("selective")))
            .await;
        assert_eq!(status, StatusCode::OK, "{selective}");
        let (_, _, full) = server
            .send(post_json("/v1/scenes/box/visibility", &body("full")))
            .await;
        assert_eq!(selective["fraction"], full["fraction"]);
        assert_eq!(selective["visible"], full["visible"]);
        assert_eq!(selective["stats"]["receivers"], 40);
        (server, full)
    }

    #[tokio::test]
    async fn the_panel_hides_the_points_behind_it() {
        let (server, full) = behind_the_panel(json!({"position": [2, 1.5, 1.2]})).await;
        let visible: Vec<bool> = serde_json::from_value(full["visible"].clone()).unwrap();
        // Seen from the light, the panel hides y 0.5 to 2.5 at x = 6.
        assert!(
            visible.iter().any(|v| !v) && visible[0] && visible[39],
            "{visible:?}"
        );
        let bad =
            json!({"light": {"position": [2, 1.5, 1.2]}, "points": [[0, 0, 1e39]]}).to_string();
        let (status, _, _) = server
            .send(post_json("/v1/scenes/box/visibility", &bad))
            .await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        let (status, _, _) = server
            .send(post_json("/v1/scenes/nothing/visibility", &bad))
            .await;
        assert_eq!(status, StatusCode::NOT_FOUND);
    }

    #[tokio::test]
    async fn a_spot_light_reaches_only_the_points_in_its_cone() {
        // Aimed past the panel's lower end at y = 0.3, 8 degrees wide:
        // at x = 6 it reaches y up to about 0.9, and the panel hides
        // y 0.5 and up; without the cone the last point would be lit.
        let spot = json!({"shape": "spot", "position": [2, 1.5, 1.2],
                          "direction": [4, -1.2, 0], "half_angle_deg": 8});
        let (_, full) = behind_the_panel(spot).await;
        let visible: Vec<bool> = serde_json::from_value(full["visible"].clone()).unwrap();
        assert!(visible[0] && !visible[39], "{visible:?}");
        assert!(visible.iter().filter(|v| **v).count() < 10, "{visible:?}");
    }

    #[tokio::test]
    async fn points_see_part_of_a_sphere_behind_the_panel_edge() {
        let light = json!({"position": [2, 1.5, 1.2], "shape": "sphere", "radius": 0.3});
        let (_, full) = behind_the_panel(light).await;
        let fraction: Vec<f32> = serde_json::from_value(full["fraction"].clone()).unwrap();
        assert!(
            fraction.iter().any(|f| *f > 0.0 && *f < 1.0),
            "{fraction:?}"
        );
        assert!(
            fraction.contains(&0.0) && fraction.contains(&1.0),
            "{fraction:?}"
        );
        let visible: Vec<bool> = serde_json::from_value(full["visible"].clone()).unwrap();
        assert!(visible
            .iter()
            .zip(&fraction)
            .all(|(v, f)| *v == (*f == 1.0)));
    }

    #[tokio::test]
    async fn too_many_points_are_refused_and_bad_maps_are_422() {
        let server = TestServer::new();
        let points = vec![[1.0f32, 1.0, 1.0]; crate::routes::rays::MAX_RAYS + 1];
        let body = json!({"light": {"position": [2, 1.5, 1.2]}, "points": points}).to_string();
        let (status, _, problem) = server
            .send(post_json("/v1/scenes/shoebox/visibility", &body))
            .await;
        assert_eq!(status, StatusCode::PAYLOAD_TOO_LARGE, "{problem}");
        let body = json!({"light": {"position": [2, 1.5, 1.2]}, "points": [[1, 1, 1]], "shadow_map_size": 1024});
        let (status, _, _) = server
            .send(post_json(
                "/v1/scenes/shoebox/visibility",
                &body.to_string(),
            ))
            .await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    }
}
