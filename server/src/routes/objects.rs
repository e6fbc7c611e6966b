//! `PATCH /v1/scenes/{id}/objects/{object}`: move an object and/or give it
//! new vertex positions; the hierarchy is refitted or rebuilt and the
//! answer says which and how long it took.

use axum::extract::{Path, State};
use axum::{Extension, Json};
use glam::Vec3;
use serde::Deserialize;
use utoipa::ToSchema;

use crate::app::AppState;
use crate::auth::Caller;
use crate::error::{ApiError, JsonBody, Problem};
use crate::registry::{EditReport, ObjectEdit, SceneEntry};

/// Omitted parts stay as they are.
#[derive(Clone, Debug, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ObjectPatch {
    /// Quaternion `[x, y, z, w]` (normalised by the server).
    pub rotation: Option<[f32; 4]>,
    /// `[x, y, z]` in metres.
    pub translation: Option<[f32; 3]>,
    /// Every vertex's new position in the object's frame, in the mesh's
    /// vertex order (the count cannot change).
    pub vertices: Option<Vec<[f32; 3]>>,
}

impl ObjectPatch {
    pub fn to_edit(&self) -> Result<ObjectEdit, ApiError> {
        if self.rotation.is_none() && self.translation.is_none() && self.vertices.is_none() {
            return Err(ApiError::Invalid(
                "nothing to change: give rotation, translation or vertices".into(),
            ));
        }
        Ok(ObjectEdit {
            rotation: self.rotation,
            translation: self.translation,
            vertices: self
                .vertices
                .as_ref()
                .map(|v| v.iter().copied().map(Vec3::from_array).collect()),
        })
    }
}

/// An object by name, or by index when the name is all digits and no
/// object has that name.
pub fn object_index(entry: &SceneEntry, object: &str) -> Result<usize, ApiError> {
    let objects = &entry.object_names;
    objects
        .iter()
        .position(|name| name == object)
        .or_else(|| object.parse::<usize>().ok().filter(|&i| i < objects.len()))
        .ok_or_else(|| {
            ApiError::UnknownObject(format!(
                "`{object}` (the scene has {} objects)",
                objects.len()
            ))
        })
}

/// Moves or deforms one object.
#[utoipa::path(patch, path = "/v1/scenes/{id}/objects/{object}", tag = "scenes",
    params(("id" = String, Path, description = "Scene id"), ("object" = String, Path, description = "Object name or index")),
    request_body = ObjectPatch,
    responses((status = 200, body = EditReport), (status = 404, body = Problem, content_type = "application/problem+json"),
        (status = 422, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn patch(
    State(state): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path((id, object)): Path<(String, String)>,
    JsonBody(patch): JsonBody<ObjectPatch>,
) -> Result<Json<EditReport>, ApiError> {
    let entry = state.registry().get(&id)?;
    caller.may_change(&entry.meta)?;
    let edit = patch.to_edit()?;
    let job_state = state.clone();
    let report = state
        .compute()
        .run(move || {
            let index = object_index(&entry, &object)?;
            job_state.registry().edit_object(&entry, index, &edit)
        })
        .await??;
    state.metrics().count_update(report.action);
    Ok(Json(report))
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn moving_and_deforming_report_what_the_hierarchy_did() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let uri = "/v1/scenes/box/objects/panel";
        let (status, _, moved) = server
            .send(patch_json(uri, r#"{"translation": [1, 0, 0]}"#))
            .await;
        assert_eq!(status, StatusCode::OK, "{moved}");
        assert_eq!(moved["action"], "transform");
        assert_eq!(moved["revision"], 1);
        let vertices = r#"{"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2.2], [4, 1, 2.2]]}"#;
        let (status, _, deformed) = server.send(patch_json(uri, vertices)).await;
        assert_eq!(status, StatusCode::OK, "{deformed}");
        assert!(deformed["action"] == "refit" || deformed["action"] == "rebuild");
        assert_eq!(deformed["revision"], 2);
        let (_, _, detail) = server.send(get("/v1/scenes/box")).await;
        assert_eq!(
            detail["objects"][1]["translation"],
            serde_json::json!([1.0, 0.0, 0.0])
        );
        assert_eq!(detail["revision"], 2);
    }

    #[tokio::test]
    async fn bad_edits_are_problems_and_change_nothing() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let cases = [
            (
                "/v1/scenes/box/objects/panel",
                "{}",
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes/box/objects/panel",
                r#"{"rotation": [0, 0, 0, 0]}"#,
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes/box/objects/panel",
                r#"{"translation": [1e300, 0, 0]}"#,
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes/box/objects/panel",
                r#"{"vertices": [[0, 0, 0]]}"#,
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes/box/objects/panel",
                r#"{"scale": 2}"#,
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes/box/objects/panel",
                r#"{"translation": [1, 0"#,
                StatusCode::BAD_REQUEST,
            ),
            (
                "/v1/scenes/box/objects/7",
                r#"{"translation": [1, 0, 0]}"#,
                StatusCode::NOT_FOUND,
            ),
            (
                "/v1/scenes/nope/objects/panel",
                r#"{"translation": [1, 0, 0]}"#,
                StatusCode::NOT_FOUND,
            ),
        ];
        for (uri, body, expected) in cases {
            let (status, content_type, problem) = server.send(patch_json(uri, body)).await;
            assert_eq!(status, expected, "{body}: {problem}");
            assert_eq!(content_type, "application/problem+json");
        }
        let (_, _, detail) = server.send(get("/v1/scenes/box")).await;
        assert_eq!(detail["revision"], 0);
    }

    #[tokio::test]
    async fn with_api_keys_only_the_creator_may_edit() {
        let server = TestServer::with(|c| c.api_keys = vec!["alice".into(), "bob".into()]);
        let authed = |key: &str, mut r: axum::http::Request<axum::body::Body>| {
            r.headers_mut().insert(
                "authorization",
                format!("Bearer {key}").parse().expect("header"),
            );
            r
        };
        let (status, _, _) = server.send(get("/v1/scenes")).await;
        assert_eq!(status, StatusCode::UNAUTHORIZED);
        let (status, _, _) = server.send(authed("mallory", get("/v1/scenes"))).await;
        assert_eq!(status, StatusCode::UNAUTHORIZED);
        let (status, _, _) = server
            .send(authed("alice", post_json("/v1/scenes?id=box", BOX_DOC)))
            .await;
        assert_eq!(status, StatusCode::CREATED);
        let uri = "/v1/scenes/box/objects/panel";
        let body = r#"{"translation": [1, 0, 0]}"#;
        let (status, _, problem) = server.send(authed("bob", patch_json(uri, body))).await;
        assert_eq!(status, StatusCode::FORBIDDEN, "{problem}");
        let (status, _, _) = server.send(authed("bob", delete("/v1/scenes/box"))).await;
        assert_eq!(status, StatusCode::FORBIDDEN);
        let (status, _, _) = server.send(authed("alice", patch_json(uri, body))).await;
        assert_eq!(status, StatusCode::OK);
        let (status, _, _) = server.send(authed("bob", get("/v1/scenes/box"))).await;
        assert_eq!(status, StatusCode::OK, "reading is open to every key");
        let (status, _, _) = server.send(get("/healthz")).await;
        assert_eq!(status, StatusCode::OK, "probes need no key");
    }
}
