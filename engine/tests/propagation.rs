//! Frustum tracing against the exact image-source reference.

use frusta_engine::acoustics::path::ValidPath;
use frusta_engine::acoustics::reference::image_sources;
use frusta_engine::acoustics::{AcousticScene, TraceOptions};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene};
use glam::{DVec3, Vec3};

fn shoebox(subdivisions: u32, absorption: f32) -> Scene {
    let mut room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0));
    room.subdivisions = subdivisions;
    Scene::single_object(
        "room",
        room.generate().unwrap(),
        Material::uniform("walls", absorption).unwrap(),
    )
    .unwrap()
}

fn bundled(name: &str) -> Scene {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.json"));
    Scene::load(&path).unwrap()
}

/// Compares traced paths with the reference: returns (found, exact, false).
fn compare(
    scene: &AcousticScene,
    s: DVec3,
    l: DVec3,
    order: u32,
    sampling: u32,
) -> (usize, usize, usize, Vec<ValidPath>) {
    let options = TraceOptions {
        max_order: order,
        sampling,
        energy_threshold: 0.0,
        ..TraceOptions::default()
    };
    let traced = scene.find_paths(s, &[l], &options).paths.remove(0);
    let exact = image_sources(
        scene.bvh(),
        scene.surfaces(),
        &scene.materials,
        s,
        l,
        order as usize,
    );
    let matches = |a: &ValidPath, b: &ValidPath| {
        a.vertices
            .iter()
            .map(|v| v.event)
            .eq(b.vertices.iter().map(|v| v.event))
    };
    let found = exact
        .iter()
        .filter(|e| traced.iter().any(|t| matches(t, e)))
        .count();
    let false_paths = traced
        .iter()
        .filter(|t| !exact.iter().any(|e| matches(t, e)))
        .count();
    let missing: Vec<ValidPath> = exact
        .iter()
        .filter(|e| !traced.iter().any(|t| matches(t, e)))
        .cloned()
        .collect();
    (found, exact.len(), false_paths, missing)
}

#[test]
fn shoebox_finds_every_image_source_to_order_6() {
    for subdivisions in [1, 3] {
        let scene = AcousticScene::new(&shoebox(subdivisions, 0.2));
        let (s, l) = (DVec3::new(2.0, 3.5, 1.2), DVec3::new(7.3, 1.9, 1.7));
        let (found, exact, false_paths, missing) = compare(&scene, s, l, 6, 8);
        assert_eq!(false_paths, 0);
        assert_eq!(
            found,
            exact,
            "missing {:?}",
            missing.iter().map(|m| m.image_source).collect::<Vec<_>>()
        );
    }
}

#[test]
fn l_room_and_two_rooms_recall() {
    for (name, s, l, order) in [
        (
            "l-room",
            DVec3::new(1.0, 9.0, 1.5),
            DVec3::new(11.0, 5.0, 1.2),
            4,
        ),
        (
            "two-rooms",
            DVec3::new(1.5, 2.0, 1.5),
            DVec3::new(8.0, 1.0, 1.2),
            3,
        ),
    ] {
        let scene = AcousticScene::new(&bundled(name));
        let (found, exact, false_paths, _) = compare(&scene, s, l, order, 16);
        println!("{name}: {found}/{exact}");
        assert_eq!(false_paths, 0);
        assert!(
            found as f64 >= 0.99 * exact as f64,
            "{name}: {found}/{exact}"
        );
    }
}

#[test]
fn sampled_cells_find_the_box_image_sources_with_fewer_frusta() {
    let scene = AcousticScene::new(&shoebox(4, 0.2));
    let (s, l) = (DVec3::new(2.0, 3.5, 1.2), DVec3::new(7.3, 1.9, 1.7));
    let run = |cells| {
        let options = TraceOptions {
            max_order: 4,
            energy_threshold: 0.0,
            cells,
            ..TraceOptions::default()
        };
        scene.find_paths(s, &[l], &options)
    };
    let sampled = run(frusta_engine::acoustics::CellAssignment::Sampled);
    let conservative = run(frusta_engine::acoustics::CellAssignment::Conservative);
    // Walls are large next to cells here, so sample rays miss nothing.
    assert_eq!(sampled.paths[0].len(), 129);
    let lengths = |p: &[ValidPath]| p.iter().map(|x| x.length).collect::<Vec<_>>();
    assert_eq!(lengths(&sampled.paths[0]), lengths(&conservative.paths[0]));
    assert!(sampled.stats.frusta <= conservative.stats.frusta);
}
