//! What the cross-crate tests in `tests/tests/` share: the real server on
//! a free loopback port over its own data directory, and `frusta-client`
//! clients of it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use frusta_client::{Answer, Client, Config};
use serde_json::Value;

/// A running server on a free loopback port; dropping it shuts it down.
pub struct Server(frusta_server::BackgroundServer);

/// A data directory that outlives server restarts, removed on drop.
pub struct DataDir(pub PathBuf);

impl DataDir {
    /// A fresh directory whose bundled scenes are only the small ones.
    pub fn new(name: &str) -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "frusta-it-{name}-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        let scenes = dir.join("scenes");
        std::fs::create_dir_all(&scenes).expect("temp dir");
        let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
        for file in ["shoebox.json", "l-room.json"] {
            std::fs::copy(bundled.join(file), scenes.join(file)).expect("copy scene");
        }
        Self(dir)
    }

    pub fn config(&self) -> frusta_server::Config {
        let mut config = frusta_server::Config::with_data_dir(self.0.join("data"));
        config.scenes_dir = self.0.join("scenes");
        config
    }
}

impl Drop for DataDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

impl Server {
    pub fn start(data: &DataDir) -> Self {
        Self::start_with(data.config())
    }

    pub fn start_with(mut config: frusta_server::Config) -> Self {
        config.addr = ([127, 0, 0, 1], 0).into();
        Self(frusta_server::BackgroundServer::start(config).expect("the server starts"))
    }

    /// A client of this server, as every Rust client talks to it.
    pub fn client(&self) -> Client {
        Client::new(&self.0.url(), Config::default()).expect("an http:// URL")
    }

    /// `host:port`.
    pub fn addr(&self) -> std::net::SocketAddr {
        self.0.addr
    }

    /// Shuts down gracefully and waits until every task has ended.
    pub fn stop(self) {
        self.0.stop();
    }

    pub fn get(&self, path: &str) -> (u16, String, Value) {
        parts(self.client().get(path))
    }

    pub fn post(&self, path: &str, body: &str) -> (u16, String, Value) {
        parts(
            self.client()
                .post(path, "application/json", body.as_bytes()),
        )
    }

    pub fn patch(&self, path: &str, body: &str) -> (u16, String, Value) {
        parts(
            self.client()
                .patch(path, "application/json", body.as_bytes()),
        )
    }

    pub fn delete(&self, path: &str) -> (u16, String, Value) {
        parts(self.client().delete(path))
    }
}

/// Status, content type and JSON body (`Null` when empty, a string when
/// not JSON), for tests of what any client would see.
fn parts(answer: Result<Answer, frusta_client::Error>) -> (u16, String, Value) {
    let answer = answer.expect("HTTP exchange");
    let text = String::from_utf8_lossy(&answer.body).into_owned();
    let json = if text.is_empty() {
        Value::Null
    } else {
        serde_json::from_str(&text).unwrap_or(Value::String(text))
    };
    (answer.status, answer.content_type, json)
}

/// A 10 x 6 x 3 m box with a dynamic 1 x 1.5 m panel at x = 4.
pub const BOX_DOC: &str = r#"{
  "name": "box with panel",
  "materials": {"walls": {"absorption": 0.1}},
  "objects": [
    {"name": "room", "material": "walls",
     "mesh": {"box_room": {"min": [0, 0, 0], "max": [10, 6, 3]}}},
    {"name": "panel", "material": "walls", "dynamic": true,
     "mesh": {"vertices": [[4, 1, 0.5], [4, 2, 0.5], [4, 2, 2], [4, 1, 2]],
              "triangles": [[0, 1, 2], [0, 2, 3]]}}
  ]
}"#;
