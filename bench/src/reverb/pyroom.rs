//! pyroomacoustics' hybrid (image sources to the same order, then its ray
//! tracer with the same ray count and length) as a peer for box rooms:
//! `bench/peers/pyroom_hybrid.py`, set up by `bench/peers/setup.sh`. Its
//! broadband response is split into octave bands by frusta's filter bank
//! and measured by the same ISO 3382 code as frusta's, so the parameters
//! differ only by what the two simulations computed.

use frusta_engine::acoustics::signal::{filter_and_sum, RoomParameters};
use frusta_engine::scene::{BAND_COUNT, OCTAVE_BANDS_HZ};
use glam::DVec3;
use serde_json::{json, Value};

use super::theory::BoxWalls;
use crate::propagation::pyroom::run_script;

/// What the peer answered for one room.
pub struct Hybrid {
    pub ms: f64,
    pub threads: usize,
    pub version: String,
    /// Per band of [`OCTAVE_BANDS_HZ`].
    pub parameters: Vec<RoomParameters>,
    /// Its broadband response, and per band the squared band signal as an
    /// echogram.
    pub rir: Vec<f32>,
    pub echograms: Vec<Vec<(f64, f64)>>,
}

/// One room's job for the script.
pub struct Job<'a> {
    pub walls: &'a BoxWalls,
    pub source: DVec3,
    pub listener: DVec3,
    pub order: u32,
    pub rays: u32,
    pub length_s: f64,
    pub speed: f64,
}

fn wall(walls: &BoxWalls, axis: usize, side: usize) -> Value {
    json!({
        "absorption": walls.absorption[axis][side],
        "scattering": walls.scattering[axis][side],
    })
}

/// Runs the peer on `job`; an error says why it could not.
pub fn run(job: &Job) -> Result<Hybrid, String> {
    const RATE: u32 = 48_000;
    let w = job.walls;
    let room = json!({
        "name": "room",
        "size": (w.max - w.min).to_array(),
        "walls": {
            "west": wall(w, 0, 0), "east": wall(w, 0, 1),
            "south": wall(w, 1, 0), "north": wall(w, 1, 1),
            "floor": wall(w, 2, 0), "ceiling": wall(w, 2, 1),
        },
        "center_freqs": OCTAVE_BANDS_HZ,
        "source": (job.source - w.min).to_array(),
        "listener": (job.listener - w.min).to_array(),
        "max_order": job.order,
        "rays": job.rays,
        "length_s": job.length_s,
        "fs": RATE,
        "c": job.speed,
    });
    let answer = run_script("pyroom_hybrid.py", &json!({ "rooms": [room] }))?;
    let r = &answer["rooms"][0];
    if let Some(e) = r.get("error") {
        return Err(format!("pyroom_hybrid.py: {e}"));
    }
    let rir: Vec<f32> = r["rir"]
        .as_array()
        .ok_or("pyroom_hybrid.py answered no rir")?
        .iter()
        .map(|v| v.as_f64().unwrap_or(0.0) as f32)
        .collect();
    let mut parameters = Vec::new();
    let mut echograms = Vec::new();
    for b in 0..BAND_COUNT {
        let mut bands = vec![vec![0.0f32; rir.len()]; BAND_COUNT];
        bands[b].clone_from(&rir);
        let band = filter_and_sum(&bands, RATE).map_err(|e| e.to_string())?;
        parameters.push(RoomParameters::from_signal(&band, RATE).map_err(|e| e.to_string())?);
        let rate = f64::from(RATE);
        echograms.push(
            band.iter()
                .enumerate()
                .map(|(i, &v)| (i as f64 / rate, f64::from(v).powi(2)))
                .collect(),
        );
    }
    Ok(Hybrid {
        ms: r["seconds"].as_f64().unwrap_or(f64::NAN) * 1e3,
        threads: r["threads"].as_u64().unwrap_or(1) as usize,
        version: r["version"].as_str().unwrap_or("?").to_string(),
        parameters,
        rir,
        echograms,
    })
}
