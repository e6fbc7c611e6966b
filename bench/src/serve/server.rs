//! The real server in this process, on a free loopback port over a fresh
//! data directory seeded with one scene (so startup builds nothing else,
//! e.g. not the 200k hall).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;

use tokio::sync::oneshot;

pub struct Local {
    pub addr: SocketAddr,
    dir: PathBuf,
    stop: oneshot::Sender<()>,
    thread: JoinHandle<Result<(), String>>,
}

impl Local {
    pub fn start(scene: &str) -> Result<Self, String> {
        let dir = std::env::temp_dir().join(format!("frusta-bench-serve-{}", std::process::id()));
        let scenes = dir.join("scenes");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&scenes).map_err(|e| format!("{}: {e}", scenes.display()))?;
        let file = format!("{scene}.json");
        let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
        std::fs::copy(bundled.join(&file), scenes.join(&file))
            .map_err(|e| format!("{file}: {e}"))?;
        let mut config = frusta_server::Config::with_data_dir(dir.join("data"));
        config.scenes_dir = scenes;

        eprintln!("[{scene}] starting the server (building the scene)...");
        let (addr_tx, addr_rx) = std::sync::mpsc::channel();
        let (stop, stopped) = oneshot::channel::<()>();
        // Two workers as on the 2-core target; simulations run on rayon's
        // pool either way.
        let thread = std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .map_err(|e| e.to_string())?;
            runtime.block_on(async move {
                let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
                    .await
                    .map_err(|e| e.to_string())?;
                let state = frusta_server::open(&config)?;
                let addr = listener.local_addr().map_err(|e| e.to_string())?;
                let _ = addr_tx.send(addr);
                let shutdown = async {
                    let _ = stopped.await;
                };
                frusta_server::serve(state, listener, shutdown)
                    .await
                    .map_err(|e| e.to_string())
            })
        });
        match addr_rx.recv() {
            Ok(addr) => Ok(Self {
                addr,
                dir,
                stop,
                thread,
            }),
            // The thread ended before it listened: its error says why.
            Err(_) => {
                let _ = std::fs::remove_dir_all(&dir);
                Err(match thread.join() {
                    Ok(Err(e)) => e,
                    Ok(Ok(())) => "the server stopped".into(),
                    Err(_) => "the server panicked".into(),
                })
            }
        }
    }

    /// Graceful shutdown, then the data directory goes.
    pub fn stop(self) {
        let _ = self.stop.send(());
        if let Ok(Err(e)) = self.thread.join() {
            eprintln!("server: {e}");
        }
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A `kB` line of `/proc/self/status` (e.g. `VmHWM`, `VmRSS`) in MiB;
/// `None` off Linux.
pub fn status_mib(key: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}
