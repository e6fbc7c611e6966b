//! Liveness probe: answers as soon as the listener is up, which is after
//! every scene has been built.

use axum::Json;
use serde_json::{json, Value};

pub async fn healthz() -> Json<Value> {
    Json(json!({ "status": "ok" }))
}

#[cfg(test)]
mod tests {
    use crate::app::test_support::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn healthz_is_ok() {
        let (status, _, body) = send(get("/healthz")).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(body, serde_json::json!({ "status": "ok" }));
    }
}
