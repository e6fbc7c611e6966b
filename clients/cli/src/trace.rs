//! `frusta trace`: the closest hit of one ray, for spot-checking geometry
//! and materials by hand.

use std::error::Error;
use std::path::Path;

use frusta_engine::bvh::BuildOptions;
use frusta_engine::geometry::Ray;
use frusta_engine::query::SceneBvh;
use frusta_engine::scene::Scene;
use glam::Vec3;
use serde_json::json;

pub fn run(
    path: &Path,
    origin: Vec3,
    direction: Vec3,
    as_json: bool,
) -> Result<(), Box<dyn Error>> {
    // The engine quietly misses a zero direction; say so instead.
    let direction = direction
        .try_normalize()
        .ok_or("direction must be non-zero")?;
    let scene = Scene::load(path)?;
    let bvh = SceneBvh::build(&scene, &BuildOptions::default());
    let hit = bvh.closest_hit(&Ray::new(origin, direction));
    let Some(h) = hit else {
        if as_json {
            println!("{}", json!({ "hit": null }));
        } else {
            println!("no hit");
        }
        return Ok(());
    };
    let name = |names: Option<&String>| names.map_or("?", String::as_str).to_owned();
    let object_name = name(scene.objects.get(h.object as usize).map(|o| &o.name));
    let material = name(scene.materials.get(h.material as usize).map(|m| &m.name));
    if as_json {
        let doc = json!({ "hit": {
            "t": h.t,
            "object": h.object,
            "object_name": object_name,
            "triangle": h.triangle,
            "point": h.point.to_array(),
            "normal": h.normal.to_array(),
            "material": material,
        }});
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!(
            "hit       object `{object_name}` (#{}), triangle {}",
            h.object, h.triangle
        );
        println!("distance  {}", h.t);
        println!("point     {} {} {}", h.point.x, h.point.y, h.point.z);
        println!("normal    {} {} {}", h.normal.x, h.normal.y, h.normal.z);
        println!("material  {material}");
    }
    Ok(())
}
