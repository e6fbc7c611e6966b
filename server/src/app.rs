//! The state handlers share and the one router that also builds the
//! OpenAPI document.

use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::Uri;
use axum::middleware::{from_fn_with_state, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;
use utoipa::OpenApi;
use utoipa_axum::router::{OpenApiRouter, UtoipaMethodRouterExt};
use utoipa_axum::routes;
use utoipa_swagger_ui::SwaggerUi;

use crate::auth::{self, digest};
use crate::compute::ComputePool;
use crate::config::{Config, Limits};
use crate::error::ApiError;
use crate::lod_cache::LodCache;
use crate::metrics::{self, Metrics};
use crate::registry::Registry;
use crate::routes::{
    collisions, health, impulse_responses, materials, objects, occlusion, rays, scenes, shadows,
    stream, visibility,
};
use crate::shadow_cache::ShadowCache;

#[derive(Clone)]
pub struct AppState(Arc<Inner>);

struct Inner {
    registry: Registry,
    limits: Limits,
    /// SHA-256 digests of the configured keys.
    api_keys: Vec<String>,
    metrics: Metrics,
    compute: ComputePool,
    /// Ray and occlusion queries: a lane of their own, so a query of
    /// microseconds never waits behind impulse responses of seconds.
    queries: ComputePool,
    streams: Arc<Semaphore>,
    /// KiB of upload bodies buffered at once, over all requests.
    upload_buffer: Arc<Semaphore>,
    /// Cancelled on shutdown: streams close with "going away".
    shutdown: CancellationToken,
    /// Stream tasks, awaited on shutdown.
    tasks: TaskTracker,
    /// The shadow data of the scene last asked about.
    shadows: ShadowCache,
    /// Scenes simplified for impulse responses with levels of detail.
    lods: LodCache,
}

impl AppState {
    pub fn new(registry: Registry, config: &Config) -> Self {
        let state = Self(Arc::new(Inner {
            registry,
            limits: config.limits.clone(),
            api_keys: config.api_keys.iter().map(|k| digest(k.trim())).collect(),
            metrics: Metrics::default(),
            compute: ComputePool::new(config.limits.max_queued),
            queries: ComputePool::new(config.limits.max_queued),
            streams: Arc::new(Semaphore::new(config.limits.max_streams)),
            upload_buffer: Arc::new(Semaphore::new(
                config
                    .limits
                    .max_buffered_upload_mib
                    .saturating_mul(1024)
                    .min(Semaphore::MAX_PERMITS),
            )),
            shutdown: CancellationToken::new(),
            tasks: TaskTracker::new(),
            shadows: ShadowCache::default(),
            lods: LodCache::default(),
        }));
        state.refresh_scene_gauges();
        state
    }

    pub fn registry(&self) -> &Registry {
        &self.0.registry
    }

    pub fn limits(&self) -> &Limits {
        &self.0.limits
    }

    pub fn api_keys(&self) -> &[String] {
        &self.0.api_keys
    }

    pub fn metrics(&self) -> &Metrics {
        &self.0.metrics
    }

    pub fn compute(&self) -> &ComputePool {
        &self.0.compute
    }

    pub fn queries(&self) -> &ComputePool {
        &self.0.queries
    }

    pub fn shadow_cache(&self) -> &ShadowCache {
        &self.0.shadows
    }

    pub fn lod_cache(&self) -> &LodCache {
        &self.0.lods
    }

    pub fn streams(&self) -> &Arc<Semaphore> {
        &self.0.streams
    }

    pub fn upload_buffer(&self) -> &Arc<Semaphore> {
        &self.0.upload_buffer
    }

    pub fn shutdown_token(&self) -> &CancellationToken {
        &self.0.shutdown
    }

    pub fn tasks(&self) -> &TaskTracker {
        &self.0.tasks
    }

    pub fn refresh_scene_gauges(&self) {
        let scenes = self.registry().list().len();
        let triangles = self.registry().total_triangles();
        self.metrics().scenes.set(scenes as i64);
        self.metrics().triangles.set(triangles as i64);
    }
}

#[derive(OpenApi)]
#[openapi(
    info(
        title = "frusta",
        description = "Geometric acoustics: scenes, impulse responses, streams and ray queries. Every error is an RFC 9457 problem document (application/problem+json)."
    ),
    tags(
        (name = "scenes", description = "Upload, inspect, edit and delete scenes"),
        (name = "acoustics", description = "Impulse responses and streams"),
        (name = "queries", description = "Ray and visibility queries"),
    ),
    // A stream's messages travel after the upgrade, so no operation
    // names them; they are listed for clients.
    components(schemas(frusta_api::stream::StreamUpdate, frusta_api::stream::StreamFrame)),
    modifiers(&BearerAuth)
)]
struct ApiDoc;

