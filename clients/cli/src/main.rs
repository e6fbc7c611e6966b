//! `frusta`: offline tools for inspecting scenes, tracing single rays and
//! computing impulse responses, and a client of `frusta-server` for the
//! same work on its scenes.

mod auralize;
mod collide;
mod info;
mod ir;
mod progress;
mod remote;
mod report;
mod shadows;
mod simulation_args;
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
    about = "Inspect frusta scenes, trace rays, compute impulse responses and collisions, offline or on a frusta server"
)]
struct Cli {
    /// The frusta server for `scenes`, `stream`, `ir --scene-id` and
    /// `collide --scene-id`, e.g.
    /// `http://127.0.0.1:8080`; offline commands ignore it.
    #[arg(long, global = true, env = "FRUSTA_SERVER", value_name = "URL")]
    server: Option<String>,
    /// API key for a server that requires one, sent as `Authorization: Bearer KEY`.
    #[arg(
        long,
        global = true,
        env = "FRUSTA_API_KEY",
        hide_env_values = true,
        value_name = "KEY"
    )]
    api_key: Option<String>,
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
    /// Impulse response from a source to a listener by frustum tracing,
    /// here or (with `--scene-id`) on the server.
    Ir(Box<ir::IrArgs>),
    /// Which triangles touch, come within a distance, or meet while objects
    /// move, here or (with `--scene-id`) on the server.
    Collide(Box<collide::CollideArgs>),
    /// Where a light (point, spot, directional or area) reaches in a
    /// camera's view, as a PNG, here or (with `--scene-id`) on the server.
    Shadows(Box<shadows::ShadowArgs>),
    /// The server's scenes (needs `--server`).
    Scenes {
        #[command(subcommand)]
        command: remote::scenes::ScenesCommand,
    },
    /// Stream impulse responses from the server to a moving listener and
    /// measure latency (needs `--server`).
    Stream(Box<remote::stream::StreamArgs>),
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
    let cli = Cli::parse();
    let server = || remote::client(cli.server.as_deref(), cli.api_key.as_deref());
    let result = match &cli.command {
        Command::Scene {
            command: SceneCommand::Info { path, json },
        } => info::run(path, *json),
        Command::Trace {
            scene,
            origin,
            direction,
            json,
        } => trace::run(scene, *origin, *direction, *json),
        Command::Ir(args) => match &args.scene_id {
            Some(id) => server().and_then(|s| remote::ir::run(&s, id, args)),
            None => ir::run(args),
        },
        Command::Collide(args) => match &args.scene_id {
            Some(id) => server().and_then(|s| collide::run_remote(&s, id, args)),
            None => collide::run(args),
        },
        Command::Shadows(args) => match &args.scene_id {
            Some(id) => server().and_then(|s| shadows::run_remote(&s, id, args)),
            None => shadows::run(args),
        },
        Command::Scenes { command } => server().and_then(|s| remote::scenes::run(&s, command)),
        Command::Stream(args) => server().and_then(|s| remote::stream::run(&s, args)),
        Command::Auralize { ir, dry, out } => auralize::run(ir, dry, out),
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
