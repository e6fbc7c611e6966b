//! Everything an operator can set: flags with environment-variable twins,
//! and the per-request limits that keep one client from exhausting the
//! machine.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Parser;

#[derive(Clone, Debug, Parser)]
#[command(
    version,
    about = "Serve frusta scenes: impulse responses, streams and ray queries over HTTP and WebSocket"
)]
pub struct Config {
    /// Address to listen on.
    #[arg(long, env = "FRUSTA_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: SocketAddr,
    /// Where scenes and their edits are stored (created if absent).
    #[arg(long, env = "FRUSTA_DATA_DIR", default_value = "frusta-data")]
    pub data_dir: PathBuf,
    /// Scenes (`*.json`) added to a new, empty data directory so that a
    /// first start has something to simulate; relative to the working
    /// directory (from the repository's root: its bundled `scenes/`).
    #[arg(long, env = "FRUSTA_SCENES_DIR", default_value = "scenes")]
    pub scenes_dir: PathBuf,
    /// Comma-separated API keys. When set, every `/v1` request needs
    /// `Authorization: Bearer KEY`, and a scene can be changed only with the
    /// key that created it.
    #[arg(
        long,
        env = "FRUSTA_API_KEYS",
        value_delimiter = ',',
        hide_env_values = true
    )]
    pub api_keys: Vec<String>,
    #[command(flatten)]
    pub limits: Limits,
}

/// Caps per request and in total; each has a flag and an environment twin.
#[derive(Clone, Debug, clap::Args)]
pub struct Limits {
    /// Largest scene upload, in MiB.
    #[arg(long, env = "FRUSTA_MAX_UPLOAD_MIB", default_value_t = 256)]
    pub max_upload_mib: usize,
    /// Upload bytes the server buffers at once over all requests, in MiB:
    /// uploads past it wait for none and are refused (503, Retry-After).
    #[arg(long, env = "FRUSTA_MAX_BUFFERED_UPLOAD_MIB", default_value_t = 512)]
    pub max_buffered_upload_mib: usize,
    /// Most triangles in one scene.
    #[arg(long, env = "FRUSTA_MAX_TRIANGLES", default_value_t = 2_000_000)]
    pub max_triangles: usize,
    /// Most triangles in all scenes together (bounds memory).
    #[arg(long, env = "FRUSTA_MAX_TOTAL_TRIANGLES", default_value_t = 20_000_000)]
    pub max_total_triangles: usize,
    /// Highest reflection order a request may ask for.
    #[arg(long, env = "FRUSTA_MAX_ORDER", default_value_t = 8)]
    pub max_order: u32,
    /// Largest sub-frustum sampling (N) a request may ask for.
    #[arg(long, env = "FRUSTA_MAX_SAMPLING", default_value_t = 32)]
    pub max_sampling: u32,
    /// Most rays a request's late reverberation may trace per source.
    #[arg(long, env = "FRUSTA_MAX_TAIL_RAYS", default_value_t = 65_536)]
    pub max_tail_rays: u32,
    /// Most source-listener pairs in one request.
    #[arg(long, env = "FRUSTA_MAX_PAIRS", default_value_t = 64)]
    pub max_pairs: usize,
    /// Samples one request may produce in the worst case (pairs x channels
    /// x sample rate x the 60 s longest impulse response), in MiB.
    #[arg(long, env = "FRUSTA_MAX_IR_MIB", default_value_t = 1024)]
    pub max_ir_mib: u64,
    /// Compute time one simulation may take, in milliseconds.
    #[arg(long, env = "FRUSTA_MAX_COMPUTE_MS", default_value_t = 30_000)]
    pub max_compute_ms: u64,
    /// Simulations waiting for a core before new ones are refused (503).
    #[arg(long, env = "FRUSTA_MAX_QUEUED", default_value_t = 256)]
    pub max_queued: usize,
    /// Frusta a stream keeps per source so that moving listeners need no
    /// new trace (about 160 bytes each); a trace with more keeps none.
    #[arg(long, env = "FRUSTA_MAX_CACHED_FRUSTA", default_value_t = 500_000)]
    pub max_cached_frusta: usize,
    /// Open WebSocket streams.
    #[arg(long, env = "FRUSTA_MAX_STREAMS", default_value_t = 64)]
    pub max_streams: usize,
    /// Connections open at once; past it new ones wait in the listen
    /// backlog until one closes (keep it below the file-descriptor limit).
    #[arg(long, env = "FRUSTA_MAX_CONNECTIONS", default_value_t = 512)]
    pub max_connections: usize,
    /// Time a client has to send a request's headers, in seconds; a
    /// connection that takes longer is closed.
    #[arg(long, env = "FRUSTA_HEADER_TIMEOUT_S", default_value_t = 10)]
    pub header_timeout_s: u64,
    /// Time a whole request may take, in seconds.
    #[arg(long, env = "FRUSTA_REQUEST_TIMEOUT_S", default_value_t = 60)]
    pub request_timeout_s: u64,
}

impl Limits {
    /// Refuses settings under which the server could not work: an upload
    /// larger than the upload buffer would be refused for ever, a zero
    /// header timeout or connection cap would refuse every request.
    pub fn check(&self) -> Result<(), String> {
        if self.max_upload_mib > self.max_buffered_upload_mib {
            return Err(format!(
                "--max-upload-mib {} exceeds --max-buffered-upload-mib {}: such uploads could never be buffered",
                self.max_upload_mib, self.max_buffered_upload_mib
            ));
        }
        if self.header_timeout_s == 0 || self.max_connections == 0 {
            return Err("--header-timeout-s and --max-connections must be at least 1".into());
        }
        Ok(())
    }

    pub fn max_upload_bytes(&self) -> usize {
        self.max_upload_mib.saturating_mul(1024 * 1024)
    }

    /// When work starting now must end: one deadline for all the work of
    /// a request or a stream update, so their parts share the limit.
    pub fn compute_deadline(&self) -> Instant {
        Instant::now() + Duration::from_millis(self.max_compute_ms)
    }

    pub fn header_timeout(&self) -> Duration {
        Duration::from_secs(self.header_timeout_s)
    }

    pub fn request_timeout(&self) -> Duration {
        Duration::from_secs(self.request_timeout_s)
    }
}

impl Config {
    /// The defaults with another data directory: what tests and embedders
    /// start from.
    pub fn with_data_dir(data_dir: impl Into<PathBuf>) -> Self {
        let mut config = Self::parse_from(["frusta-server"]);
        config.data_dir = data_dir.into();
        config
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_that_could_never_work_are_refused() {
        let ok = Config::with_data_dir("unused").limits;
        assert!(ok.check().is_ok());
        let mut big_upload = ok.clone();
        big_upload.max_upload_mib = big_upload.max_buffered_upload_mib + 1;
        assert!(big_upload
            .check()
            .unwrap_err()
            .contains("--max-buffered-upload-mib"));
        for tweak in [
            |l: &mut Limits| l.header_timeout_s = 0,
            |l: &mut Limits| l.max_connections = 0,
        ] {
            let mut bad = ok.clone();
            tweak(&mut bad);
            assert!(bad.check().is_err());
        }
    }
}
