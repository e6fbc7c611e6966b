//! The router and the state its handlers share.

use std::sync::Arc;

use axum::extract::DefaultBodyLimit;
use axum::http::Uri;
use axum::routing::{get, post};
use axum::Router;

use crate::catalog::{Catalog, LoadedScene};
use crate::error::ApiError;
use crate::routes::{health, rays, scenes};

/// Immutable after startup, so handlers share it without locks.
#[derive(Clone)]
pub struct AppState {
    catalog: Arc<Catalog>,
}

impl AppState {
    pub fn new(catalog: Catalog) -> Self {
        Self {
            catalog: Arc::new(catalog),
        }
    }

    pub fn catalog(&self) -> &Catalog {
        &self.catalog
    }

    pub fn scene(&self, id: &str) -> Result<Arc<LoadedScene>, ApiError> {
        self.catalog
            .get(id)
            .cloned()
            .ok_or_else(|| ApiError::SceneNotFound(id.to_owned()))
    }
}

/// Room for [`rays::MAX_RAYS`] rays written out verbosely; axum's 2 MB
/// default would reject batches well below the ray limit.
const RAYS_BODY_LIMIT: usize = 32 * 1024 * 1024;

pub fn router(state: AppState) -> Router {
    Router::new()
        .route("/healthz", get(health::healthz))
        .route("/v1/scenes", get(scenes::list))
        .route("/v1/scenes/{id}", get(scenes::detail))
        .route(
            "/v1/scenes/{id}/rays",
            post(rays::trace).layer(DefaultBodyLimit::max(RAYS_BODY_LIMIT)),
        )
        .fallback(|uri: Uri| async move { ApiError::RouteNotFound(uri.path().to_owned()) })
        .with_state(state)
}

#[cfg(test)]
pub(crate) mod test_support {
    //! The router over the bundled scenes, loaded once per test binary.

    use std::path::Path;
    use std::sync::OnceLock;

    use axum::body::Body;
    use axum::http::{Request, StatusCode};
    use http_body_util::BodyExt;
    use tower::ServiceExt;

    use super::*;

    fn state() -> AppState {
        static STATE: OnceLock<AppState> = OnceLock::new();
        STATE
            .get_or_init(|| {
                let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
                AppState::new(crate::catalog::load_dir(&dir).expect("bundled scenes"))
            })
            .clone()
    }

    /// Sends one request; returns status, content type and JSON body.
    pub async fn send(request: Request<Body>) -> (StatusCode, String, serde_json::Value) {
        let response = router(state()).oneshot(request).await.expect("infallible");
        let status = response.status();
        let content_type = response
            .headers()
            .get("content-type")
            .and_then(|v| v.to_str().ok())
            .unwrap_or_default()
            .to_owned();
        let bytes = response
            .into_body()
            .collect()
            .await
            .expect("body")
            .to_bytes();
        let json = serde_json::from_slice(&bytes).expect("JSON body");
        (status, content_type, json)
    }

    pub fn get(uri: &str) -> Request<Body> {
        Request::get(uri).body(Body::empty()).expect("request")
    }

    pub fn post_json(uri: &str, body: &str) -> Request<Body> {
        Request::post(uri)
            .header("content-type", "application/json")
            .body(Body::from(body.to_owned()))
            .expect("request")
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn unknown_route_is_a_problem() {
        let (status, content_type, body) = send(get("/nope")).await;
        assert_eq!(status, StatusCode::NOT_FOUND);
        assert_eq!(content_type, "application/problem+json");
        assert_eq!(body["type"], "urn:frusta:problem:unknown-route");
    }
}
