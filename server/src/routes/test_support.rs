//! A server over a fresh data directory holding the bundled shoebox, and
//! request helpers, for the handlers' unit tests.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use axum::body::Body;
use axum::http::{Request, StatusCode};
use http_body_util::BodyExt;
use tower::ServiceExt;

use crate::{open, router, AppState, Config};

/// A closed 10 x 6 x 3 m box (12 triangles) with one dynamic panel.
pub const BOX_DOC: &str = r#"{
  "materials": {"walls": {"absorption": 0.1}},
  "objects": [
    {"name": "room", "material": "walls",
     "mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3]}}},
    {"name": "panel", "material": "walls", "dynamic": true,
     "mesh": {"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2], [4, 1, 2]],
              "triangles": [[0, 1, 2], [0, 2, 3]]}}
  ]
}"#;

pub struct TestServer {
    pub state: AppState,
    dir: PathBuf,
    config: Config,
}

impl TestServer {
    pub fn new() -> Self {
        Self::with(|_| {})
    }

    /// A server whose configuration `tweak` may change.
    pub fn with(tweak: impl FnOnce(&mut Config)) -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "frusta-server-test-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let scenes = dir.join("scenes");
        std::fs::create_dir_all(&scenes).expect("temp dir");
        let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/shoebox.json");
        std::fs::copy(bundled, scenes.join("shoebox.json")).expect("copy shoebox");
        let mut config = Config::with_data_dir(dir.join("data"));
        config.scenes_dir = scenes;
        tweak(&mut config);
        let state = open(&config).expect("open");
        Self { state, dir, config }
    }

    /// The server stopped and started again on the same data directory,
    /// as after a restart: only what was stored comes back.
    pub fn restart(mut self) -> Self {
        let dir = std::mem::take(&mut self.dir);
        let config = self.config.clone();
        // One open database per file: the old state closes first.
        drop(self);
        let state = open(&config).expect("reopen");
        Self { state, dir, config }
    }

    /// Sends one request; returns status, content type and JSON body
    /// (`null` when the body is empty).
    pub async fn send(&self, request: Request<Body>) -> (StatusCode, String, serde_json::Value) {
        let (status, content_type, bytes) = self.send_raw(request).await;
        let json = if bytes.is_empty() {
            serde_json::Value::Null
        } else {
            serde_json::from_slice(&bytes)
                .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&bytes)))
        };
        (status, content_type, json)
    }

    pub async fn send_raw(&self, request: Request<Body>) -> (StatusCode, String, Vec<u8>) {
        let response = router(self.state.clone())
            .oneshot(request)
            .await
            .expect("infallible");
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
        (status, content_type, bytes.to_vec())
    }
}

impl TestServer {
    /// Moves object `object` of scene `id` by `translation`, which must
    /// succeed.
    pub async fn translate(&self, id: &str, object: &str, translation: [f32; 3]) {
        let uri = format!("/v1/scenes/{id}/objects/{object}");
        let body = serde_json::json!({ "translation": translation }).to_string();
        let (status, _, answer) = self.send(patch_json(&uri, &body)).await;
        assert!(status.is_success(), "{answer}");
    }
}

impl Drop for TestServer {
    fn drop(&mut self) {
        if !self.dir.as_os_str().is_empty() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

pub fn get(uri: &str) -> Request<Body> {
    Request::get(uri).body(Body::empty()).expect("request")
}

pub fn delete(uri: &str) -> Request<Body> {
    Request::delete(uri).body(Body::empty()).expect("request")
}

pub fn post_json(uri: &str, body: &str) -> Request<Body> {
    with_json(Request::post(uri), body)
}

pub fn patch_json(uri: &str, body: &str) -> Request<Body> {
    with_json(Request::patch(uri), body)
}

fn with_json(builder: axum::http::request::Builder, body: &str) -> Request<Body> {
    builder
        .header("content-type", "application/json")
        .body(Body::from(body.to_owned()))
        .expect("request")
}