/// Documents, on every `/v1` operation, the problem documents any request
/// can meet (malformed body, missing key, overload, timeout), so each route
/// lists only its own. Applied after the routes are collected: `ApiDoc`'s
/// own modifiers run before there are any paths.
struct ProblemResponses;

impl utoipa::Modify for ProblemResponses {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::{ContentBuilder, Ref, ResponseBuilder};
        let common = [
            ("400", "Malformed JSON"),
            ("401", "Missing or unknown API key (servers with keys)"),
            ("413", "Body above this route's limit"),
            ("415", "Unsupported content type"),
            (
                "422",
                "Well-formed input the server cannot use; the detail names the field",
            ),
            ("503", "Too many simulations or streams waiting; retry"),
            ("504", "The request took longer than the server's timeout"),
        ];
        for (path, item) in openapi.paths.paths.iter_mut() {
            if !path.starts_with("/v1/") {
                continue;
            }
            let not_found = path
                .contains("{id}")
                .then_some(("404", "No such scene (or object)"));
            let operations = [
                &mut item.get,
                &mut item.post,
                &mut item.patch,
                &mut item.delete,
                &mut item.put,
            ];
            for operation in operations.into_iter().flatten() {
                for (status, description) in common.into_iter().chain(not_found) {
                    let problem = ResponseBuilder::new()
                        .description(description)
                        .content(
                            "application/problem+json",
                            ContentBuilder::new()
                                .schema(Some(Ref::from_schema_name("Problem")))
                                .build(),
                        )
                        .build();
                    operation
                        .responses
                        .responses
                        .entry(status.to_owned())
                        .or_insert(problem.into());
                }
            }
        }
    }
}

struct BearerAuth;

impl utoipa::Modify for BearerAuth {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::security::{Http, HttpAuthScheme, SecurityScheme};
        let components = openapi.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            "api_key",
            SecurityScheme::Http(Http::new(HttpAuthScheme::Bearer)),
        );
    }
}

pub fn router(state: AppState) -> Router {
    let (v1, mut api) = OpenApiRouter::with_openapi(ApiDoc::openapi())
        .routes(routes!(scenes::list, scenes::create))
        .routes(routes!(scenes::detail, scenes::delete))
        .routes(
            routes!(objects::patch)
                .layer(axum::extract::DefaultBodyLimit::max(objects::BODY_LIMIT)),
        )
        .routes(routes!(materials::patch))
        .routes(routes!(impulse_responses::create))
        .routes(routes!(stream::connect))
        .routes(routes!(rays::trace).layer(axum::extract::DefaultBodyLimit::max(rays::BODY_LIMIT)))
        .routes(
            routes!(collisions::query)
                .layer(axum::extract::DefaultBodyLimit::max(objects::BODY_LIMIT)),
        )
        .routes(
            routes!(occlusion::check).layer(axum::extract::DefaultBodyLimit::max(rays::BODY_LIMIT)),
        )
        .routes(routes!(shadows::render))
        .routes(
            routes!(visibility::check)
                .layer(axum::extract::DefaultBodyLimit::max(rays::BODY_LIMIT)),
        )
        .layer(from_fn_with_state(state.clone(), auth::authenticate))
        .split_for_parts();
    utoipa::Modify::modify(&ProblemResponses, &mut api);
    Router::new()
        .merge(v1)
        .route("/healthz", get(health::healthz))
        .route("/metrics", get(metrics_text))
        .merge(SwaggerUi::new("/docs").url("/openapi.json", api))
        .route_layer(from_fn_with_state(state.clone(), metrics::track))
        .layer(from_fn_with_state(state.clone(), request_timeout))
        .fallback(|uri: Uri| async move { ApiError::RouteNotFound(uri.path().to_owned()) })
        .layer(axum::middleware::from_fn(crate::error::problem_documents))
        .with_state(state)
}

async fn metrics_text(State(state): State<AppState>) -> impl IntoResponse {
    (
        [(
            axum::http::header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        state.metrics().render(),
    )
}

/// Caps the time to answer any request; a stream's time after its
/// upgrade does not count.
async fn request_timeout(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let limit = state.limits().request_timeout();
    match tokio::time::timeout(limit, next.run(request)).await {
        Ok(response) => response,
        Err(_) => ApiError::Timeout {
            seconds: limit.as_secs(),
        }
        .into_response(),
    }
}
