//! `frusta-bench update`: what moving or deforming one object of a scene
//! costs the acoustic world (hierarchy, top level and plane groups), by the
//! size of the object. A bundled hall gets two objects of its own, a
//! 12-triangle panel and a 1,280-triangle sculpture, and every object is
//! moved rigidly and deformed (same triangles, refit) in interleaved rounds.
//! What each update costs should follow the object's triangles, not the
//! scene's.

use std::path::{Path, PathBuf};
use std::time::Instant;

use frusta_engine::acoustics::AcousticScene;
use frusta_engine::bvh::DEFAULT_REBUILD_THRESHOLD;
use frusta_engine::geometry::{shapes, RigidTransform, TriangleMesh};
use frusta_engine::scene::{Scene, SceneObject};
use glam::{Quat, Vec3};
use serde::Serialize;

use crate::provenance::{self, Provenance};
use crate::stats::median;

#[derive(clap::Args)]
pub struct Args {
    /// Bundled scene to add the objects to (`scenes/<NAME>.json`).
    #[arg(long, default_value = "hall-200k")]
    scene: String,
    /// Rounds: each object is moved and deformed once per round; medians.
    #[arg(long, default_value_t = 21)]
    rounds: usize,
    /// Also write `update.txt` and `update.json` into this directory.
    #[arg(long)]
    save: Option<PathBuf>,
}

#[derive(Serialize)]
struct Row {
    object: String,
    triangles: usize,
    move_ms: f64,
    deform_ms: f64,
}

#[derive(Serialize)]
struct Document {
    #[serde(flatten)]
    provenance: Provenance,
    scene: String,
    scene_triangles: usize,
    rounds: usize,
    rows: Vec<Row>,
}

fn object(name: &str, mesh: TriangleMesh, at: Vec3) -> SceneObject {
    SceneObject {
        name: name.into(),
        materials: vec![0; mesh.triangle_count()],
        mesh,
        transform: RigidTransform::from_translation(at),
        dynamic: true,
    }
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

pub fn run(args: Args) -> Result<(), String> {
    let mut provenance = provenance::start(rayon::current_num_threads());
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{}.json", args.scene));
    let mut scene = Scene::load(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    // Inside the hall's air, clear of seats and pillars (see
    // `engine/src/scene/generate/hall.rs`).
    scene.objects.push(object(
        "panel",
        shapes::cube(0.5, 1),
        Vec3::new(20.0, 12.0, 8.0),
    ));
    scene.objects.push(object(
        "sculpture",
        shapes::icosphere(1.0, 3),
        Vec3::new(14.0, 12.0, 10.0),
    ));
    let mut world = AcousticScene::new(&scene);
    let rounds = args.rounds.max(1);
    let mut times = vec![(Vec::new(), Vec::new()); scene.objects.len()];
    for round in 0..rounds {
        for (o, obj) in scene.objects.iter().enumerate() {
            // Back and forth by a centimetre and a small turn; the shape
            // swells and shrinks by a millimetre about the object's origin.
            let sign = if round % 2 == 0 { 1.0 } else { -1.0 };
            let to = RigidTransform::new(
                Quat::from_rotation_z(0.01 * sign) * obj.transform.rotation,
                obj.transform.translation + Vec3::splat(0.01 * sign),
            )
            .map_err(|e| e.to_string())?;
            let start = Instant::now();
            world.set_transform(o, to).map_err(|e| e.to_string())?;
            times[o].0.push(ms_since(start));
            let scale = 1.0 + 1e-3 * sign;
            let positions = obj.mesh.positions().iter().map(|&p| p * scale).collect();
            let mesh = TriangleMesh::new(positions, obj.mesh.triangles().to_vec())
                .map_err(|e| e.to_string())?;
            let start = Instant::now();
            world
                .update_mesh(o, &mesh, &obj.materials, DEFAULT_REBUILD_THRESHOLD)
                .map_err(|e| e.to_string())?;
            times[o].1.push(ms_since(start));
        }
    }
    provenance.finish();
    let rows: Vec<Row> = scene
        .objects
        .iter()
        .zip(times)
        .map(|(obj, (moves, deforms))| Row {
            object: obj.name.clone(),
            triangles: obj.mesh.triangle_count(),
            move_ms: median(moves),
            deform_ms: median(deforms),
        })
        .collect();
    let doc = Document {
        scene_triangles: rows.iter().map(|r| r.triangles).sum(),
        scene: args.scene,
        rounds,
        rows,
        provenance,
    };
    let text = table(&doc);
    print!("{text}");
    if let Some(dir) = args.save {
        let json = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
        std::fs::write(dir.join("update.json"), json + "\n").map_err(|e| e.to_string())?;
        std::fs::write(dir.join("update.txt"), text).map_err(|e| e.to_string())?;
    }
    Ok(())
}

fn table(doc: &Document) -> String {
    let mut out = doc.provenance.header();
    out += &format!(
        "\nscene {}: {} triangles in {} objects; medians of {} rounds\n",
        doc.scene,
        doc.scene_triangles,
        doc.rows.len(),
        doc.rounds
    );
    out += "move: AcousticScene::set_transform; deform: update_mesh with the same triangles (refit)\n\n";
    out += "object       triangles   move ms  deform ms\n";
    out += "-------------------------------------------\n";
    for r in &doc.rows {
        out += &format!(
            "{:<12} {:>9} {:>9.3} {:>10.3}\n",
            r.object, r.triangles, r.move_ms, r.deform_ms
        );
    }
    out
}
