//! What the cross-crate tests in `tests/tests/` share: the real server on
//! a free loopback port over its own data directory, and small HTTP and
//! WebSocket helpers.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread::JoinHandle;

use serde_json::Value;
use tokio::sync::oneshot;

/// A running server; dropping it shuts it down gracefully.
pub struct Server {
    pub addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

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

    pub fn start_with(config: frusta_server::Config) -> Self {
        let (addr_tx, addr_rx) = std::sync::mpsc::channel();
        let (stop, stopped) = oneshot::channel::<()>();
        let thread = std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .expect("runtime");
            runtime.block_on(async move {
                let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
                    .await
                    .expect("bind");
                let state = frusta_server::open(&config).expect("open the data directory");
                addr_tx
                    .send(listener.local_addr().expect("address"))
                    .expect("send address");
                frusta_server::serve(state, listener, async {
                    let _ = stopped.await;
                })
                .await
                .expect("serve");
            });
        });
        let addr = addr_rx.recv().expect("the server started");
        Self {
            addr,
            stop: Some(stop),
            thread: Some(thread),
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }

    pub fn ws_url(&self, path: &str) -> String {
        format!("ws://{}{path}", self.addr)
    }

    /// Shuts down gracefully and waits until every task has ended.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            thread.join().expect("server thread");
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// An HTTP client that returns 4xx and 5xx answers instead of failing.
pub fn client() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .build()
        .into()
}

/// Status, content type and JSON body (`Null` when empty).
pub fn answer(
    response: Result<ureq::http::Response<ureq::Body>, ureq::Error>,
) -> (u16, String, Value) {
    let mut response = response.expect("HTTP exchange");
    let status = response.status().as_u16();
    let content_type = response
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .unwrap_or_default()
        .to_owned();
    let text = response.body_mut().read_to_string().expect("body");
    let json = if text.is_empty() {
        Value::Null
    } else {
        serde_json::from_str(&text).unwrap_or(Value::String(text))
    };
    (status, content_type, json)
}

pub fn get(url: &str) -> (u16, String, Value) {
    answer(client().get(url).call())
}

pub fn post(url: &str, body: &str) -> (u16, String, Value) {
    answer(
        client()
            .post(url)
            .header("content-type", "application/json")
            .send(body),
    )
}

pub fn patch(url: &str, body: &str) -> (u16, String, Value) {
    answer(
        client()
            .patch(url)
            .header("content-type", "application/json")
            .send(body),
    )
}

pub fn delete(url: &str) -> (u16, String, Value) {
    answer(client().delete(url).call())
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
