//! The simulation flags `frusta ir` and `frusta stream` share, so that a
//! simulation asked of the server is the one the same flags ask offline.

use clap::Args;
use frusta_engine::acoustics::signal::Channels;
use frusta_engine::acoustics::{CellAssignment, SimulationOptions, Tail, TailOptions};
use glam::Vec3;

use crate::vec3;

#[derive(Clone, Copy, clap::ValueEnum)]
enum Cells {
    Conservative,
    Sampled,
}

#[derive(Args)]
pub struct SimulationArgs {
    /// Source position `X,Y,Z`.
    #[arg(long, value_parser = vec3::parse, allow_hyphen_values = true)]
    pub source: Vec3,
    /// Listener position `X,Y,Z`.
    #[arg(long, value_parser = vec3::parse, allow_hyphen_values = true)]
    pub listener: Vec3,
    /// Highest reflection order.
    #[arg(long, default_value_t = 4)]
    max_order: u32,
    /// Sub-frusta per frustum side (N); default 2 with conservative cells,
    /// 8 with sampled cells.
    #[arg(long)]
    sampling: Option<u32>,
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
    /// Only the exact paths: no late reverberation.
    #[arg(long)]
    no_tail: bool,
    /// Rays of the late reverberation per source.
    #[arg(long, default_value_t = TailOptions::default().rays)]
    tail_rays: u32,
    /// Longest late reverberation, s.
    #[arg(long, default_value_t = TailOptions::default().max_length_s)]
    tail_length: f64,
    /// Seed of the late reverberation.
    #[arg(long, default_value_t = 0)]
    tail_seed: u64,
    /// Most edges a diffracted path bends around (0: none, at most 2).
    #[arg(long, default_value_t = SimulationOptions::default().diffraction_order)]
    diffraction_order: u32,
    /// Streams: how far a source may move before its frusta are traced
    /// again, m (within it they are re-mirrored; 0: trace every move).
    #[arg(long, default_value_t = SimulationOptions::default().source_reuse_m)]
    source_reuse: f64,
    /// Levels of detail: simplify every object within this many metres
    /// (features smaller than it cost no frusta; 0: exact geometry).
    #[arg(long, default_value_t = 0.0)]
    pub lod_error: f32,
}

impl SimulationArgs {
    /// The simulation options these flags ask for; the server takes the
    /// same type as JSON.
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
            tail: if self.no_tail {
                Tail::None
            } else {
                Tail::Stochastic(TailOptions {
                    rays: self.tail_rays,
                    max_length_s: self.tail_length,
                    seed: self.tail_seed,
                    receiver_radius_m: None,
                })
            },
            diffraction_order: self.diffraction_order,
            source_reuse_m: self.source_reuse,
            ..defaults
        }
    }
}
