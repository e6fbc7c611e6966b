//! Where a saved result came from: the command that made it, the commit and
//! the machine, so a figure in the README can be traced and rerun.

use std::path::Path;
use std::process::Command;

use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Machine {
    /// `model name` from `/proc/cpuinfo`.
    pub cpu: String,
    pub logical_cpus: usize,
    /// Rayon threads used by the run.
    pub threads: usize,
    /// 1-minute load average at the start and the end: the machine is
    /// shared, and a load above the thread count means the figures are from
    /// a busy machine.
    pub load_average: [f64; 2],
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Provenance {
    pub command: String,
    /// `git rev-parse HEAD` of the workspace.
    pub commit: String,
    /// Paths with uncommitted changes when the run started
    /// (`git status --porcelain`, tracked files).
    pub uncommitted: Vec<String>,
    pub machine: Machine,
}

fn git(args: &[&str]) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    Command::new("git")
        .args(args)
        .current_dir(root)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default()
}

/// The 1-minute load average (0 where `/proc/loadavg` is missing).
pub fn load_average() -> f64 {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or(0.0)
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

fn quote(arg: String) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "-_./=,:+".contains(c);
    if !arg.is_empty() && arg.chars().all(plain) {
        arg
    } else {
        format!("'{}'", arg.replace('\'', r"'\''"))
    }
}

/// This process's command line as the `cargo run` that reproduces it (the
/// same profile and features), with `FRUSTA_SHARED_DIR` when it is set.
pub fn command() -> String {
    let env = std::env::var("FRUSTA_SHARED_DIR")
        .map(|d| format!("FRUSTA_SHARED_DIR={} ", quote(d)))
        .unwrap_or_default();
    let release = if cfg!(debug_assertions) {
        ""
    } else {
        " --release"
    };
    let features = if cfg!(feature = "embree") {
        " --features embree"
    } else {
        ""
    };
    let args: Vec<String> = std::env::args().skip(1).map(quote).collect();
    format!(
        "{env}cargo run{release} -p frusta-bench{features} -- {}",
        args.join(" ")
    )
}

/// Taken at the start of a run; [`Provenance::finish`] adds the end's load.
pub fn start(threads: usize) -> Provenance {
    Provenance {
        command: command(),
        commit: git(&["rev-parse", "HEAD"]).trim().to_string(),
        uncommitted: git(&["status", "--porcelain", "--untracked-files=no"])
            .lines()
            .filter_map(|l| l.get(3..).map(str::to_string))
            .collect(),
        machine: Machine {
            cpu: cpu_model(),
            logical_cpus: std::thread::available_parallelism().map_or(0, |n| n.get()),
            threads,
            load_average: [load_average(), 0.0],
        },
    }
}

impl Provenance {
    pub fn finish(&mut self) {
        self.machine.load_average[1] = load_average();
    }

    /// The header lines of a saved text result.
    pub fn header(&self) -> String {
        let m = &self.machine;
        let uncommitted = if self.uncommitted.is_empty() {
            "none".to_string()
        } else {
            self.uncommitted.join(", ")
        };
        format!(
            "command: {}\ncommit: {} (uncommitted changes: {uncommitted})\n\
             machine: {}, {} logical CPUs, {} threads; load average {:.2} at start, {:.2} at end\n",
            self.command,
            self.commit,
            m.cpu,
            m.logical_cpus,
            m.threads,
            m.load_average[0],
            m.load_average[1]
        )
    }
}

/// Prints a run, as pretty JSON (`printed`) or its text table, and with
/// `save` writes `NAME.json` (`saved`: the run with its provenance) and
/// `NAME.txt` (the table) into that directory.
pub fn emit(
    name: &str,
    printed: &impl Serialize,
    saved: &impl Serialize,
    text: &str,
    json: bool,
    save: Option<&Path>,
) -> Result<(), String> {
    if json {
        let out = serde_json::to_string_pretty(printed).map_err(|e| e.to_string())?;
        println!("{out}");
    } else {
        print!("{text}");
    }
    if let Some(dir) = save {
        let out = serde_json::to_string_pretty(saved).map_err(|e| e.to_string())?;
        std::fs::write(dir.join(format!("{name}.json")), out + "\n").map_err(|e| e.to_string())?;
        std::fs::write(dir.join(format!("{name}.txt")), text).map_err(|e| e.to_string())?;
    }
    Ok(())
}
