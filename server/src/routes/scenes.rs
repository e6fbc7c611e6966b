//! `/v1/scenes`: upload (JSON scene document, OBJ or glTF), list, inspect
//! and delete scenes.

use axum::body::Body;
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::{Extension, Json};
use frusta_api::scenes::{
    CreateQuery, ObjectSummary, SceneDetail, SceneList, SceneSummary, SceneUpload,
};
use frusta_api::schemas::Binary;
use frusta_engine::scene::load::{parse_gltf, parse_obj};
use frusta_engine::scene::{builtin_material, MeshSpec, Scene, SceneDocument};

use crate::app::AppState;
use crate::auth::Caller;
use crate::error::{ApiError, Problem};
use crate::registry::{now_unix_ms, SceneEntry};
use crate::routes::large_body;
use crate::store::SceneMeta;

/// A scene as the list and uploads show it.
pub fn summary(entry: &SceneEntry) -> SceneSummary {
    let live = entry.read();
    SceneSummary {
        id: entry.id.clone(),
        revision: live.acoustic.revision(),
        bundled: entry.meta.bundled,
        created_unix_ms: entry.meta.created_unix_ms,
        triangles: live.scene.triangle_count(),
        objects: live
            .scene
            .objects
            .iter()
            .enumerate()
            .map(|(index, o)| ObjectSummary {
                index,
                name: o.name.clone(),
                triangles: o.mesh.triangle_count(),
                vertices: o.mesh.positions().len(),
                dynamic: o.dynamic,
                rotation: o.transform.rotation.to_array(),
                translation: o.transform.translation.to_array(),
            })
            .collect(),
        materials: live
            .scene
            .materials
            .iter()
            .map(|m| m.name.clone())
            .collect(),
        build_ms: live.build_ms,
    }
}

/// Lists every scene.
#[utoipa::path(get, path = "/v1/scenes", tag = "scenes",
    responses((status = 200, body = SceneList)), security((), ("api_key" = [])))]
pub async fn list(State(state): State<AppState>) -> Json<SceneList> {
    let scenes = state.registry().list().iter().map(|e| summary(e)).collect();
    Json(SceneList { scenes })
}

