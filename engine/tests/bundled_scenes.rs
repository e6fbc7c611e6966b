//! Every bundled scene in `scenes/` loads, is valid and uses only materials
//! that its triangles reference.

use std::path::PathBuf;

use frusta_engine::scene::Scene;

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

#[test]
fn every_bundled_scene_loads() {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(scenes_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("json") {
            continue;
        }
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(!scene.objects.is_empty(), "{}", path.display());
        for o in &scene.objects {
            assert_eq!(o.materials.len(), o.mesh.triangle_count());
            assert!(o
                .materials
                .iter()
                .all(|&m| (m as usize) < scene.materials.len()));
            assert_eq!(o.mesh.degenerate_count(), 0, "{}", path.display());
        }
        found.push(path.file_stem().unwrap().to_string_lossy().into_owned());
    }
    found.sort();
    assert_eq!(
        found,
        ["hall-10k", "hall-200k", "l-room", "shoebox", "two-rooms"]
    );
}

#[test]
fn hall_scenes_hit_their_triangle_counts() {
    for (name, target) in [("hall-10k", 10_000.0), ("hall-200k", 200_000.0)] {
        let scene = Scene::load(&scenes_dir().join(format!("{name}.json"))).unwrap();
        let n = scene.triangle_count() as f64;
        assert!((n / target - 1.0).abs() < 0.15, "{name}: {n}");
    }
}

#[test]
fn shoebox_uses_its_three_surface_materials() {
    let scene = Scene::load(&scenes_dir().join("shoebox.json")).unwrap();
    let room = scene.object("room").unwrap();
    let mut used: Vec<&str> = room
        .materials
        .iter()
        .map(|&m| scene.materials[m as usize].name.as_str())
        .collect();
    used.sort();
    used.dedup();
    assert_eq!(used, ["ceiling", "floor", "walls"]);
}
