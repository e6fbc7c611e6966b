//! `frusta`: offline tools for inspecting scenes, tracing single rays and
//! computing impulse responses, without running the service.

mod auralize;
mod info;
mod ir;
mod trace;
mod vec3;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use glam::Vec3;

#[derive(Parser)]
#[command(
    name = "frusta",
    version,
    about = "Inspect frusta scenes, trace rays, compute impulse responses"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Scene commands.
    Scene {
        #[command(subcommand)]
        command: SceneCommand,
    },
    /// Trace one ray and print its closest hit.
    Trace {
        /// Scene file (`.json`, `.obj`, `.gltf`, `.glb`).
        #[arg(long)]
        scene: PathBuf,
        /// Ray origin as `X,Y,Z`.
        #[arg(long, value_parser = vec3::parse, allow_hyphen_values = true)]
        origin: Vec3,
        /// Ray direction as `X,Y,Z`; normalised, so `t` is a distance.
        #[arg(long, value_parser = vec3::parse, allow_hyphen_values = true)]
        direction: Vec3,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Impulse response from a source to a listener by frustum tracing.
    Ir(Box<ir::IrArgs>),
    /// Convolve a dry WAV with an impulse response WAV.
    Auralize {
        /// Impulse response WAV (e.g. from `frusta ir --out`).
        #[arg(long)]
        ir: PathBuf,
        /// Dry (anechoic) recording.
        #[arg(long)]
        dry: PathBuf,
        /// Output WAV.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Load a scene, build its BVH, and print what it holds.
    Info {
        /// Scene file (`.json`, `.obj`, `.gltf`, `.glb`).
        path: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    let result = match Cli::parse().command {
        Command::Scene {
            command: SceneCommand::Info { path, json },
        } => info::run(&path, json),
        Command::Trace {
            scene,
            origin,
            direction,
            json,
        } => trace::run(&scene, origin, direction, json),
        Command::Ir(args) => ir::run(&args),
        Command::Auralize { ir, dry, out } => auralize::run(&ir, &dry, &out),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Rust ignores SIGPIPE, so `frusta ir | head` would panic in `println!`
/// once `head` exits; a command-line tool should end quietly instead, as
/// other Unix tools do.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before any other thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
