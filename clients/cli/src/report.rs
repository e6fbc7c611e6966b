//! How `frusta ir` prints an impulse response. The text report reads the
//! response back from its JSON, so a response computed here and one a
//! server sent (the same fields, as JSON) print through one path.

use std::error::Error;
use std::path::Path;

use serde::{Deserialize, Serialize};

#[derive(Deserialize)]
struct Report {
    bands_hz: Vec<f32>,
    paths: Vec<SoundPath>,
    parameters: Vec<BandParameters>,
    stats: Stats,
}

#[derive(Deserialize)]
struct SoundPath {
    order: usize,
    distance_m: f64,
    delay_s: f64,
    surfaces: Vec<Surface>,
    pressure_gain: Vec<f32>,
}

#[derive(Deserialize)]
struct Surface {
    material: String,
}

#[derive(Deserialize)]
struct BandParameters {
    band_hz: f32,
    edt_s: Option<f64>,
    t20_s: Option<f64>,
    t30_s: Option<f64>,
    c50_db: Option<f64>,
    c80_db: Option<f64>,
    d50: Option<f64>,
    ts_s: Option<f64>,
}

#[derive(Deserialize)]
struct Stats {
    paths: usize,
    frusta: u64,
    trace_ms: f64,
    total_ms: f64,
    threads: usize,
}

/// Prints `response` (an engine `Response` or its JSON) as pretty JSON or
/// as the text report; `wav` is where its samples were written, if anywhere.
pub fn print(
    response: &impl Serialize,
    as_json: bool,
    wav: Option<&Path>,
) -> Result<(), Box<dyn Error>> {
    if as_json {
        println!("{}", serde_json::to_string_pretty(response)?);
        return Ok(());
    }
    let report: Report = serde_json::from_value(serde_json::to_value(response)?)?;
    report.print();
    if let Some(path) = wav {
        println!("wrote {}", path.display());
    }
    Ok(())
}

impl Report {
    fn print(&self) {
        let s = &self.stats;
        println!(
            "{} paths, {} frusta, traced in {:.2} ms ({:.2} ms in all, {} threads)",
            s.paths, s.frusta, s.trace_ms, s.total_ms, s.threads
        );
        println!("order  distance m   delay ms  gain at 1 kHz (dB)  surfaces");
        let khz = self.bands_hz.iter().position(|&b| b == 1000.0);
        for p in &self.paths {
            let gain = khz
                .and_then(|b| p.pressure_gain.get(b))
                .map_or(f32::NAN, |g| 20.0 * g.log10());
            let surfaces: Vec<&str> = p.surfaces.iter().map(|e| e.material.as_str()).collect();
            println!(
                "{:>5}  {:>10.4}  {:>9.4}  {:>18.2}  {}",
                p.order,
                p.distance_m,
                p.delay_s * 1e3,
                gain,
                surfaces.join(" > ")
            );
        }
        println!("band Hz    EDT s   T20 s   T30 s  C50 dB  C80 dB    D50    Ts s");
        let f = |v: Option<f64>| v.map_or("     -".to_string(), |v| format!("{v:>6.2}"));
        for b in &self.parameters {
            println!(
                "{:>7}  {}  {}  {}  {}  {}  {}  {}",
                b.band_hz,
                f(b.edt_s),
                f(b.t20_s),
                f(b.t30_s),
                f(b.c50_db),
                f(b.c80_db),
                f(b.d50),
                f(b.ts_s)
            );
        }
    }
}
