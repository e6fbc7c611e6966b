//! `frusta-bench`: benchmarks for frusta.
//!
//! `frusta-bench bvh --mesh PATH [--json] [--rays N]` compares our BVH with
//! peer libraries on the same mesh and rays (see `bvh_bench`). Further
//! `frusta-bench propagation [--json] [--quick] [--plot FILE.png]` sweeps
//! frustum tracing against the image-source reference (see `propagation`),
//! and `frusta-bench serve [--json] [--quick] [--url URL]` loads the service
//! with impulse-response requests and a WebSocket stream (see `serve`).

mod bvh_bench;
mod mesh;
mod propagation;
mod rays;
mod report;
mod serve;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use bvh_bench::{Input, IMPLS};
use mesh::BenchMesh;
use report::MeshReport;

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
    Bvh(BvhArgs),
    /// Specular paths by frustum tracing vs the exact image-source
    /// reference over sampling N and order (pyroomacoustics as a peer).
    Propagation(propagation::Args),
    /// The service under load: concurrent impulse-response requests, then
    /// a closed-loop WebSocket stream (listener moving, then source).
    Serve(serve::Args),
}

#[derive(clap::Args)]
struct BvhArgs {
    /// Mesh or scene file (OBJ, glTF or scene JSON, flattened to one mesh):
    /// a path, or a name in `<shared>/data/meshes/` (repeatable).
    #[arg(long)]
    mesh: Vec<String>,
    /// A bundled hall scene, `scenes/hall-<SIZE>.json` (repeatable).
    #[arg(long, value_parser = ["10k", "200k"])]
    hall: Vec<String>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Rays per set (the camera image is rounded to 8x8 tiles).
    #[arg(long, default_value_t = 1 << 20)]
    rays: usize,
    /// Comma-separated implementations to run (default: all compiled in).
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Rayon threads (default: rayon's default, all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Timed builds (and refits: twice this many) per implementation; median.
    #[arg(long, default_value_t = 3)]
    build_runs: usize,
    /// Timed passes per ray set; best.
    #[arg(long, default_value_t = 3)]
    trace_runs: usize,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Bvh(args) => bvh(args),
        Command::Propagation(args) => propagation::run(args),
        Command::Serve(args) => serve::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The meshes to run on: `--mesh` files, then `--hall` scenes.
fn meshes(args: &BvhArgs) -> Result<Vec<BenchMesh>, String> {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let halls = args
        .hall
        .iter()
        .map(|size| scenes.join(format!("hall-{size}.json")));
    let paths: Vec<PathBuf> = args
        .mesh
        .iter()
        .map(|m| mesh::resolve(m))
        .chain(halls)
        .collect();
    if paths.is_empty() {
        return Err("give --mesh PATH or --hall SIZE".into());
    }
    paths.iter().map(|p| mesh::load(p)).collect()
}

fn bvh(args: BvhArgs) -> Result<(), String> {
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| e.to_string())?;
    }
    let threads = rayon::current_num_threads();
    let selected: Vec<&str> = IMPLS
        .iter()
        .copied()
        .filter(|i| args.only.is_empty() || args.only.iter().any(|o| o == i))
        .collect();
    for o in &args.only {
        if !IMPLS.contains(&o.as_str()) {
            return Err(format!("unknown implementation {o:?}; known: {IMPLS:?}"));
        }
    }

    let mut reports = Vec::new();
    for m in meshes(&args)? {
        let bounds = m.mesh.bounds();
        let (w, h) = rays::camera_size(args.rays);
        let coherent = rays::coherent(&bounds, w, h);
        let incoherent = rays::incoherent(&bounds, coherent.len(), 0x5EED_F00D);
        let mut input = Input {
            mesh: &m,
            coherent: &coherent,
            incoherent: &incoherent,
            reference: None,
            build_runs: args.build_runs,
            trace_runs: args.trace_runs,
        };
        // Ours first: its closest hits are the reference for the others.
        let ours = bvh_bench::run_named("frusta", &input).expect("frusta is always built");
        input.reference = Some(&ours.distances);
        let mut results = Vec::new();
        if selected.contains(&"frusta") {
            results.push(ours.result.clone());
        }
        for name in selected.iter().filter(|&&n| n != "frusta") {
            eprintln!("[{}] {name}...", m.name);
            match bvh_bench::run_named(name, &input) {
                Some(r) => {
                    if r.result.mismatch_fraction > 1e-4 {
                        eprintln!(
                            "warning: {name} on {}: {:.3}% of closest hits differ from ours",
                            m.name,
                            100.0 * r.result.mismatch_fraction
                        );
                    }
                    results.push(r.result);
                }
                None => eprintln!("note: {name} not compiled in (feature `embree`)"),
            }
        }
        reports.push(MeshReport {
            mesh: m.name.clone(),
            triangles: m.mesh.triangle_count(),
            threads,
            rays: coherent.len(),
            results,
        });
        if !args.json {
            println!("{}", report::table(reports.last().unwrap()));
        }
    }
    if args.json {
        let json = if reports.len() == 1 {
            serde_json::to_string(&reports[0])
        } else {
            serde_json::to_string(&serde_json::json!({ "meshes": reports }))
        };
        println!("{}", json.map_err(|e| e.to_string())?);
    }
    Ok(())
}
