//! Prometheus metrics, served at `GET /metrics` in the text exposition
//! format. One registry per server (no global state), so tests and
//! embedders can run several servers in one process.

use std::time::Instant;

use axum::extract::{MatchedPath, Request, State};
use axum::http::Method;
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

/// The method as a label: the standard ones by name, anything else
/// `other`, since a client can send any token as a method and each new
/// label would be kept for good.
fn method_label(method: &Method) -> &'static str {
    match *method {
        Method::GET => "GET",
        Method::HEAD => "HEAD",
        Method::POST => "POST",
        Method::PUT => "PUT",
        Method::PATCH => "PATCH",
        Method::DELETE => "DELETE",
        Method::OPTIONS => "OPTIONS",
        Method::CONNECT => "CONNECT",
        Method::TRACE => "TRACE",
        _ => "other",
    }
}

/// Middleware counting and timing every request by route template.
pub async fn track(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let start = Instant::now();
    let method = method_label(request.method()).to_owned();
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

#[cfg(test)]
mod tests {
    use axum::body::Body;
    use axum::http::{Method, Request};

    use crate::routes::test_support::*;

    #[tokio::test]
    async fn made_up_methods_share_one_label() {
        let server = TestServer::new();
        for i in 0..50 {
            let method =
                Method::from_bytes(format!("MADEUP{i:04}{}", "X".repeat(1000)).as_bytes()).unwrap();
            let request = Request::builder()
                .method(method)
                .uri("/v1/scenes")
                .body(Body::empty())
                .unwrap();
            server.send_raw(request).await;
        }
        let (_, _, text) = server.send_raw(get("/metrics")).await;
        let text = String::from_utf8(text).unwrap();
        assert!(!text.contains("MADEUP"), "{} bytes", text.len());
        assert!(text.contains(r#"method="other""#));
        assert!(text.len() < 100_000, "{} bytes", text.len());
    }
}
