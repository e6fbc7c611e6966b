//! The real release server as a child process (the binary beside this
//! one), so its memory is its own and it runs as deployed: its own
//! runtime, pools and allocator, on a loopback port the OS picks, over a
//! fresh data directory with the bundled shoebox as its only scene.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

/// Log lines kept as they came.
const FIRST_LINES: usize = 10;

/// What the server logged that is worth a look: `WARN` and `ERROR` lines
/// on stdout, and anything on stderr (a panic).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Log {
    pub warnings: usize,
    pub errors: usize,
    pub stderr_lines: usize,
    /// The first [`FIRST_LINES`] of them.
    pub first: Vec<String>,
}

pub struct Server {
    child: Child,
    dir: PathBuf,
    /// `http://127.0.0.1:PORT`.
    pub url: String,
    pub log: Arc<Mutex<Log>>,
}

impl Server {
    pub fn start() -> Result<Self, String> {
        let exe = std::env::current_exe()
            .map_err(|e| format!("cannot find this executable: {e}"))?
            .with_file_name("frusta-server");
        if !exe.exists() {
            return Err(format!(
                "{} is missing: build it with `cargo build --release -p frusta-server`",
                exe.display()
            ));
        }
        let dir = std::env::temp_dir().join(format!("frusta-soak-{}", std::process::id()));
        let scenes = dir.join("scenes");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&scenes).map_err(|e| format!("{}: {e}", scenes.display()))?;
        let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/shoebox.json");
        std::fs::copy(&bundled, scenes.join("shoebox.json"))
            .map_err(|e| format!("{}: {e}", bundled.display()))?;
        let mut child = Command::new(&exe)
            .args(["--addr", "127.0.0.1:0", "--data-dir"])
            .arg(dir.join("data"))
            .arg("--scenes-dir")
            .arg(&scenes)
            // The address is logged at info.
            .env("RUST_LOG", "info")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("{}: {e}", exe.display()))?;
        let log = Arc::new(Mutex::new(Log::default()));
        let (addr_tx, addr_rx) = mpsc::channel();
        let stdout = child.stdout.take().expect("piped");
        let stderr = child.stderr.take().expect("piped");
        drain(stdout, log.clone(), Some(addr_tx));
        drain(stderr, log.clone(), None);
        // From here on the child is killed on drop, whatever fails.
        let mut server = Self {
            child,
            dir,
            url: String::new(),
            log,
        };
        match addr_rx.recv_timeout(Duration::from_secs(60)) {
            Ok(addr) => server.url = format!("http://{addr}"),
            Err(_) => return Err("the server did not log its address within 60 s".into()),
        }
        Ok(server)
    }

    pub fn pid(&self) -> String {
        self.child.id().to_string()
    }

    /// Bytes of the data directory (the store), in MiB.
    pub fn store_mib(&self) -> f64 {
        let files = std::fs::read_dir(self.dir.join("data"))
            .into_iter()
            .flatten();
        let bytes: u64 = files
            .filter_map(|f| f.ok()?.metadata().ok())
            .map(|m| m.len())
            .sum();
        bytes as f64 / (1 << 20) as f64
    }

    /// SIGTERM, as a deployment stops it (in-flight requests finish,
    /// streams close), then up to 30 s for it to exit 0.
    pub fn stop(mut self) -> Result<(), String> {
        if let Ok(Some(status)) = self.child.try_wait() {
            return Err(format!("the server had exited before the end ({status})"));
        }
        let _ = Command::new("kill").args(["-TERM", &self.pid()]).status();
        let deadline = Instant::now() + Duration::from_secs(30);
        while Instant::now() < deadline {
            match self.child.try_wait() {
                Ok(Some(status)) if status.success() => return Ok(()),
                Ok(Some(status)) => {
                    return Err(format!("after SIGTERM the server exited {status}"))
                }
                _ => std::thread::sleep(Duration::from_millis(100)),
            }
        }
        Err("the server did not exit within 30 s of SIGTERM (killed)".into())
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Reads a pipe to its end on a thread of its own, so the server never
/// blocks on a full pipe. Stdout (`addr` given) sends the listening
/// address once and counts `WARN`/`ERROR` lines; on stderr every line
/// counts.
fn drain(
    pipe: impl Read + Send + 'static,
    log: Arc<Mutex<Log>>,
    addr: Option<mpsc::Sender<String>>,
) {
    std::thread::spawn(move || {
        for line in BufReader::new(pipe).lines().map_while(Result::ok) {
            if let Some(tx) = &addr {
                if let Some(rest) = line.split("addr=").nth(1) {
                    let _ = tx.send(rest.split_whitespace().next().unwrap_or("").to_string());
                }
            }
            let mut log = log.lock().expect("log lock");
            let counter = match addr {
                None => &mut log.stderr_lines,
                Some(_) if line.contains(" WARN ") => &mut log.warnings,
                Some(_) if line.contains(" ERROR ") => &mut log.errors,
                Some(_) => continue,
            };
            *counter += 1;
            if log.first.len() < FIRST_LINES {
                log.first.push(line);
            }
        }
    });
}
