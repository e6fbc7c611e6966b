//! `frusta-bench collide`: discrete collision per frame on a deforming
//! cloth (self-collision) and on a mesh moving through a copy of itself
//! (a pair), with the trees' boxes or oriented boxes, with and without a
//! front kept between frames (the cloth's near pairs, the pair's BVTT
//! front), and the same queries through `parry3d`
//! in the same process. Every variant must find the same pairs, frame by
//! frame; parry's are compared with ours and differences reported.
//!
//! Each frame is a refit (the cloth's new vertices; nothing for a rigid
//! move, which changes only a transform) and the query; rounds replay
//! the whole animation once per variant, interleaved, and the figures are
//! medians over rounds.

mod cloth;
mod parry;

use std::path::PathBuf;
use std::time::Instant;

use frusta_engine::bvh::obb::ObbTree;
use frusta_engine::bvh::traverse::front::Front;
use frusta_engine::bvh::{BuildOptions, MeshBvh};
use frusta_engine::collision::{
    mesh_contacts, mesh_self_contacts, triangle_distance, NearPairs, Placed,
};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use glam::{Quat, Vec3};
use serde::Serialize;

use crate::provenance::{self, Provenance};
use crate::report::aligned;
use crate::serve::Latency;
use crate::stats::median;

#[derive(clap::Args)]
pub struct Args {
    /// Quads per side of the cloth (two triangles each; 158 gives 49,928).
    #[arg(long, default_value_t = 158)]
    cloth: usize,
    /// The mesh moved through a copy of itself (a path, or a name in
    /// `../shared/data/meshes`).
    #[arg(long, default_value = "stanford-bunny")]
    mesh: String,
    /// Frames of each animation.
    #[arg(long, default_value_t = 40)]
    frames: usize,
    /// Rounds over every variant; times are medians.
    #[arg(long, default_value_t = 5)]
    rounds: usize,
    /// Only this case: `cloth` (self) or `pair` (the moving copy).
    #[arg(long)]
    case: Option<String>,
    /// Only these bounding volumes: `aabb` or `obb`.
    #[arg(long)]
    bv: Option<String>,
    /// Only with (`yes`) or without (`no`) the front.
    #[arg(long)]
    front: Option<String>,
    /// Leave parry3d out.
    #[arg(long)]
    no_peer: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Also write `collide.txt` and `collide.json` (with provenance) here.
    #[arg(long)]
    save: Option<PathBuf>,
}

/// One variant of one case.
#[derive(Clone, Debug, Serialize)]
struct Run {
    case: String,
    kind: &'static str,
    triangles: usize,
    bv: &'static str,
    front: bool,
    frames: usize,
    ms_per_frame: f64,
    /// The 90th percentile of the frames' times (nearest rank), median
    /// over rounds.
    p90_frame_ms: f64,
    refit_ms: f64,
    query_ms: f64,
    /// Intersecting triangle pairs, summed over the frames.
    pairs: usize,
    parry3d_ms_per_frame: Option<f64>,
    parry3d_pairs: Option<usize>,
    /// Frames where parry's pairs differ from ours.
    parry3d_frames_differing: Option<usize>,
    /// Pairs parry reports that do not intersect (its GJK test decides
    /// within a tolerance), and the largest distance between such a pair's
    /// triangles.
    parry3d_extra_pairs: Option<usize>,
    parry3d_extra_max_distance: Option<f64>,
    /// Intersecting pairs parry does not report.
    parry3d_missed_pairs: Option<usize>,
}

/// How parry's answers differ from the exact ones, over all frames.
#[derive(Clone, Copy)]
struct Compared {
    extra: usize,
    extra_max_distance: f64,
    missed: usize,
}

/// Counts parry's extra and missed pairs frame by frame, measuring each
/// extra pair's distance (in f64, on the frame's world coordinates).
fn compare(case: &Case, exact: &[Vec<(u32, u32)>], peer: &[Vec<(u32, u32)>]) -> Compared {
    let mut c = Compared {
        extra: 0,
        extra_max_distance: 0.0,
        missed: 0,
    };
    let corners = |mesh: &TriangleMesh, t: u32, at: &RigidTransform| {
        let q = at.rotation.as_dquat();
        mesh.corners(t as usize)
            .map(|p| q * Vec3::from(p).as_dvec3() + at.translation.as_dvec3())
    };
    let fixed = RigidTransform::default();
    for (f, (ours, theirs)) in exact.iter().zip(peer).enumerate() {
        let ours_set: std::collections::BTreeSet<_> = ours.iter().collect();
        let theirs_set: std::collections::BTreeSet<_> = theirs.iter().collect();
        c.missed += ours.iter().filter(|p| !theirs_set.contains(p)).count();
        for &(p, q) in theirs.iter().filter(|p| !ours_set.contains(p)) {
            c.extra += 1;
            let (a, b) = match &case.motion {
                Motion::Deform(meshes) => (
                    corners(&meshes[f], p, &fixed),
                    corners(&meshes[f], q, &fixed),
                ),
                Motion::Move(poses) => (
                    corners(&case.mesh, p, &fixed),
                    corners(&case.mesh, q, &poses[f]),
                ),
            };
            c.extra_max_distance = c.extra_max_distance.max(triangle_distance(&a, &b));
        }
    }
    c
}

