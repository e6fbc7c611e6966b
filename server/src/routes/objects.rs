//! `PATCH /v1/scenes/{id}/objects/{object}`: move an object and/or give it
//! new vertex positions; the hierarchy is refitted or rebuilt and the
//! answer says which and how long it took.

use axum::body::Body;
use axum::extract::{Path, State};
use axum::http::HeaderMap;
use axum::{Extension, Json};
use frusta_api::collisions::object_by_name;
use frusta_api::objects::{EditReport, ObjectPatch};
use frusta_api::schemas::Binary;
use glam::Vec3;

use crate::app::AppState;
use crate::auth::Caller;
use crate::error::{ApiError, Problem};
use crate::registry::{ObjectEdit, SceneEntry};
use crate::routes::large_body;

/// The edit a patch asks for; a patch that changes nothing is refused.
pub fn edit_of(patch: &ObjectPatch) -> Result<ObjectEdit, ApiError> {
    if patch.rotation.is_none() && patch.translation.is_none() && patch.vertices.is_none() {
        return Err(ApiError::Invalid(
            "nothing to change: give rotation, translation or vertices".into(),
        ));
    }
    Ok(ObjectEdit {
        rotation: patch.rotation,
        translation: patch.translation,
        vertices: patch
            .vertices
            .as_ref()
            .map(|v| v.iter().copied().map(Vec3::from_array).collect()),
    })
}

/// Vertex positions sent as little-endian `f32` triples.
fn binary_vertices(bytes: &[u8]) -> Result<ObjectEdit, ApiError> {
    if bytes.is_empty() || bytes.len() % 12 != 0 {
        return Err(ApiError::Invalid(format!(
            "a binary edit is whole vertices of three little-endian f32 (12 bytes each); got {} bytes",
            bytes.len()
        )));
    }
    let vertices = bytes
        .chunks_exact(12)
        .map(|v| {
            let c = |i: usize| f32::from_le_bytes([v[i], v[i + 1], v[i + 2], v[i + 3]]);
            Vec3::new(c(0), c(4), c(8))
        })
        .collect();
    Ok(ObjectEdit {
        vertices: Some(vertices),
        ..Default::default()
    })
}

/// An object by name, or by index when the name is all digits and no
/// object has that name.
pub fn object_index(entry: &SceneEntry, object: &str) -> Result<usize, ApiError> {
    object_by_name(&entry.object_names, object)
        .map(|i| i as usize)
        .map_err(ApiError::from_engine)
}

/// Largest edit body: 64 MiB, about 1.5M vertices as JSON or 5.5M as
/// binary (axum's default of 2 MiB held about 80k as JSON).
pub const BODY_LIMIT: usize = 64 << 20;

/// Moves or deforms one object. Besides JSON, the body may be the new
/// vertex positions alone as `application/octet-stream`: little-endian
/// `f32` triples in the mesh's vertex order, a quarter of the JSON's size
/// and nothing to parse.
#[utoipa::path(patch, path = "/v1/scenes/{id}/objects/{object}", tag = "scenes",
    params(("id" = String, Path, description = "Scene id"), ("object" = String, Path, description = "Object name or index")),
    request_body(description = "JSON, or the vertex positions alone as application/octet-stream (little-endian f32 x, y, z per vertex)",
        content((ObjectPatch = "application/json"), (Binary = "application/octet-stream"))),
    responses((status = 200, body = EditReport), (status = 404, body = Problem, content_type = "application/problem+json"),
        (status = 422, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn patch(
    State(state): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path((id, object)): Path<(String, String)>,
    headers: HeaderMap,
    body: Body,
) -> Result<Json<EditReport>, ApiError> {
    let entry = state.registry().get(&id)?;
    caller.may_change(&entry.meta)?;
    let media_type = large_body::media_type(&headers, "");
    if !matches!(
        media_type.as_str(),
        "application/json" | "application/octet-stream"
    ) {
        return Err(ApiError::UnsupportedMediaType(format!(
            "cannot read `{media_type}`: send application/json or application/octet-stream (vertices)"
        )));
    }
    let body = large_body::read(&state, &headers, body, BODY_LIMIT).await?;
    let job_state = state.clone();
    let report = state
        .compute()
        .run(move || {
            // Parsed here, not on the async runtime: an edit can be 64 MiB.
            let edit = if media_type == "application/json" {
                let Json(patch) = Json::<ObjectPatch>::from_bytes(&body.bytes)?;
                edit_of(&patch)?
            } else {
                binary_vertices(&body.bytes)?
            };
            let index = object_index(&entry, &object)?;
            job_state.registry().edit_object(&entry, index, &edit)
        })
        .await??;
    state.metrics().count_update(report.action.as_str());
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
                r#"{"translation": [0, -3e38, 0]}"#,
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

    fn octet_patch(uri: &str, body: Vec<u8>) -> axum::http::Request<axum::body::Body> {
        axum::http::Request::patch(uri)
            .header("content-type", "application/octet-stream")
            .body(axum::body::Body::from(body))
            .unwrap()
    }

    #[tokio::test]
    async fn large_meshes_deform_as_json_or_as_binary() {
        let server = TestServer::new();
        // About 100k vertices: over 2 MiB as JSON.
        let doc = r#"{"objects": [{"name": "room", "dynamic": true, "material": "concrete",
            "mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3], "subdivisions": 130}}}]}"#;
        let (status, _, created) = server.send(post_json("/v1/scenes?id=big", doc)).await;
        assert_eq!(status, StatusCode::CREATED, "{created}");
        let entry = server.state.registry().get("big").unwrap();
        let positions = entry.read().scene.objects[0].mesh.positions().to_vec();
        assert!(positions.len() > 80_000, "{}", positions.len());
        let uri = "/v1/scenes/big/objects/room";
        let scaled: Vec<[f32; 3]> = positions.iter().map(|p| (*p * 1.01).to_array()).collect();
        let json = serde_json::json!({ "vertices": scaled }).to_string();
        assert!(json.len() > 2 << 20);
        let (status, _, report) = server.send(patch_json(uri, &json)).await;
        assert_eq!(status, StatusCode::OK, "{report}");
        let binary: Vec<u8> = positions
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let (status, _, report) = server.send(octet_patch(uri, binary)).await;
        assert_eq!(status, StatusCode::OK, "{report}");
        assert_eq!(report["revision"], 2);
        assert_eq!(
            entry.read().scene.objects[0].mesh.positions(),
            &positions[..]
        );
        // Whole vertices only, of the right count, in a known media type.
        let (status, _, _) = server.send(octet_patch(uri, vec![0; 13])).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        let (status, _, _) = server.send(octet_patch(uri, vec![0; 24])).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
        let text = axum::http::Request::patch(uri)
            .header("content-type", "text/csv")
            .body(axum::body::Body::from("1,2,3"))
            .unwrap();
        let (status, _, _) = server.send(text).await;
        assert_eq!(status, StatusCode::UNSUPPORTED_MEDIA_TYPE);
        assert_eq!(entry.read().acoustic.revision(), 2);
    }
}
