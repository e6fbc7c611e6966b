//! `frusta-server`: scenes uploaded over REST and kept in a crash-safe
//! store; impulse responses over HTTP and streamed over WebSocket as things
//! move; ray, visibility and collision queries on the same hierarchies.
//!
//! The binary is a thin shell over [`open`] and [`serve`], which tests and
//! embedders call directly, or through [`BackgroundServer`].

mod app;
mod auth;
mod background;
mod collide;
mod compute;
pub mod config;
mod connections;
mod error;
mod lod_cache;
mod metrics;
mod registry;
mod routes;
mod shadow_cache;
mod simulation;
mod store;

use std::future::Future;
use std::path::Path;

use frusta_engine::scene::Scene;

pub use app::{router, AppState};
pub use background::BackgroundServer;
pub use config::Config;

use registry::{now_unix_ms, Registry};
use store::{SceneMeta, Store};

/// Opens the data directory (adding the bundled scenes on its first use)
/// and builds every stored scene. Blocking: call it before serving, or on a
/// blocking thread.
pub fn open(config: &Config) -> Result<AppState, String> {
    config.limits.check()?;
    let store = Store::open(&config.data_dir)
        .map_err(|e| format!("cannot open {}: {e}", config.data_dir.display()))?;
    let seeded = store
        .seeded()
        .map_err(|e| format!("cannot read the store: {e}"))?;
    let registry = Registry::load(store).map_err(|e| e.to_string())?;
    if !seeded {
        add_bundled(&registry, &config.scenes_dir);
        registry
            .store()
            .mark_seeded()
            .map_err(|e| format!("cannot write the store: {e}"))?;
    }
    Ok(AppState::new(registry, config))
}

/// Adds every `*.json` scene of `dir`. A scene that fails to load is
/// logged and skipped, so one broken file cannot keep the service down.
fn add_bundled(registry: &Registry, dir: &Path) {
    let mut paths: Vec<_> = match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect(),
        Err(e) => {
            tracing::warn!(dir = %dir.display(), error = %e, "no bundled scenes");
            return;
        }
    };
    paths.sort();
    for path in paths {
        let Some(id) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        let meta = SceneMeta {
            owner: None,
            created_unix_ms: now_unix_ms(),
            bundled: true,
            upload_digest: None,
        };
        let added = Scene::load(&path)
            .map_err(|e| e.to_string())
            .and_then(|scene| {
                // Bundled scenes are the operator's: no triangle budget.
                let reservation = registry.reserve(
                    Some(id.to_owned()),
                    id,
                    scene.triangle_count(),
                    usize::MAX,
                    None,
                );
                reservation
                    .and_then(|r| registry.create(r, meta, scene))
                    .map_err(|e| e.to_string())
            });
        if let Err(e) = added {
            tracing::error!(path = %path.display(), error = %e, "skipping bundled scene");
        }
    }
}

/// Serves until `shutdown` resolves, then lets in-flight requests finish
/// and closes every stream with "going away".
pub async fn serve(
    state: AppState,
    listener: tokio::net::TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let token = state.shutdown_token().clone();
    let tasks = state.tasks().clone();
    let limits = state.limits().clone();
    let cancel = token.clone();
    tokio::spawn(async move {
        shutdown.await;
        cancel.cancel();
    });
    connections::accept(listener, router(state), &limits, &token).await;
    tasks.close();
    tasks.wait().await;
    Ok(())
}
