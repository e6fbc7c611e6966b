//! The real server in this process, on a free loopback port over a fresh
//! data directory seeded with one scene (so startup builds nothing else,
//! e.g. not the 200k hall).

use std::path::{Path, PathBuf};

/// The server and its data directory. Fields drop in order: the server
/// stops before the directory goes.
pub struct Local {
    server: frusta_server::BackgroundServer,
    dir: PathBuf,
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
        config.addr = ([127, 0, 0, 1], 0).into();
        eprintln!("[{scene}] starting the server (building the scene)...");
        match frusta_server::BackgroundServer::start(config) {
            Ok(server) => Ok(Self { server, dir }),
            Err(e) => {
                let _ = std::fs::remove_dir_all(&dir);
                Err(e)
            }
        }
    }

    /// `http://ADDR`.
    pub fn url(&self) -> String {
        self.server.url()
    }

    /// Graceful shutdown, then the data directory goes.
    pub fn stop(self) {
        self.server.stop();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A `kB` line of `/proc/{process}/status` (e.g. `VmHWM`, `VmRSS`) in
/// MiB, `process` being `self` or a pid; `None` off Linux, or when the
/// process is gone (a zombie has no `Vm` lines).
pub fn status_mib(process: &str, key: &str) -> Option<f64> {
    let status = std::fs::read_to_string(format!("/proc/{process}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}
