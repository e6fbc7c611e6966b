//! Scene listing and detail: what a client needs to pick a scene and
//! interpret hits (object and material names by index).

use axum::extract::{Path, State};
use axum::Json;
use frusta_engine::query::SceneBvhStats;
use serde::Serialize;

use crate::app::AppState;
use crate::catalog::LoadedScene;
use crate::error::ApiError;

#[derive(Serialize)]
pub struct SceneSummary {
    id: String,
    objects: usize,
    triangles: usize,
    /// Material names in id order, so a hit's material index maps here.
    materials: Vec<String>,
}

impl SceneSummary {
    fn new(id: &str, loaded: &LoadedScene) -> Self {
        Self {
            id: id.to_owned(),
            objects: loaded.scene.objects.len(),
            triangles: loaded.scene.triangle_count(),
            materials: loaded
                .scene
                .materials
                .iter()
                .map(|m| m.name.clone())
                .collect(),
        }
    }
}

#[derive(Serialize)]
pub struct SceneList {
    scenes: Vec<SceneSummary>,
}

pub async fn list(State(state): State<AppState>) -> Json<SceneList> {
    let scenes = state
        .catalog()
        .iter()
        .map(|(id, loaded)| SceneSummary::new(id, loaded))
        .collect();
    Json(SceneList { scenes })
}

#[derive(Serialize)]
pub struct SceneDetail {
    #[serde(flatten)]
    summary: SceneSummary,
    build_ms: f64,
    stats: SceneBvhStats,
}

pub async fn detail(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SceneDetail>, ApiError> {
    let loaded = state.scene(&id)?;
    Ok(Json(SceneDetail {
        summary: SceneSummary::new(&id, &loaded),
        build_ms: loaded.build_time.as_secs_f64() * 1e3,
        stats: loaded.bvh.stats(),
    }))
}

#[cfg(test)]
mod tests {
    use crate::app::test_support::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn list_shows_the_bundled_shoebox() {
        let (status, _, body) = send(get("/v1/scenes")).await;
        assert_eq!(status, StatusCode::OK);
        let scenes = body["scenes"].as_array().expect("scenes array");
        let shoebox = scenes
            .iter()
            .find(|s| s["id"] == "shoebox")
            .expect("shoebox listed");
        assert_eq!(shoebox["objects"], 1);
        assert_eq!(shoebox["triangles"], 12);
        let materials = shoebox["materials"].as_array().expect("materials");
        assert!(materials.iter().any(|m| m == "walls"));
    }

    #[tokio::test]
    async fn detail_includes_bvh_stats() {
        let (status, _, body) = send(get("/v1/scenes/shoebox")).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(body["id"], "shoebox");
        assert_eq!(body["stats"]["triangles"], 12);
        assert_eq!(body["stats"]["objects"].as_array().map(Vec::len), Some(1));
    }

    #[tokio::test]
    async fn unknown_scene_is_a_404_problem() {
        let (status, content_type, body) = send(get("/v1/scenes/atlantis")).await;
        assert_eq!(status, StatusCode::NOT_FOUND);
        assert_eq!(content_type, "application/problem+json");
        assert_eq!(body["status"], 404);
        assert_eq!(body["title"], "Unknown scene");
        assert!(body["detail"]
            .as_str()
            .is_some_and(|d| d.contains("atlantis")));
    }
}