#[derive(Serialize)]
struct Report {
    runs: Vec<Run>,
}

#[derive(Serialize)]
struct Saved<'a> {
    #[serde(flatten)]
    provenance: Provenance,
    rounds: usize,
    #[serde(flatten)]
    report: &'a Report,
}

/// What a case animates.
enum Motion {
    /// New vertex positions per frame.
    Deform(Vec<TriangleMesh>),
    /// A pose per frame of the copy, relative to the fixed original.
    Move(Vec<RigidTransform>),
}

struct Case {
    name: String,
    mesh: TriangleMesh,
    motion: Motion,
}

impl Case {
    fn kind(&self) -> &'static str {
        match self.motion {
            Motion::Deform(_) => "self",
            Motion::Move(_) => "pair",
        }
    }

    fn frames(&self) -> usize {
        match &self.motion {
            Motion::Deform(f) => f.len(),
            Motion::Move(f) => f.len(),
        }
    }
}

/// The intersecting pairs of every frame.
type Frames = Vec<Vec<(u32, u32)>>;

/// Milliseconds of refit and of query over one replay, and its pairs.
struct Replay {
    refit_ms: f64,
    query_ms: f64,
    /// Each frame's refit and query.
    frame_ms: Vec<f64>,
    pairs: Frames,
}

impl Replay {
    fn new() -> Self {
        Self {
            refit_ms: 0.0,
            query_ms: 0.0,
            frame_ms: Vec::new(),
            pairs: Vec::new(),
        }
    }

    /// Counts one frame: its refit and query times and its pairs.
    fn frame(&mut self, refit_ms: f64, query_ms: f64, pairs: Vec<(u32, u32)>) {
        self.refit_ms += refit_ms;
        self.query_ms += query_ms;
        self.frame_ms.push(refit_ms + query_ms);
        self.pairs.push(pairs);
    }

    /// The frame time nine frames in ten stay within: where a front
    /// renews itself every few frames, those frames show here.
    fn p90_ms(&self) -> f64 {
        Latency::of(self.frame_ms.clone()).map_or(0.0, |l| l.p90)
    }
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// One replay of the case with our engine.
fn ours(case: &Case, obb: bool, front: bool) -> Result<Replay, String> {
    let err = |e: frusta_engine::Error| e.to_string();
    let mut bvh = MeshBvh::build(&case.mesh, &BuildOptions::default());
    let mut obbs = obb.then(|| ObbTree::fit(&bvh));
    let mut kept = front.then(Front::new);
    let mut near = front.then(|| NearPairs::new(&case.mesh));
    let mut replay = Replay::new();
    match &case.motion {
        Motion::Deform(frames) => {
            for mesh in frames {
                let t = Instant::now();
                bvh.refit(mesh).map_err(err)?;
                if let Some(o) = &mut obbs {
                    o.refit(&bvh);
                }
                let refit_ms = ms(t);
                let t = Instant::now();
                let pairs = mesh_self_contacts(&bvh, obbs.as_ref(), near.as_mut()).map_err(err)?;
                replay.frame(refit_ms, ms(t), pairs);
            }
        }
        Motion::Move(poses) => {
            let fixed = RigidTransform::default();
            for pose in poses {
                let t = Instant::now();
                let a = Placed {
                    mesh: &bvh,
                    to_world: &fixed,
                    obbs: obbs.as_ref(),
                };
                let b = Placed {
                    to_world: pose,
                    ..a
                };
                let pairs = mesh_contacts(a, b, kept.as_mut()).map_err(err)?;
                replay.frame(0.0, ms(t), pairs);
            }
        }
    }
    Ok(replay)
}

/// One replay of the case with parry3d.
fn peer(case: &Case) -> Replay {
    let mut mesh = parry::mesh(case.mesh.positions(), case.mesh.triangles());
    let mut replay = Replay::new();
    match &case.motion {
        Motion::Deform(frames) => {
            for f in frames {
                let t = Instant::now();
                parry::refit(&mut mesh, f.positions());
                let refit_ms = ms(t);
                let t = Instant::now();
                let pairs = parry::self_pairs(&mesh);
                replay.frame(refit_ms, ms(t), pairs);
            }
        }
        Motion::Move(poses) => {
            for pose in poses {
                let t = Instant::now();
                let pairs = parry::pairs(&mesh, &mesh, pose.rotation, pose.translation);
                replay.frame(0.0, ms(t), pairs);
            }
        }
    }
    replay
}

fn cloth_case(n: usize, frames: usize) -> Result<Case, String> {
    let triangles = cloth::triangles(n);
    let at = |s: f32| {
        TriangleMesh::new(cloth::positions(n, s), triangles.clone()).map_err(|e| e.to_string())
    };
    let span = (frames.max(2) - 1) as f32;
    let meshes = (0..frames)
        .map(|f| at(f as f32 / span))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Case {
        name: "cloth".into(),
        mesh: at(0.0)?,
        motion: Motion::Deform(meshes),
    })
}

