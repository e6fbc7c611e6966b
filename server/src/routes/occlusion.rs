//! `POST /v1/scenes/{id}/occlusion`: point-to-point visibility on the same
//! hierarchy the propagation uses.

use axum::extract::{Path, State};
use axum::Json;
use frusta_api::occlusion::{OcclusionRequest, OcclusionResponse};
use frusta_engine::geometry::Ray;
use glam::Vec3;

use crate::app::AppState;
use crate::error::{ApiError, JsonBody, Problem};
use crate::routes::rays::MAX_RAYS;

/// Ends within this fraction of the distance (plus a micrometre) are
/// ignored, so points lying on surfaces do not occlude themselves.
const END_SLACK: f32 = 1e-5;

/// Whether each pair of points sees each other.
#[utoipa::path(post, path = "/v1/scenes/{id}/occlusion", tag = "queries",
    params(("id" = String, Path, description = "Scene id")),
    request_body = OcclusionRequest,
    responses((status = 200, body = OcclusionResponse), (status = 422, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn check(
    State(state): State<AppState>,
    Path(id): Path<String>,
    JsonBody(request): JsonBody<OcclusionRequest>,
) -> Result<Json<OcclusionResponse>, ApiError> {
    let entry = state.registry().get(&id)?;
    if request.pairs.len() > MAX_RAYS {
        return Err(ApiError::TooManyRays {
            count: request.pairs.len(),
            max: MAX_RAYS,
        });
    }
    // `None`: the points coincide, which is visible by definition.
    let rays = request
        .pairs
        .iter()
        .enumerate()
        .map(|(index, p)| {
            let (from, to) = (Vec3::from_array(p.from), Vec3::from_array(p.to));
            let d = to - from;
            let length = d.length();
            if !from.is_finite() || !to.is_finite() || !length.is_finite() {
                return Err(ApiError::InvalidRay {
                    index,
                    reason: "points must be finite",
                });
            }
            let slack = length * END_SLACK + 1e-6;
            Ok((length > 2.0 * slack)
                .then(|| Ray::new(from, d / length).with_range(slack, length - slack)))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let visible = state
        .queries()
        .run(move || {
            let live = entry.read();
            let bvh = live.acoustic.bvh();
            rays.iter()
                .map(|r| r.as_ref().is_none_or(|r| !bvh.any_hit(r)))
                .collect()
        })
        .await?;
    Ok(Json(OcclusionResponse { visible }))
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;
    use serde_json::json;

    #[tokio::test]
    async fn a_panel_blocks_and_surfaces_do_not_occlude_themselves() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let body = json!({"pairs": [
            {"from": [2, 1.5, 1], "to": [6, 1.5, 1]},
            {"from": [2, 4, 1], "to": [6, 4, 1]},
            {"from": [0, 3, 1.5], "to": [10, 3, 1.5]},
            {"from": [5, 5, 1], "to": [5, 5, 1]},
        ]});
        let (status, _, out) = server
            .send(post_json("/v1/scenes/box/occlusion", &body.to_string()))
            .await;
        assert_eq!(status, StatusCode::OK, "{out}");
        assert_eq!(out["visible"], json!([false, true, true, true]));
        let nan = r#"{"pairs": [{"from": [0, 0, 0], "to": [1e39, 0, 0]}]}"#;
        let (status, _, problem) = server
            .send(post_json("/v1/scenes/box/occlusion", nan))
            .await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        assert_eq!(problem["ray_index"], 0);
    }

    #[tokio::test]
    async fn the_most_pairs_allowed_fit_in_the_body_limit() {
        let server = TestServer::new();
        let pair =
            r#"{"from": [2.123456, 1.523456, 1.023456], "to": [6.123456, 1.523456, 1.023456]}"#;
        let pairs = vec![pair; crate::routes::rays::MAX_RAYS].join(", ");
        let body = format!(r#"{{"pairs": [{pairs}]}}"#);
        assert!(body.len() > 2 << 20);
        let (status, _, out) = server
            .send(post_json("/v1/scenes/shoebox/occlusion", &body))
            .await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(
            out["visible"].as_array().unwrap().len(),
            crate::routes::rays::MAX_RAYS
        );
    }
}
