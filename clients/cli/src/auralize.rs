//! `frusta auralize`: a dry recording convolved with an impulse response.

use std::error::Error;
use std::path::Path;

use frusta_engine::acoustics::signal::{auralize, read_wav, write_wav, ImpulseResponse};

pub fn run(ir: &Path, dry: &Path, out: &Path) -> Result<(), Box<dyn Error>> {
    let (ir_rate, ir_channels) = read_wav(ir)?;
    let (dry_rate, dry_channels) = read_wav(dry)?;
    let response = ImpulseResponse {
        sample_rate: ir_rate,
        channels: ir_channels,
    };
    let wet = auralize(&dry_channels, dry_rate, &response)?;
    // Normalise only if the result would clip: a float WAV can hold it, but
    // most players cannot.
    let peak = wet.iter().flatten().fold(0.0f32, |m, &x| m.max(x.abs()));
    let gain = if peak > 1.0 { 1.0 / peak } else { 1.0 };
    let channels = wet
        .into_iter()
        .map(|c| c.into_iter().map(|x| x * gain).collect())
        .collect();
    write_wav(
        out,
        &ImpulseResponse {
            sample_rate: dry_rate,
            channels,
        },
    )?;
    println!(
        "wrote {} ({} Hz){}",
        out.display(),
        dry_rate,
        if gain < 1.0 {
            format!(", scaled by {gain:.3} to avoid clipping")
        } else {
            String::new()
        }
    );
    Ok(())
}
