//! `frusta-bench`: benchmarks for frusta.
//!
//! `frusta-bench bvh --mesh PATH [--json] [--rays N] [--rounds R] [--save DIR]`
//! compares our BVH with peer libraries on the same mesh and rays, in
//! interleaved rounds (see `bvh_bench`). Further
//! `frusta-bench propagation [--json] [--quick] [--plot FILE.png]` sweeps
//! frustum tracing against the independent reference, with pyroomacoustics
//! as a peer (see `propagation`),
//! and `frusta-bench serve [--json] [--quick] [--url URL]` loads the service
//! with impulse-response requests and a WebSocket stream (see `serve`);
//! `frusta-bench soak [--minutes M] [--clients C] [--quick] [--json]
//! [--save DIR]` runs the release server under a long mixed load and checks
//! that nothing fails and its memory stays flat (see `soak`);
//! `frusta-bench update [--scene NAME] [--save DIR]` times moving and
//! deforming one object by its size (see `update`);
//! `frusta-bench ccd` and `frusta-bench collide` measure continuous tests
//! and per-frame discrete collision with parry3d side by side;
//! `frusta-bench reverb [--scene NAME] [--json] [--save DIR]` sets hybrid
//! impulse responses beside exact image sources, Sabine and Eyring (see
//! `reverb`); `frusta-bench shadows [--scene NAME] [--json] [--save DIR]`
//! times hard shadows by shadow map, selective and full ray tracing (see
//! `shadows`); `frusta-bench lod [--hall SIZE] [--bound M] [--ir-bound M]
//! [--json] [--save DIR]` sets ray queries on levels of detail, and
//! impulse responses on scenes simplified by them, beside exact geometry
//! (see `lod`).

mod bvh_bench;
mod ccd;
mod collide;
mod jnd;
mod lod;
mod mesh;
mod propagation;
mod provenance;
mod rays;
mod report;
mod reuse;
mod reverb;
mod serve;
mod shadows;
mod soak;
mod stats;
mod update;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "frusta-bench", about = "Benchmarks for frusta")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// BVH build, refit and trace: ours vs bvh, obvhs, parry3d (and Embree
    /// with the `embree` feature).
    Bvh(bvh_bench::cli::Args),
    /// Specular paths by frustum tracing vs the independent reference over
    /// sampling N, order and cell mode (pyroomacoustics as a peer).
    Propagation(propagation::Args),
    /// The service under load: concurrent impulse-response requests, then
    /// a closed-loop WebSocket stream (listener moving, then source).
    Serve(serve::Args),
    /// The release server (a child process) under minutes of mixed load:
    /// uploads, edits, deletes, impulse responses, queries, streams; fails
    /// on any unexpected answer or growing memory.
    Soak(soak::Args),
    /// Moving and deforming one object of a hall: the cost by the object's
    /// size.
    Update(update::Args),
    /// Continuous vertex–face and edge–edge tests on the sample queries of
    /// Wang et al. 2021: false negatives, false positives, time per query.
    Ccd(ccd::Args),
    /// Discrete collision per frame: a deforming cloth against itself and
    /// a mesh against a moving copy, AABB vs OBB, with and without a BVTT
    /// front, parry3d side by side.
    Collide(collide::Args),
    /// Hybrid impulse responses (exact paths, then the stochastic tail):
    /// ISO 3382 parameters per band beside the exact image sources (box
    /// rooms), Sabine and Eyring, and the time of each part.
    Reverb(reverb::Args),
    /// A source moving in small steps, as a stream moves it: updates that
    /// reuse its frusta within a distance beside fresh traces, time and
    /// recall.
    Reuse(reuse::Args),
    /// Hard shadows of a moving light per frame: the plain shadow map,
    /// selective and full ray tracing side by side, wrong pixels counted.
    Shadows(shadows::Args),
    /// Ray queries with cones against levels of detail (R-LODs) at growing
    /// error bounds, and impulse responses on scenes simplified by them,
    /// beside exact geometry: time, hit displacement, energy and parameter
    /// errors.
    Lod(lod::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Bvh(args) => bvh_bench::cli::run(args),
        Command::Propagation(args) => propagation::run(args),
        Command::Serve(args) => serve::run(args),
        Command::Soak(args) => soak::run(args),
        Command::Update(args) => update::run(args),
        Command::Ccd(args) => ccd::run(args),
        Command::Collide(args) => collide::run(args),
        Command::Reverb(args) => reverb::run(args),
        Command::Reuse(args) => reuse::run(args),
        Command::Shadows(args) => shadows::run(args),
        Command::Lod(args) => lod::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