/// The mesh's copy crosses it along x, from half its size to one side to
/// half to the other, turning 0.6 rad about a tilted axis on the way.
fn moving_copy_case(arg: &str, frames: usize) -> Result<Case, String> {
    let loaded = crate::mesh::load(&crate::mesh::resolve(arg))?;
    let b = loaded.mesh.bounds();
    let (size, centre) = (Vec3::from(b.extent()), Vec3::from(b.center()));
    let axis = Vec3::new(0.3, 1.0, 0.2).normalize();
    let span = (frames.max(2) - 1) as f32;
    let poses = (0..frames)
        .map(|f| {
            let s = f as f32 / span;
            let rotation = Quat::from_axis_angle(axis, 0.6 * s);
            // Turn about the mesh's centre, then shift.
            let shift = Vec3::new(size.x * (0.5 - s), 0.05 * size.y, 0.0);
            let translation = centre - rotation * centre + shift;
            RigidTransform::new(rotation, translation).map_err(|e| e.to_string())
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Case {
        name: loaded.name,
        mesh: loaded.mesh,
        motion: Motion::Move(poses),
    })
}

const VARIANTS: [(&str, bool); 4] = [
    ("aabb", false),
    ("aabb", true),
    ("obb", false),
    ("obb", true),
];

/// Every variant of one case, `rounds` times, interleaved.
fn run_case(
    case: &Case,
    variants: &[(&'static str, bool)],
    rounds: usize,
    with_peer: bool,
) -> Result<Vec<Run>, String> {
    let n = variants.len();
    let mut times: Vec<Vec<(f64, f64, f64)>> = vec![Vec::new(); n + 1];
    let mut answers: Vec<Option<Frames>> = vec![None; n + 1];
    for round in 0..rounds.max(1) {
        // Rotate who goes first, so no variant always runs on a warm cache.
        for k in 0..n + 1 {
            let v = (k + round) % (n + 1);
            let replay = if v == n {
                if !with_peer {
                    continue;
                }
                peer(case)
            } else {
                let (bv, front) = variants[v];
                ours(case, bv == "obb", front)?
            };
            times[v].push((replay.refit_ms, replay.query_ms, replay.p90_ms()));
            answers[v].get_or_insert(replay.pairs);
        }
    }
    let reference = answers[0].clone().unwrap_or_default();
    for (v, (bv, front)) in variants.iter().enumerate() {
        if answers[v].as_ref() != Some(&reference) {
            let (bv0, front0) = variants[0];
            return Err(format!(
                "{}: {bv} (front: {front}) found other pairs than {bv0} (front: {front0})",
                case.name
            ));
        }
    }
    let frames = case.frames().max(1) as f64;
    let per_frame = |t: &[(f64, f64, f64)]| {
        (
            median(t.iter().map(|x| (x.0 + x.1) / frames).collect()),
            median(t.iter().map(|x| x.0 / frames).collect()),
            median(t.iter().map(|x| x.1 / frames).collect()),
            median(t.iter().map(|x| x.2).collect()),
        )
    };
    let peer_answer = answers[n].as_ref();
    let peer_ms = peer_answer.map(|_| per_frame(&times[n]).0);
    let peer_pairs = peer_answer.map(|a| a.iter().map(Vec::len).sum());
    let differing = peer_answer.map(|a| a.iter().zip(&reference).filter(|(p, o)| p != o).count());
    let compared = peer_answer.map(|a| compare(case, &reference, a));
    Ok(variants
        .iter()
        .enumerate()
        .map(|(v, &(bv, front))| {
            let (total, refit, query, p90) = per_frame(&times[v]);
            Run {
                case: case.name.clone(),
                kind: case.kind(),
                triangles: case.mesh.triangle_count(),
                bv,
                front,
                frames: case.frames(),
                ms_per_frame: total,
                p90_frame_ms: p90,
                refit_ms: refit,
                query_ms: query,
                pairs: reference.iter().map(Vec::len).sum(),
                parry3d_ms_per_frame: peer_ms,
                parry3d_pairs: peer_pairs,
                parry3d_frames_differing: differing,
                parry3d_extra_pairs: compared.map(|c| c.extra),
                parry3d_extra_max_distance: compared.map(|c| c.extra_max_distance),
                parry3d_missed_pairs: compared.map(|c| c.missed),
            }
        })
        .collect())
}

pub fn run(args: Args) -> Result<(), String> {
    let mut provenance = provenance::start(rayon::current_num_threads());
    let wanted = |name: &str| args.case.as_deref().is_none_or(|c| c == name);
    let mut cases = Vec::new();
    if wanted("cloth") {
        cases.push(cloth_case(args.cloth, args.frames)?);
    }
    if wanted("pair") {
        cases.push(moving_copy_case(&args.mesh, args.frames)?);
    }
    if cases.is_empty() {
        return Err("--case is `cloth` or `pair`".into());
    }
    let variants: Vec<(&'static str, bool)> = VARIANTS
        .into_iter()
        .filter(|(bv, _)| args.bv.as_deref().is_none_or(|b| b == *bv))
        .filter(|(_, f)| args.front.as_deref().is_none_or(|w| (w == "yes") == *f))
        .collect();
    if variants.is_empty() {
        return Err("--bv is `aabb` or `obb`".into());
    }
    let mut runs = Vec::new();
    for case in &cases {
        runs.extend(run_case(case, &variants, args.rounds, !args.no_peer)?);
    }
    provenance.finish();
    let report = Report { runs };
    let text = table(&report, &provenance, &args);
    let saved = Saved {
        provenance,
        rounds: args.rounds,
        report: &report,
    };
    provenance::emit(
        "collide",
        &report,
        &saved,
        &text,
        args.json,
        args.save.as_deref(),
    )
}

fn table(report: &Report, provenance: &Provenance, args: &Args) -> String {
    let mut out = provenance.header();
    out += &format!(
        "\n{} frames per case, median of {} rounds; ms per frame = refit + query; \
         p90 = the frame time nine frames in ten stay within; \
         pairs summed over frames (exact); parry3d: AABB tree, no front, its GJK \
         intersection test: extra = pairs it reports that do not intersect, max dist = \
         the farthest apart of those, missed = intersecting pairs it does not report\n\n",
        args.frames, args.rounds
    );
    let opt = |x: Option<f64>| x.map_or("-".into(), |x| format!("{x:.2}"));
    let mut rows = vec![[
        "case",
        "kind",
        "triangles",
        "bv",
        "front",
        "ms/frame",
        "p90",
        "refit",
        "query",
        "pairs",
        "parry3d ms",
        "parry3d pairs",
        "extra",
        "max dist",
        "missed",
        "vs parry3d",
    ]
    .map(String::from)
    .to_vec()];
    for r in &report.runs {
        rows.push(vec![
            r.case.clone(),
            r.kind.into(),
            r.triangles.to_string(),
            r.bv.into(),
            if r.front { "yes" } else { "no" }.into(),
            format!("{:.2}", r.ms_per_frame),
            format!("{:.2}", r.p90_frame_ms),
            format!("{:.2}", r.refit_ms),
            format!("{:.2}", r.query_ms),
            r.pairs.to_string(),
            opt(r.parry3d_ms_per_frame),
            r.parry3d_pairs.map_or("-".into(), |p| p.to_string()),
            r.parry3d_extra_pairs.map_or("-".into(), |p| p.to_string()),
            r.parry3d_extra_max_distance
                .map_or("-".into(), |d| format!("{d:.1e}")),
            r.parry3d_missed_pairs.map_or("-".into(), |p| p.to_string()),
            r.parry3d_ms_per_frame
                .map_or("-".into(), |p| format!("{:.2}x", p / r.ms_per_frame)),
        ]);
    }
    out += &aligned(&rows, 5);
    out
}
