//! `PATCH /v1/scenes/{id}/materials`: replace materials' coefficients by
//! name, or add materials. Triangles keep their materials; no hierarchy
//! changes.

use axum::extract::{Path, State};
use axum::{Extension, Json};
use frusta_api::materials::{MaterialsEdited, MaterialsPatch};
use frusta_engine::scene::Scene;
use serde_json::Value;

use crate::app::AppState;
use crate::auth::Caller;
use crate::error::{ApiError, JsonBody, Problem};

/// Body: `{"materials": {"<name>": "<library material>" | {"absorption": ..., "scattering": ..., "transmission": ...}}}`,
/// as in the scene document.
#[utoipa::path(patch, path = "/v1/scenes/{id}/materials", tag = "scenes",
    params(("id" = String, Path, description = "Scene id")),
    request_body(content = MaterialsPatch, description = "Materials as in the scene document: new names are added, known ones changed"),
    responses((status = 200, body = MaterialsEdited), (status = 422, body = Problem, content_type = "application/problem+json")),
    security((), ("api_key" = [])))]
pub async fn patch(
    State(state): State<AppState>,
    Extension(caller): Extension<Caller>,
    Path(id): Path<String>,
    JsonBody(body): JsonBody<Value>,
) -> Result<Json<MaterialsEdited>, ApiError> {
    let entry = state.registry().get(&id)?;
    caller.may_change(&entry.meta)?;
    let materials = match body {
        Value::Object(mut fields) if fields.len() == 1 && fields.contains_key("materials") => {
            fields.remove("materials").unwrap_or_default()
        }
        _ => {
            return Err(ApiError::Invalid(
                "the body must be {\"materials\": {name: material, ...}}".into(),
            ))
        }
    };
    let job_state = state.clone();
    let edited = state
        .compute()
        .run(move || {
            // The scene format resolves library names and checks
            // coefficients; on the compute pool, since a large edit takes
            // a while and the async runtime must stay free.
            let document = serde_json::json!({ "materials": materials, "objects": [] }).to_string();
            let parsed = Scene::from_json_str(&document, None).map_err(ApiError::from_engine)?;
            let revision = job_state
                .registry()
                .edit_materials(&entry, parsed.materials)?;
            let materials = entry
                .read()
                .scene
                .materials
                .iter()
                .map(|m| m.name.clone())
                .collect();
            Ok::<_, ApiError>(MaterialsEdited {
                revision,
                materials,
            })
        })
        .await??;
    Ok(Json(edited))
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn replacing_a_material_changes_the_impulse_response() {
        let server = TestServer::new();
        server.send(post_json("/v1/scenes?id=box", BOX_DOC)).await;
        let ir = r#"{"sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}], "max_order": 2}"#;
        let uri = "/v1/scenes/box/impulse-responses";
        let (_, _, before) = server.send(post_json(uri, ir)).await;
        let body = r#"{"materials": {"walls": "anechoic", "extra": {"absorption": 0.5}}}"#;
        let (status, _, edited) = server
            .send(patch_json("/v1/scenes/box/materials", body))
            .await;
        assert_eq!(status, StatusCode::OK, "{edited}");
        assert_eq!(edited["materials"], serde_json::json!(["walls", "extra"]));
        let (_, _, after) = server.send(post_json(uri, ir)).await;
        // The first reflection's gain (diffraction at the panel's edges
        // does not depend on the walls' material).
        let gain = |r: &serde_json::Value| {
            let paths = r["responses"][0]["paths"].as_array()?;
            let reflected = paths
                .iter()
                .find(|p| p["surfaces"][0]["event"] == "reflection")?;
            reflected["pressure_gain"][4].as_f64()
        };
        assert!(gain(&before).is_some(), "{before}");
        assert!(gain(&after) < gain(&before), "{before} {after}");
        let bad = r#"{"materials": {"walls": {"absorption": 2}}}"#;
        let (status, _, _) = server
            .send(patch_json("/v1/scenes/box/materials", bad))
            .await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    }
}
