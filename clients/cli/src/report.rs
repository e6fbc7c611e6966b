//! How `frusta ir` prints an impulse response, computed here or by a
//! server: both are the service's answer type, the offline one converted
//! from the engine's `Response` directly.

use std::error::Error;
use std::path::Path;

use frusta_client::api::impulse_responses::PairResponse;

/// Prints `response` as pretty JSON or as the text report; `wav` is where
/// its samples were written, if anywhere.
pub fn print(
    response: &PairResponse,
    as_json: bool,
    wav: Option<&Path>,
) -> Result<(), Box<dyn Error>> {
    if as_json {
        println!("{}", serde_json::to_string_pretty(response)?);
        return Ok(());
    }
    text(response);
    if let Some(path) = wav {
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn text(response: &PairResponse) {
    let s = &response.stats;
    println!(
        "{} paths, {} frusta, traced in {:.2} ms, diffraction {:.2} ms ({:.2} ms in all, {} threads)",
        s.paths, s.frusta, s.trace_ms, s.diffraction_ms, s.total_ms, s.threads
    );
    if let Some(t) = &s.tail {
        println!(
            "late reverberation: {} rays, {} reflections, {} shadow rays, sphere {:.2} m, room {:.0} m³, traced in {:.2} ms",
            t.rays, t.reflections, t.shadow_rays, t.receiver_radius_m, t.volume_m3, t.trace_ms
        );
    }
    println!("order  distance m   delay ms  gain at 1 kHz (dB)  surfaces");
    let khz = response.bands_hz.iter().position(|&b| b == 1000.0);
    for p in &response.paths {
        let gain = khz
            .and_then(|b| p.pressure_gain.get(b))
            .map_or(f32::NAN, |g| 20.0 * g.abs().log10());
        let surfaces: Vec<String> = p
            .surfaces
            .iter()
            .map(|e| match e.event.as_str() {
                "diffraction" => format!("edge of {}", e.material),
                _ => e.material.clone(),
            })
            .collect();
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
    for b in &response.parameters {
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
