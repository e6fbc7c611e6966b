//! The pyroomacoustics peer: `bench/peers/setup.sh` once, then one JSON job
//! on the stdin of `bench/peers/pyroom_ism.py` (see `bench/peers/README.md`).
//! Its image-source model is libroom's single-threaded C++ (no thread pool
//! in `Room::image_source_model`), so its rows say 1 thread.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use glam::DVec3;
use serde_json::{json, Value};

use super::walls::Wall;

/// One room at one order, in one of the two inputs.
pub struct Job {
    pub scene: &'static str,
    /// `pyroomacoustics` (polygon walls) or `pyroomacoustics-triangles`.
    pub imp: &'static str,
    pub order: u32,
    pub walls: Vec<Wall>,
    pub source: DVec3,
    pub listener: DVec3,
}

/// The peer's answer for one job.
pub struct Outcome {
    pub scene: &'static str,
    pub imp: &'static str,
    pub order: u32,
    pub walls: usize,
    pub ms: f64,
    pub paths: usize,
    pub duplicates: usize,
    /// The visible image sources, the direct path's (the source) included.
    pub image_sources: Vec<DVec3>,
}

fn peers_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("peers")
}

/// Runs the setup script, then `script` (in `bench/peers`) with `job` on
/// its stdin, and reads its JSON answer. An error says why the peer can't
/// run; the caller goes on without it.
pub(crate) fn run_script(script: &str, job: &Value) -> Result<Value, String> {
    let dir = peers_dir();
    let setup = Command::new("bash")
        .arg(dir.join("setup.sh"))
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("could not run setup.sh: {e}"))?;
    if !setup.status.success() {
        return Err(format!("setup.sh failed ({})", setup.status));
    }
    let python = String::from_utf8_lossy(&setup.stdout).trim().to_string();
    if python.is_empty() {
        return Err("setup.sh printed no python path".into());
    }
    let job = serde_json::to_vec(job).map_err(|e| e.to_string())?;
    let mut child = Command::new(&python)
        .arg(dir.join(script))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("could not start {python}: {e}"))?;
    child
        .stdin
        .take()
        .expect("piped stdin")
        .write_all(&job)
        .map_err(|e| format!("writing the job: {e}"))?;
    let out = child
        .wait_with_output()
        .map_err(|e| format!("waiting for {script}: {e}"))?;
    if !out.status.success() {
        return Err(format!("{script} failed ({})", out.status));
    }
    serde_json::from_slice(&out.stdout).map_err(|e| format!("{script} output: {e}"))
}

/// All jobs in one Python process.
pub fn run(jobs: &[Job]) -> Result<Vec<Outcome>, String> {
    let rooms: Vec<Value> = jobs
        .iter()
        .map(|j| {
            json!({
                "name": format!("{}-{}-o{}", j.imp, j.scene, j.order),
                "walls": j.walls.iter().map(|w| json!({
                    "corners": w.corners.iter().map(|p| p.to_array()).collect::<Vec<_>>(),
                    "absorption": w.absorption,
                })).collect::<Vec<_>>(),
                "source": j.source.to_array(),
                "listener": j.listener.to_array(),
                "max_order": j.order,
            })
        })
        .collect();
    let result = run_script("pyroom_ism.py", &json!({ "rooms": rooms }))?;
    let rooms = result["rooms"]
        .as_array()
        .ok_or("pyroom_ism.py output has no rooms")?;
    let mut outcomes = Vec::new();
    for (j, r) in jobs.iter().zip(rooms) {
        if let Some(e) = r.get("error") {
            eprintln!("warning: {} on {} order {}: {e}", j.imp, j.scene, j.order);
            continue;
        }
        let num = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        let image_sources = r["image_sources"]
            .as_array()
            .ok_or("pyroom_ism.py output has no image_sources")?
            .iter()
            .map(|p| {
                let c = |i: usize| p[i].as_f64().unwrap_or(f64::NAN);
                DVec3::new(c(0), c(1), c(2))
            })
            .collect();
        outcomes.push(Outcome {
            scene: j.scene,
            imp: j.imp,
            order: j.order,
            walls: num("walls") as usize,
            ms: num("seconds") * 1e3,
            paths: num("paths") as usize,
            duplicates: num("duplicates") as usize,
            image_sources,
        });
    }
    Ok(outcomes)
}