/// One scene: objects, materials and hierarchy statistics.
#[utoipa::path(get, path = "/v1/scenes/{id}", tag = "scenes",
    params(("id" = String, Path, description = "Scene id")),
    responses((status = 200, body = SceneDetail), (status = 404, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn detail(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SceneDetail>, ApiError> {
    let entry = state.registry().get(&id)?;
    let bvh = (&entry.read().acoustic.bvh().stats()).into();
    Ok(Json(SceneDetail {
        summary: summary(&entry),
        bvh,
    }))
}

/// Uploads a scene: a JSON scene document (`scenes/README.md`; inline and
/// generated meshes, no file references), or an OBJ (`model/obj`) or glTF
/// (`model/gltf-binary`, `model/gltf+json`) mesh as one object.
#[utoipa::path(post, path = "/v1/scenes", tag = "scenes", params(CreateQuery),
    request_body(description = "A scene document, or one mesh as OBJ or glTF",
        content((SceneUpload = "application/json"), (String = "model/obj"), (Binary = "model/gltf-binary"), (Object = "model/gltf+json"))),
    responses((status = 201, body = SceneSummary),
        (status = 200, body = SceneSummary, description = "This exact upload was stored under this id before: a retry, answered with the stored scene"),
        (status = 409, body = Problem, content_type = "application/problem+json"),
        (status = 413, body = Problem, content_type = "application/problem+json"), (status = 422, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn create(
    State(state): State<AppState>,
    Extension(caller): Extension<Caller>,
    Query(query): Query<CreateQuery>,
    headers: HeaderMap,
    body: Body,
) -> Result<(StatusCode, HeaderMap, Json<SceneSummary>), ApiError> {
    let limit = state.limits().max_upload_bytes();
    let body = large_body::read(&state, &headers, body, limit).await?;
    let content_type = large_body::media_type(&headers, "application/json");
    if let Some(id) = &query.id {
        check_id(id)?;
    }
    let job_state = state.clone();
    let (status, summary) = state
        .compute()
        .run(move || {
            // The body (and its claim on the upload buffer) lives until
            // the job ends; hashing and parsing it happen here, off the
            // async runtime.
            let bytes = &body.bytes;
            let registry = job_state.registry();
            // A retry of an upload that was stored (its answer lost, or a
            // 504 that came while it finished) gets the stored scene.
            let upload_digest = digest_upload(&content_type, &query, bytes);
            let replay = |id: &str| {
                registry.get(id).ok().filter(|e| {
                    e.meta.owner == caller.key
                        && e.meta.upload_digest.as_deref() == Some(upload_digest.as_str())
                })
            };
            if let Some(entry) = query.id.as_deref().and_then(replay) {
                return Ok((StatusCode::OK, summary(&entry)));
            }
            let limits = job_state.limits();
            let scene = parse(&content_type, bytes, &query, limits.max_triangles)?;
            let triangles = scene.triangle_count();
            if triangles > limits.max_triangles {
                return Err(too_many_triangles(triangles as u64, limits.max_triangles));
            }
            let slug = match &query.id {
                Some(_) => String::new(),
                None => slug(&scene_name(bytes, &content_type)),
            };
            let max_total = limits.max_total_triangles;
            // Who sent what: a retry matches its first attempt on both.
            let upload = format!("{}\n{upload_digest}", caller.key.as_deref().unwrap_or(""));
            let reservation = match registry.reserve(
                query.id.clone(),
                &slug,
                triangles,
                max_total,
                Some(&upload),
            ) {
                // The same upload, sent twice, stored while this one parsed.
                Err(ApiError::SceneExists(id)) => {
                    return match replay(&id) {
                        Some(entry) => Ok((StatusCode::OK, summary(&entry))),
                        None => Err(ApiError::SceneExists(id)),
                    }
                }
                reservation => reservation?,
            };
            let id = reservation.id.clone();
            let meta = SceneMeta {
                owner: caller.key.clone(),
                created_unix_ms: now_unix_ms(),
                bundled: false,
                upload_digest: Some(upload_digest.clone()),
            };
            registry.create(reservation, meta, scene)?;
            Ok((StatusCode::CREATED, summary(registry.get(&id)?.as_ref())))
        })
        .await??;
    state.refresh_scene_gauges();
    let headers = location(&summary.id);
    Ok((status, headers, Json(summary)))
}

fn location(id: &str) -> HeaderMap {
    let mut headers = HeaderMap::new();
    if let Ok(location) = format!("/v1/scenes/{id}").parse() {
        headers.insert(header::LOCATION, location);
    }
    headers
}

/// What identifies an upload: its media type, query and body.
fn digest_upload(content_type: &str, query: &CreateQuery, body: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    let mut hash = Sha256::new();
    for part in [
        Some(content_type),
        query.material.as_deref(),
        query.object.as_deref(),
    ] {
        hash.update(part.unwrap_or("\u{0}").as_bytes());
        hash.update([0xff]);
    }
    hash.update(body);
    hash.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

fn parse(
    content_type: &str,
    bytes: &[u8],
    query: &CreateQuery,
    max_triangles: usize,
) -> Result<Scene, ApiError> {
    let text = || {
        std::str::from_utf8(bytes)
            .map_err(|e| ApiError::Invalid(format!("the body is not UTF-8: {e}")))
    };
    let mesh = match content_type {
        "application/json" => {
            let document = SceneDocument::parse(text()?).map_err(ApiError::from_engine)?;
            // Generated meshes are checked before they exist: a small
            // document can ask for millions of triangles.
            let bound = triangle_bound(&document);
            if bound > max_triangles as u64 {
                return Err(too_many_triangles(bound, max_triangles));
            }
            return document.build(None).map_err(ApiError::from_engine);
        }
        "model/obj" | "text/plain" => parse_obj(text()?),
        "model/gltf-binary" | "model/gltf+json" | "application/octet-stream" => {
            parse_gltf(bytes, None, max_triangles as u64)
        }
        other => {
            return Err(ApiError::UnsupportedMediaType(format!(
                "cannot read `{other}`: send application/json (scene document), model/obj or model/gltf-binary"
            )))
        }
    }
    .map_err(ApiError::from_engine)?;
    let material_name = query.material.as_deref().unwrap_or("concrete");
    let material = builtin_material(material_name)
        .ok_or_else(|| ApiError::Invalid(format!("`{material_name}` is not a library material")))?;
    Scene::single_object(query.object.as_deref().unwrap_or("mesh"), mesh, material)
        .map_err(ApiError::from_engine)
}

/// An upper bound on the triangles `document` builds (file meshes are
/// refused later, uploads cannot reference files).
fn triangle_bound(document: &SceneDocument) -> u64 {
    document
        .objects
        .iter()
        .map(|o| match &o.mesh {
            MeshSpec::Inline(m) => m.triangles.len() as u64,
            MeshSpec::BoxRoom(b) => 12u64.saturating_mul(u64::from(b.subdivisions).pow(2)),
            MeshSpec::LRoom(l) => 36u64.saturating_mul(u64::from(l.subdivisions).saturating_pow(3)),
            // Fixed: two boxes, a wall and a door.
            MeshSpec::TwoRooms(_) => 200,
            // The generator lands within a few percent of its target.
            MeshSpec::Hall(h) => h.target_triangles.saturating_add(h.target_triangles / 10),
            MeshSpec::File(_) => 0,
        })
        .fold(0, u64::saturating_add)
}

fn too_many_triangles(triangles: u64, max: usize) -> ApiError {
    ApiError::LimitExceeded(format!(
        "the scene has {triangles} triangles; this server takes at most {max}"
    ))
}

fn check_id(id: &str) -> Result<(), ApiError> {
    let valid = !id.is_empty()
        && id.len() <= 64
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if valid {
        Ok(())
    } else {
        Err(ApiError::Invalid(format!(
            "scene id {id:?} must be 1 to 64 letters, digits, `-` or `_`"
        )))
    }
}

/// The document's `name`, if the upload is a JSON document that has one
/// (read without building the rest: serde skips the other fields).
fn scene_name(bytes: &[u8], content_type: &str) -> String {
    #[derive(serde::Deserialize)]
    struct Named {
        name: Option<String>,
    }
    let name = (content_type == "application/json")
        .then(|| serde_json::from_slice::<Named>(bytes).ok())
        .flatten()
        .and_then(|n| n.name);
    name.unwrap_or_else(|| "scene".into())
}

/// `name` as an id: lower-case letters, digits and single dashes, at most
/// 48 characters (the registry appends `-2`, `-3`, ... while it is taken).
fn slug(name: &str) -> String {
    let mut slug: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect::<String>()
        .split('-')
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("-");
    slug.truncate(48);
    if slug.is_empty() {
        slug = "scene".into();
    }
    slug
}

/// Deletes a scene and its stored edits; open streams on it close.
#[utoipa::path(delete, path = "/v1/scenes/{id}", tag = "scenes",
    params(("id" = String, Path, description = "Scene id")),
    responses((status = 204), (status = 403, body = Problem, content_type = "application/problem+json"), (status = 404, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn delete(
    State(state): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    let entry = state.registry().get(&id)?;
    caller.may_change(&entry.meta)?;
    let job_state = state.clone();
    state
        .compute()
        .run(move || job_state.registry().delete(&entry))
        .await??;
    state.refresh_scene_gauges();
    Ok(StatusCode::NO_CONTENT)
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn list_shows_the_bundled_shoebox() {
        let server = TestServer::new();
        let (status, _, body) = server.send(get("/v1/scenes")).await;
        assert_eq!(status, StatusCode::OK);
        let scenes = body["scenes"].as_array().expect("scenes array");
        let shoebox = scenes
            .iter()
            .find(|s| s["id"] == "shoebox")
            .expect("shoebox listed");
        assert_eq!(shoebox["triangles"], 12);
        assert_eq!(shoebox["bundled"], true);
        let materials = shoebox["materials"].as_array().expect("materials");
        assert!(materials.iter().any(|m| m == "walls"));
    }

    #[tokio::test]
    async fn upload_inspect_delete() {
        let server = TestServer::new();
        let (status, _, created) = server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        assert_eq!(status, StatusCode::CREATED, "{created}");
        assert_eq!(created["id"], "box");
        assert_eq!(created["triangles"], 14);
        let other = BOX_DOC.replace("0.1", "0.3");
        let (status, _, again) = server.send(post_json("/v1/scenes?id=box", &other)).await;
        assert_eq!(status, StatusCode::CONFLICT, "{again}");
        let (status, _, detail) = server.send(get("/v1/scenes/box")).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(detail["bvh"]["triangles"], 14);
        let (status, _, _) = server.send(delete("/v1/scenes/box")).await;
        assert_eq!(status, StatusCode::NO_CONTENT);
        let (status, _, problem) = server.send(get("/v1/scenes/box")).await;
        assert_eq!(status, StatusCode::NOT_FOUND);
        assert_eq!(problem["type"], "urn:frusta:problem:unknown-scene");
    }

    #[tokio::test]
    async fn ids_come_from_names_and_never_collide() {
        let server = TestServer::new();
        let doc = BOX_DOC.replacen('{', r#"{"name": "My Room!","#, 1);
        let (_, _, a) = server.send(post_json("/v1/scenes", &doc)).await;
        let (_, _, b) = server.send(post_json("/v1/scenes", &doc)).await;
        assert_eq!(a["id"], "my-room");
        assert_eq!(b["id"], "my-room-2");
    }

    #[tokio::test]
    async fn a_small_document_asking_for_a_huge_mesh_is_refused_before_it_is_built() {
        let server = TestServer::with(|c| c.limits.max_triangles = 10_000);
        for mesh in [
            r#"{"hall": {"target_triangles": 50000000}}"#,
            r#"{"box_room": {"min": [0, 0, 0], "max": [1, 1, 1], "subdivisions": 2000}}"#,
            r#"{"l_room": {"min": [0, 0, 0], "max": [9, 9, 3], "cutout": [3, 3], "subdivisions": 400}}"#,
        ] {
            let doc = format!(
                r#"{{"objects": [{{"name": "big", "material": "concrete", "mesh": {mesh}}}]}}"#
            );
            let (status, _, problem) = server.send(post_json("/v1/scenes", &doc)).await;
            assert_eq!(
                status,
                StatusCode::UNPROCESSABLE_ENTITY,
                "{mesh}: {problem}"
            );
            assert_eq!(problem["type"], "urn:frusta:problem:limit-exceeded");
        }
        let hall = r#"{"objects": [{"name": "h", "material": "concrete", "mesh": {"hall": {"target_triangles": 9000}}}]}"#;
        assert_eq!(
            server.send(post_json("/v1/scenes", hall)).await.0,
            StatusCode::CREATED
        );
    }

    #[tokio::test]
    async fn a_full_server_refuses_uploads_and_keeps_what_it_has() {
        let server = TestServer::with(|c| c.limits.max_total_triangles = 20);
        let (status, _, problem) = server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        assert_eq!(status, StatusCode::INSUFFICIENT_STORAGE, "{problem}");
        assert_eq!(problem["type"], "urn:frusta:problem:server-full");
        let (_, _, list) = server.send(get("/v1/scenes")).await;
        assert_eq!(list["scenes"].as_array().map(Vec::len), Some(1));
    }

    #[tokio::test]
    async fn an_obj_upload_is_one_object() {
        let server = TestServer::new();
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let request = axum::http::Request::post("/v1/scenes?id=tri&object=panel")
            .header("content-type", "model/obj")
            .body(axum::body::Body::from(obj))
            .expect("request");
        let (status, _, body) = server.send(request).await;
        assert_eq!(status, StatusCode::CREATED, "{body}");
        assert_eq!(body["objects"][0]["name"], "panel");
        assert_eq!(body["triangles"], 1);
    }

    #[tokio::test]
    async fn bad_uploads_are_problems_and_store_nothing() {
        let server = TestServer::new();
        let cases = [
            (
                "/v1/scenes",
                "{\"objects\": [",
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes?id=bad%20id",
                BOX_DOC,
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes",
                r#"{"objects":[{"name":"a","material":"concrete","mesh":{"vertices":[[0,0,0],[1,0,0],[0,1,0]],"triangles":[[0,1,7]]}}]}"#,
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
            (
                "/v1/scenes",
                r#"{"objects":[{"name":"a","mesh":{"file":"../etc/passwd.obj"}}]}"#,
                StatusCode::UNPROCESSABLE_ENTITY,
            ),
        ];
        let before = server.send(get("/v1/scenes")).await.2["scenes"]
            .as_array()
            .map(Vec::len);
        for (uri, body, expected) in cases {
            let (status, content_type, problem) = server.send(post_json(uri, body)).await;
            assert_eq!(status, expected, "{uri} {body}: {problem}");
            assert_eq!(content_type, "application/problem+json");
            assert!(problem["detail"].as_str().is_some_and(|d| !d.is_empty()));
        }
        let request = axum::http::Request::post("/v1/scenes")
            .header("content-type", "image/png")
            .body(axum::body::Body::from("x"))
            .expect("request");
        assert_eq!(
            server.send(request).await.0,
            StatusCode::UNSUPPORTED_MEDIA_TYPE
        );
        let after = server.send(get("/v1/scenes")).await.2["scenes"]
            .as_array()
            .map(Vec::len);
        assert_eq!(before, after);
    }

    #[tokio::test]
    async fn uploads_wait_for_no_one_past_the_upload_buffer() {
        let server = TestServer::with(|c| {
            c.limits.max_upload_mib = 1;
            c.limits.max_buffered_upload_mib = 1;
        });
        // Another upload holds the whole buffer.
        let held = server.state.upload_buffer().clone();
        let held = held.try_acquire_many_owned(1024).unwrap();
        let (status, _, problem) = server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE, "{problem}");
        assert!(problem["detail"]
            .as_str()
            .unwrap()
            .contains("upload buffer"));
        drop(held);
        let (status, _, _) = server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        assert_eq!(status, StatusCode::CREATED);
        // A declared length over the limit is refused before it is read.
        let request = axum::http::Request::post("/v1/scenes?id=big")
            .header("content-type", "application/json")
            .header("content-length", (2 << 20).to_string())
            .body(axum::body::Body::from(BOX_DOC))
            .unwrap();
        let (status, _, _) = server.send(request).await;
        assert_eq!(status, StatusCode::PAYLOAD_TOO_LARGE);
        assert_eq!(server.state.upload_buffer().available_permits(), 1024);
    }

    #[tokio::test]
    async fn a_retried_upload_is_answered_with_the_stored_scene() {
        let server = TestServer::new();
        let uri = "/v1/scenes?id=box";
        let (status, _, first) = server.send(post_json(uri, BOX_DOC)).await;
        assert_eq!(status, StatusCode::CREATED);
        // The same upload again (its answer was lost, or a 504 came while
        // it finished): the stored scene, and nothing new.
        let (status, _, again) = server.send(post_json(uri, BOX_DOC)).await;
        assert_eq!(status, StatusCode::OK, "{again}");
        assert_eq!(again, first);
        let changed = BOX_DOC.replace("0.1", "0.2");
        let (status, _, problem) = server.send(post_json(uri, &changed)).await;
        assert_eq!(status, StatusCode::CONFLICT);
        assert!(problem["detail"].as_str().unwrap().contains("`box`"));
        let server = server.restart();
        let (status, _, _) = server.send(post_json(uri, BOX_DOC)).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(server.state.registry().list().len(), 2);
    }
}
