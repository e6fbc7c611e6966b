//! `frusta scene info`: what a scene holds and what its BVH costs, for
//! checking a scene file before serving or benchmarking it.

use std::error::Error;
use std::path::Path;
use std::time::Instant;

use frusta_engine::bvh::BuildOptions;
use frusta_engine::query::SceneBvh;
use frusta_engine::scene::Scene;
use serde_json::json;

pub fn run(path: &Path, as_json: bool) -> Result<(), Box<dyn Error>> {
    let scene = Scene::load(path)?;
    let start = Instant::now();
    let bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let stats = bvh.stats();
    let materials: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();

    if as_json {
        let objects: Vec<_> = scene
            .objects
            .iter()
            .map(|o| {
                json!({
                    "name": o.name,
                    "triangles": o.mesh.triangle_count(),
                    "dynamic": o.dynamic,
                })
            })
            .collect();
        let doc = json!({
            "path": path.display().to_string(),
            "objects": objects,
            "triangles": scene.triangle_count(),
            "materials": materials,
            "bvh": stats,
            "build_ms": build_ms,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }

    println!("scene      {}", path.display());
    println!("triangles  {}", scene.triangle_count());
    println!("materials  {}", materials.join(", "));
    println!("objects    {}", scene.objects.len());
    for (object, s) in scene.objects.iter().zip(&stats.objects) {
        let kind = if object.dynamic { "dynamic" } else { "static" };
        println!(
            "  {:<20} {:>9} triangles  {kind:<7}  bvh: {} nodes, depth {}, SAH {:.2}, {} B",
            object.name, s.triangles, s.nodes, s.depth, s.sah_cost, s.memory_bytes
        );
    }
    println!(
        "bvh        {} B in total, built in {build_ms:.3} ms",
        stats.memory_bytes
    );
    Ok(())
}
