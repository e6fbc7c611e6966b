//! The scenes the service answers queries on: every `*.json` in a
//! directory, loaded and with its acceleration structure built once at
//! startup, since building is far costlier than any single query.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use frusta_engine::bvh::BuildOptions;
use frusta_engine::query::SceneBvh;
use frusta_engine::scene::Scene;

/// A scene ready for queries.
pub struct LoadedScene {
    pub scene: Scene,
    pub bvh: SceneBvh,
    pub build_time: Duration,
}

/// Scenes by id (file stem); ordered so listings are stable.
pub type Catalog = BTreeMap<String, Arc<LoadedScene>>;

/// Loads every `*.json` scene in `dir`. A scene that fails to load is
/// logged and skipped so one broken file cannot take the service down;
/// only an unreadable directory is an error.
pub fn load_dir(dir: &Path) -> std::io::Result<Catalog> {
    let mut paths: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    paths.sort();
    let mut catalog = Catalog::new();
    for path in paths {
        let Some(id) = path.file_stem().and_then(|s| s.to_str()) else {
            tracing::warn!(path = %path.display(), "skipping scene: file name is not UTF-8");
            continue;
        };
        match Scene::load(&path) {
            Ok(scene) => {
                let start = Instant::now();
                let bvh = SceneBvh::build(&scene, &BuildOptions::default());
                let build_time = start.elapsed();
                tracing::info!(
                    scene = id,
                    triangles = scene.triangle_count(),
                    build_ms = build_time.as_secs_f64() * 1e3,
                    "scene ready"
                );
                let loaded = LoadedScene {
                    scene,
                    bvh,
                    build_time,
                };
                catalog.insert(id.to_owned(), Arc::new(loaded));
            }
            Err(e) => tracing::error!(path = %path.display(), error = %e, "skipping scene"),
        }
    }
    Ok(catalog)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_broken_scene_is_skipped_not_fatal() {
        let dir = std::env::temp_dir().join(format!("frusta-catalog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let shoebox = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/shoebox.json");
        std::fs::copy(shoebox, dir.join("good.json")).expect("copy scene");
        std::fs::write(dir.join("broken.json"), "{ not json").expect("write");
        std::fs::write(dir.join("notes.txt"), "ignored").expect("write");
        let catalog = load_dir(&dir);
        std::fs::remove_dir_all(&dir).expect("clean up");
        let ids: Vec<_> = catalog.expect("readable dir").into_keys().collect();
        assert_eq!(ids, ["good"]);
    }

    #[test]
    fn a_missing_directory_is_an_error() {
        assert!(load_dir(Path::new("/no/such/frusta/scenes")).is_err());
    }
}
