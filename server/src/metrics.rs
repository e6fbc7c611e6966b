//! Prometheus metrics, served at `GET /metrics` in the text exposition
//! format. One registry per server (no global state), so tests and
//! embedders can run several servers in one process.

use std::time::Instant;

use axum::extract::{MatchedPath, Request, State};
use axum::middleware::Next;
use axum::response::Response;
use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::Registry;

use crate::app::AppState;

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct RequestLabels {
    pub method: String,
    /// The route template (`/v1/scenes/{id}`), not the raw path, so the
    /// label set stays bounded whatever ids clients send.
    pub route: String,
    pub status: u16,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct RouteLabels {
    pub method: String,
    pub route: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct UpdateLabels {
    /// `transform`, `refit` or `rebuild`.
    pub action: String,
}

type HistogramFamily = Family<RouteLabels, Histogram, fn() -> Histogram>;

pub struct Metrics {
    registry: Registry,
    pub requests: Family<RequestLabels, Counter>,
    pub latency: HistogramFamily,
    pub scenes: Gauge,
    pub triangles: Gauge,
    pub frusta: Counter,
    pub impulse_responses: Counter,
    pub object_updates: Family<UpdateLabels, Counter>,
    pub streams: Gauge,
    pub stream_updates: Counter,
}

impl Default for Metrics {
    fn default() -> Self {
        fn latency_histogram() -> Histogram {
            // 0.25 ms .. ~65 s.
            Histogram::new(exponential_buckets(0.000_25, 2.0, 19))
        }
        let mut m = Self {
            registry: Registry::with_prefix("frusta"),
            requests: Family::default(),
            latency: Family::new_with_constructor(latency_histogram),
            scenes: Gauge::default(),
            triangles: Gauge::default(),
            frusta: Counter::default(),
            impulse_responses: Counter::default(),
            object_updates: Family::default(),
            streams: Gauge::default(),
            stream_updates: Counter::default(),
        };
        let r = &mut m.registry;
        r.register(
            "http_requests",
            "HTTP requests answered",
            m.requests.clone(),
        );
        r.register(
            "http_request_duration_seconds",
            "Time to answer an HTTP request",
            m.latency.clone(),
        );
        r.register("scenes", "Scenes held", m.scenes.clone());
        r.register("triangles", "Triangles in all scenes", m.triangles.clone());
        r.register("frusta_traced", "Frusta traced", m.frusta.clone());
        r.register(
            "impulse_responses",
            "Impulse responses computed (one per source-listener pair)",
            m.impulse_responses.clone(),
        );
        r.register(
            "object_updates",
            "Object edits by what the hierarchy did",
            m.object_updates.clone(),
        );
        r.register("streams", "Open WebSocket streams", m.streams.clone());
        r.register(
            "stream_updates",
            "Impulse responses sent on streams",
            m.stream_updates.clone(),
        );
        m
    }
}

impl Metrics {
    pub fn render(&self) -> String {
        let mut out = String::new();
        // Writing into a String cannot fail.
        let _ = prometheus_client::encoding::text::encode(&mut out, &self.registry);
        out
    }

    pub fn count_update(&self, action: &str) {
        self.object_updates
            .get_or_create(&UpdateLabels {
                action: action.to_owned(),
            })
            .inc();
    }
}

/// Middleware counting and timing every request by route template.
pub async fn track(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let start = Instant::now();
    let method = request.method().to_string();
    let route = request
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "unmatched".to_owned(), |p| p.as_str().to_owned());
    let response = next.run(request).await;
    tracing::debug!(
        %method,
        %route,
        status = response.status().as_u16(),
        ms = start.elapsed().as_secs_f64() * 1e3,
        "request"
    );
    let metrics = state.metrics();
    metrics
        .latency
        .get_or_create(&RouteLabels {
            method: method.clone(),
            route: route.clone(),
        })
        .observe(start.elapsed().as_secs_f64());
    metrics
        .requests
        .get_or_create(&RequestLabels {
            method,
            route,
            status: response.status().as_u16(),
        })
        .inc();
    response
}
