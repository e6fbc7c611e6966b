//! `frusta ir`: the impulse response from one source to one listener, its
//! paths and ISO 3382-1 parameters, as text or JSON, optionally as WAV.

use std::error::Error;
use std::path::PathBuf;

use clap::Args;
use frusta_engine::acoustics::signal::{write_wav, Channels};
use frusta_engine::acoustics::{simulate, AcousticScene, CellAssignment, SimulationOptions};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene};
use glam::Vec3;

use crate::vec3;

#[derive(Clone, Copy, clap::ValueEnum)]
enum Cells {
    Conservative,
    Sampled,
}

#[derive(Args)]
pub struct IrArgs {
    /// Scene file (`.json`, `.obj`, `.gltf`, `.glb`).
    #[arg(long, conflicts_with = "shoebox", required_unless_present = "shoebox")]
    scene: Option<PathBuf>,
    /// Instead of a scene: an axis-aligned box room from the origin to `LX,LY,LZ`.
    #[arg(long, value_parser = vec3::parse, requires = "absorption")]
    shoebox: Option<Vec3>,
    /// Energy absorption of every wall of `--shoebox`, all bands.
    #[arg(long)]
    absorption: Option<f32>,
    /// Source position `X,Y,Z`.
    #[arg(long, value_parser = vec3::parse, allow_hyphen_values = true)]
    source: Vec3,
    /// Listener position `X,Y,Z`.
    #[arg(long, value_parser = vec3::parse, allow_hyphen_values = true)]
    listener: Vec3,
    /// Highest reflection order.
    #[arg(long, default_value_t = 4)]
    max_order: u32,
    /// Sub-frusta per frustum side (N).
    #[arg(long, default_value_t = 8)]
    sampling: u32,
    /// Hand sub-frusta to every triangle they touch (`conservative`: every
    /// image source) or to what their sample rays hit (`sampled`: faster in
    /// detailed scenes).
    #[arg(long, value_enum, default_value_t = Cells::Conservative)]
    cells: Cells,
    #[arg(long, default_value_t = 48_000)]
    sample_rate: u32,
    /// Turn air absorption (ISO 9613-1, 20 °C, 50 % RH) off.
    #[arg(long)]
    no_air: bool,
    /// Two channels from a spherical-head model instead of one.
    #[arg(long)]
    binaural: bool,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Write the impulse response as 32-bit float WAV.
    #[arg(long)]
    out: Option<PathBuf>,
}

impl IrArgs {
    fn scene(&self) -> Result<Scene, Box<dyn Error>> {
        match (&self.scene, self.shoebox) {
            (Some(path), _) => Ok(Scene::load(path)?),
            (None, Some(size)) => {
                let absorption = self.absorption.unwrap_or_default();
                let room = BoxRoom::new(Vec3::ZERO, size).generate()?;
                Ok(Scene::single_object(
                    "shoebox",
                    room,
                    Material::uniform("walls", absorption)?,
                )?)
            }
            (None, None) => Err("give --scene PATH or --shoebox LX,LY,LZ --absorption A".into()),
        }
    }

    /// The simulation options these flags ask for.
    pub fn options(&self) -> SimulationOptions {
        let defaults = SimulationOptions::default();
        SimulationOptions {
            max_order: self.max_order,
            sampling: self.sampling,
            cells: match self.cells {
                Cells::Conservative => CellAssignment::Conservative,
                Cells::Sampled => CellAssignment::Sampled,
            },
            sample_rate: self.sample_rate,
            air: if self.no_air { None } else { defaults.air },
            channels: if self.binaural {
                Channels::Binaural
            } else {
                Channels::Mono
            },
            ..defaults
        }
    }
}

pub fn run(args: &IrArgs) -> Result<(), Box<dyn Error>> {
    let scene = AcousticScene::new(&args.scene()?);
    let response = simulate(&scene, &[args.source], &[args.listener], &args.options())?
        .pop()
        .ok_or("no response")?;
    if let Some(path) = &args.out {
        write_wav(path, &response.impulse_response)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&response)?);
        return Ok(());
    }
    let s = &response.stats;
    println!(
        "{} paths, {} frusta, traced in {:.2} ms ({:.2} ms in all, {} threads)",
        s.paths, s.frusta, s.trace_ms, s.total_ms, s.threads
    );
    println!("order  distance m   delay ms  gain at 1 kHz (dB)  surfaces");
    let khz = response.bands_hz.iter().position(|&b| b == 1000.0);
    for p in &response.paths {
        let gain = khz.map_or(f32::NAN, |b| 20.0 * p.pressure_gain[b].log10());
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
    for b in &response.parameters {
        let p = &b.parameters;
        println!(
            "{:>7}  {}  {}  {}  {}  {}  {}  {}",
            b.band_hz,
            f(p.edt_s),
            f(p.t20_s),
            f(p.t30_s),
            f(p.c50_db),
            f(p.c80_db),
            f(p.d50),
            f(p.ts_s)
        );
    }
    if let Some(path) = &args.out {
        println!("wrote {}", path.display());
    }
    Ok(())
}
