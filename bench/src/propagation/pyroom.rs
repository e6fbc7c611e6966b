//! The pyroomacoustics peer: `bench/peers/setup.sh` once, then one JSON job
//! on the stdin of `bench/peers/pyroom_ism.py` (see `bench/peers/README.md`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use frusta_engine::scene::Scene;
use glam::{DVec3, Vec3};
use serde_json::{json, Value};

/// One room at one order.
pub struct Job {
    pub scene: &'static str,
    pub order: u32,
    pub triangles: Vec<[[f32; 3]; 3]>,
    pub absorption: f32,
    pub source: DVec3,
    pub listener: DVec3,
}

/// The peer's answer for one job.
pub struct Outcome {
    pub scene: &'static str,
    pub order: u32,
    pub walls: usize,
    pub ms: f64,
    pub paths: usize,
    pub duplicates: usize,
}

fn peers_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("peers")
}

/// One wall per world triangle, and the area-weighted mean absorption of
/// the 1 kHz band (pyroomacoustics takes one value per room here).
pub fn walls(scene: &Scene) -> (Vec<[[f32; 3]; 3]>, f32) {
    const BAND_1K: usize = 4;
    let mut tris = Vec::new();
    let (mut area_sum, mut weighted) = (0.0f64, 0.0f64);
    for o in &scene.objects {
        let pos: Vec<Vec3> = o
            .mesh
            .positions()
            .iter()
            .map(|&p| Vec3::from(o.transform.transform_point(p.into())))
            .collect();
        for (t, &m) in o.mesh.triangles().iter().zip(&o.materials) {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            let area = f64::from(0.5 * (b - a).cross(c - a).length());
            let alpha = scene
                .materials
                .get(m as usize)
                .map_or(0.0, |m| m.absorption[BAND_1K]);
            area_sum += area;
            weighted += area * f64::from(alpha);
            tris.push([a.to_array(), b.to_array(), c.to_array()]);
        }
    }
    let mean = if area_sum > 0.0 {
        weighted / area_sum
    } else {
        0.0
    };
    (tris, mean as f32)
}

/// Runs the setup script, then all jobs in one Python process. An error
/// says why the peer can't run; the caller goes on without it.
pub fn run(jobs: &[Job]) -> Result<Vec<Outcome>, String> {
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
    let rooms: Vec<Value> = jobs
        .iter()
        .map(|j| {
            json!({
                "name": format!("{}-o{}", j.scene, j.order),
                "triangles": j.triangles,
                "absorption": j.absorption,
                "source": j.source.to_array(),
                "listener": j.listener.to_array(),
                "max_order": j.order,
            })
        })
        .collect();
    let job = serde_json::to_vec(&json!({ "rooms": rooms })).map_err(|e| e.to_string())?;
    let mut child = Command::new(&python)
        .arg(dir.join("pyroom_ism.py"))
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
        .map_err(|e| format!("waiting for pyroom_ism.py: {e}"))?;
    if !out.status.success() {
        return Err(format!("pyroom_ism.py failed ({})", out.status));
    }
    let result: Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("pyroom_ism.py output: {e}"))?;
    let rooms = result["rooms"]
        .as_array()
        .ok_or("pyroom_ism.py output has no rooms")?;
    let mut outcomes = Vec::new();
    for (j, r) in jobs.iter().zip(rooms) {
        if let Some(e) = r.get("error") {
            eprintln!(
                "warning: pyroomacoustics on {} order {}: {e}",
                j.scene, j.order
            );
            continue;
        }
        let num = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        outcomes.push(Outcome {
            scene: j.scene,
            order: j.order,
            walls: num("walls") as usize,
            ms: num("seconds") * 1e3,
            paths: num("paths") as usize,
            duplicates: num("duplicates") as usize,
        });
    }
    Ok(outcomes)
}
