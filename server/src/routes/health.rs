//! Liveness probe: answers as soon as the listener is up, which is after
//! every scene has been built.

use axum::Json;
use serde_json::{json, Value};

pub async fn healthz() -> Json<Value> {
    Json(json!({ "status": "ok" }))
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn healthz_metrics_docs_and_unknown_routes() {
        let server = TestServer::new();
        let (status, _, body) = server.send(get("/healthz")).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(body, serde_json::json!({ "status": "ok" }));
        let (status, _, text) = server.send_raw(get("/metrics")).await;
        assert_eq!(status, StatusCode::OK);
        let text = String::from_utf8(text).expect("UTF-8");
        assert!(text.contains("frusta_scenes 1"), "{text}");
        let (status, _, spec) = server.send(get("/openapi.json")).await;
        assert_eq!(status, StatusCode::OK);
        for path in [
            "/v1/scenes",
            "/v1/scenes/{id}/impulse-responses",
            "/v1/scenes/{id}/stream",
        ] {
            assert!(
                spec["paths"][path].is_object(),
                "{path} missing from the spec"
            );
        }
        let (status, content_type, _) = server.send_raw(get("/docs/")).await;
        assert_eq!(status, StatusCode::OK);
        assert!(content_type.starts_with("text/html"));
        let (status, content_type, body) = server.send(get("/nope")).await;
        assert_eq!(status, StatusCode::NOT_FOUND);
        assert_eq!(content_type, "application/problem+json");
        assert_eq!(body["type"], "urn:frusta:problem:unknown-route");
    }
}
