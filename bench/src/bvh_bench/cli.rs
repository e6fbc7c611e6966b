//! `frusta-bench bvh`: arguments, the run over every mesh, and the saved
//! `bvh.json` / `bvh.txt`.

use std::path::PathBuf;

use serde::Serialize;

use super::check::{self, Reference};
use super::measure::Input;
use super::{impls, rounds};
use crate::mesh::{self, BenchMesh};
use crate::provenance::{self, Provenance};
use crate::rays;
use crate::report::{self, MeshReport};

/// Sampled rays per set for the refit check (brute force over every
/// triangle: a few seconds on the 200k hall)...
const CHECK_RAYS: usize = 1024;
/// ...and at most this many ray-triangle tests per set, so a massive hall
/// checks fewer rays (64 at least).
const CHECK_TESTS: usize = 1 << 29;

#[derive(clap::Args)]
pub struct Args {
    /// Mesh or scene file (OBJ, glTF or scene JSON, flattened to one mesh):
    /// a path, or a name in `<shared>/data/meshes/` (repeatable).
    #[arg(long)]
    mesh: Vec<String>,
    /// A hall: `scenes/hall-<SIZE>.json` where bundled (10k, 200k), else
    /// that hall generated at SIZE triangles (e.g. 20m) (repeatable).
    #[arg(long)]
    hall: Vec<String>,
    /// Print the JSON document instead of the tables.
    #[arg(long)]
    json: bool,
    /// Also write `bvh.json` and `bvh.txt` into this directory.
    #[arg(long)]
    save: Option<PathBuf>,
    /// Rays per set (the camera image is rounded to 8x8 tiles).
    #[arg(long, default_value_t = 1 << 20)]
    rays: usize,
    /// Comma-separated peers to run (default: all compiled in); ours always
    /// runs, as the reference of the ratios and the mismatch.
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Rayon threads, and Embree's (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Rounds: every implementation is measured once per round; medians.
    #[arg(long, default_value_t = 5)]
    rounds: usize,
    /// Timed builds per round (median; refits: twice this many).
    #[arg(long, default_value_t = 3)]
    build_runs: usize,
}

/// The saved document: provenance beside the results.
#[derive(Serialize)]
struct Document<'a> {
    #[serde(flatten)]
    provenance: &'a Provenance,
    rounds: usize,
    /// Per implementation: what its build and refit are, on which threads.
    notes: Vec<(&'static str, &'static str)>,
    meshes: &'a [MeshReport],
}

/// The meshes to run on: `--mesh` files, then `--hall` scenes.
fn meshes(args: &Args) -> Result<Vec<BenchMesh>, String> {
    if args.mesh.is_empty() && args.hall.is_empty() {
        return Err("give --mesh PATH or --hall SIZE".into());
    }
    let files = args.mesh.iter().map(|m| mesh::load(&mesh::resolve(m)));
    files
        .chain(args.hall.iter().map(|size| mesh::hall(size)))
        .collect()
}

fn one_mesh(m: &BenchMesh, args: &Args, selected: &[super::Impl], threads: usize) -> MeshReport {
    let bounds = m.mesh.bounds();
    let (w, h) = rays::camera_size(args.rays);
    let coherent = rays::coherent(&bounds, w, h);
    let incoherent = rays::incoherent(&bounds, coherent.len(), 0x5EED_F00D);
    let deformed = m.deformed_positions();
    let checked = (CHECK_TESTS / m.mesh.triangle_count().max(1)).clamp(64, CHECK_RAYS);
    let mut sample = check::sample(&coherent, checked);
    sample.extend(check::sample(&incoherent, checked));
    eprintln!("[{}] brute-force reference for the refit check...", m.name);
    let reference = Reference::new(&deformed, m.triangles(), sample);
    let input = Input {
        mesh: m,
        coherent: &coherent,
        incoherent: &incoherent,
        deformed: &deformed,
        refit_reference: &reference,
        build_runs: args.build_runs,
    };
    MeshReport {
        mesh: m.name.clone(),
        triangles: m.mesh.triangle_count(),
        threads,
        rays: coherent.len(),
        results: rounds::run(selected, &input, args.rounds),
    }
}

pub fn run(args: Args) -> Result<(), String> {
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| e.to_string())?;
    }
    let threads = rayon::current_num_threads();
    let all = impls();
    for o in &args.only {
        if !all.iter().any(|i| i.name == o) {
            let known: Vec<_> = all.iter().map(|i| i.name).collect();
            return Err(format!(
                "unknown implementation {o:?}; compiled in: {known:?} (Embree needs feature `embree`)"
            ));
        }
    }
    let selected: Vec<_> = all
        .into_iter()
        .filter(|i| {
            i.name == "frusta" || args.only.is_empty() || args.only.iter().any(|o| o == i.name)
        })
        .collect();
    let mut provenance = provenance::start(threads);
    let mut reports = Vec::new();
    let mut tables = Vec::new();
    let mut wrong = Vec::new();
    for m in meshes(&args)? {
        let report = one_mesh(&m, &args, &selected, threads);
        for r in &report.results {
            if r.mismatch_fraction > 1e-4 {
                eprintln!(
                    "warning: {} on {}: {:.3}% of closest hits differ from ours",
                    r.name,
                    m.name,
                    100.0 * r.mismatch_fraction
                );
            }
            if let Some(c) = r.refit_check.filter(|c| c.wrong > 0) {
                let line = format!(
                    "{} on {}: {} of {} sampled rays wrong after the refit",
                    r.name, m.name, c.wrong, c.checked
                );
                eprintln!("error: {line}");
                wrong.push(line);
            }
        }
        let table = report::table(&report, args.rounds);
        if !args.json {
            println!("{table}");
        }
        tables.push(table);
        reports.push(report);
    }
    provenance.finish();
    let doc = Document {
        provenance: &provenance,
        rounds: args.rounds,
        notes: selected.iter().map(|i| (i.name, i.note)).collect(),
        meshes: &reports,
    };
    let json = serde_json::to_string(&doc).map_err(|e| e.to_string())?;
    if args.json {
        println!("{json}");
    }
    if let Some(dir) = &args.save {
        let text = format!(
            "{}{}\n{}",
            provenance.header(),
            notes(&doc.notes),
            tables.join("\n")
        );
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for (name, body) in [("bvh.json", json + "\n"), ("bvh.txt", text)] {
            let path = dir.join(name);
            std::fs::write(&path, body).map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(format!("refit check failed: {}", wrong.join("; ")))
    }
}

/// The legend of the tables.
fn notes(notes: &[(&str, &str)]) -> String {
    let mut s = String::from(
        "thr: threads the build runs on; refit wrong: sampled rays (both sets) whose closest hit after \
         the refit differs from brute force on the moved mesh, wrong/checked over all rounds\n",
    );
    for (name, note) in notes {
        s.push_str(&format!("{name}: {note}\n"));
    }
    s
}
