//! Impulse responses on scenes simplified within an error bound
//! ([`AcousticScene::simplified`]) against an answer that shares no code
//! with them: the closed-form image sources of the flat box that a box
//! with a floor of centimetre clutter stands for at a 1 m bound (a node's
//! error is at least its radius, R-LODs' metric: the clutter goes in
//! nodes up to about a metre across, each one polygon within a centimetre
//! of the floor).

mod common;

use frusta_engine::acoustics::{
    simulate, AcousticScene, CellAssignment, Response, SimulationOptions, Tail,
};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, RawMesh, Scene};
use glam::{DVec3, Vec3};

use common::box_images;

const ROOM: [f64; 3] = [10.0, 6.0, 3.0];
const SOURCE: [f64; 3] = [2.0, 3.0, 1.5];
const LISTENER: [f64; 3] = [7.0, 2.0, 1.2];
const BOUND_M: f32 = 1.0;
/// How far a path may differ from the flat box's: twice the clutter's
/// height, and rounding.
const SLACK_M: f64 = 0.025;

/// A 10 x 6 x 3 m box whose floor carries 180 pyramids of 0.4 m square,
/// 1 cm high: 732 triangles.
fn cluttered_box() -> Scene {
    let room = BoxRoom::new(Vec3::ZERO, Vec3::from_array(ROOM.map(|v| v as f32)));
    // The clutter first, so that the walls' indices are not those of the
    // simplified mesh.
    let mut mesh = RawMesh::default();
    for i in 0..18 {
        for j in 0..10 {
            let (x, y) = (0.5 + 0.5 * i as f32, 0.5 + 0.5 * j as f32);
            let base = [(0.0, 0.0), (0.4, 0.0), (0.4, 0.4), (0.0, 0.4)]
                .map(|(dx, dy)| mesh.push_vertex(Vec3::new(x + dx, y + dy, 0.0)));
            let apex = mesh.push_vertex(Vec3::new(x + 0.2, y + 0.2, 0.01));
            for k in 0..4 {
                mesh.push_triangle([base[k], base[(k + 1) % 4], apex], None);
            }
        }
    }
    mesh.append(room.generate().unwrap());
    Scene::single_object("room", mesh, Material::uniform("walls", 0.1).unwrap()).unwrap()
}

/// The flat box's image sources up to `order` reflections (the closed
/// form, [`box_images`]), as (distance, whether the path reflects off the
/// floor).
fn images(order: i32) -> Vec<(f64, bool)> {
    let (s, l) = (DVec3::from_array(SOURCE), DVec3::from_array(LISTENER));
    box_images(DVec3::from_array(ROOM), s, l, order)
        .into_iter()
        .map(|(image, walls)| (image.distance(l), walls[4] > 0))
        .collect()
}

/// Exact paths to order 2 at 1 kHz, nothing else.
fn options() -> SimulationOptions {
    SimulationOptions {
        max_order: 2,
        cells: CellAssignment::Conservative,
        tail: Tail::None,
        diffraction_order: 0,
        air: None,
        bands_hz: vec![1000.0],
        ..Default::default()
    }
}

fn respond(scene: &AcousticScene) -> Response {
    let options = options();
    let point = |p: [f64; 3]| Vec3::from_array(p.map(|v| v as f32));
    simulate(scene, &[point(SOURCE)], &[point(LISTENER)], &options)
        .unwrap()
        .remove(0)
}

/// Simplified at 1 m, most of the clutter goes (over half the triangles)
/// and every path is one of the flat box's image sources, within twice
/// the clutter's height (a reflection off a polygon that far from the
/// floor moves a path by at most that). Every path the clutter does not
/// touch is found; of the floor's, a path may fall in a crack between two
/// neighbouring polygons, tilted a little differently (R-LODs' cracks),
/// and be lost: one of seven here. The answer reports the bound and
/// names original triangles.
#[test]
fn a_cluttered_floor_within_the_bound_reflects_as_the_flat_box() {
    let scene = cluttered_box();
    let original = scene.triangle_count();
    let lod = AcousticScene::simplified(&scene, BOUND_M).unwrap();
    assert_eq!(lod.lod_error_m(), BOUND_M);
    assert!(lod.lod().is_some_and(|l| l.polygons > 0));
    assert!(
        lod.bvh().triangle_count() * 2 < original,
        "{} of {original}",
        lod.bvh().triangle_count()
    );
    let response = respond(&lod);
    assert_eq!(response.stats.lod_error_m, BOUND_M);
    let images = images(2);
    assert_eq!(images.len(), 25);
    let near = |a: f64, b: f64| (a - b).abs() <= SLACK_M;
    let found = |d: f64| response.paths.iter().any(|p| near(p.distance_m, d));
    let distances: Vec<f64> = response.paths.iter().map(|p| p.distance_m).collect();
    for &(d, _) in images.iter().filter(|(_, floor)| !floor) {
        assert!(found(d), "no path of about {d} m: {distances:?}");
    }
    let floor: Vec<f64> = images.iter().filter(|(_, f)| *f).map(|(d, _)| *d).collect();
    assert_eq!(floor.len(), 7);
    let lost = floor.iter().filter(|&&d| !found(d)).count();
    assert!(lost <= 1, "{lost} of the floor's paths lost: {distances:?}");
    for p in &response.paths {
        assert!(images.iter().any(|&(d, _)| near(p.distance_m, d)), "{p:?}");
        for s in &p.surfaces {
            assert!((s.triangle as usize) < original, "{s:?}");
            assert_eq!(s.material, "walls");
            // Off the floor every surface is a wall kept as it is: the
            // triangle named is the original one the point lies on.
            if s.point[2] > 0.1 {
                let [a, b, c] = scene.objects[0].mesh.corners(s.triangle as usize);
                let [a, b, c] = [a, b, c].map(|v| v.as_dvec3());
                let n = (b - a).cross(c - a).normalize();
                let off = n.dot(glam::DVec3::from_array(s.point) - a).abs();
                assert!(off < 1e-4, "{s:?} is {off} m off triangle {}", s.triangle);
            }
        }
    }
}

/// Bound 0 is the exact scene, to the bit; a bound that is not a finite
/// distance of at least 0 is refused, naming the field.
#[test]
fn bound_zero_is_exact_and_bad_bounds_are_refused() {
    let scene = cluttered_box();
    let exact = respond(&AcousticScene::new(&scene));
    let zero = AcousticScene::simplified(&scene, 0.0).unwrap();
    assert!(zero.lod().is_none());
    let same = respond(&zero);
    assert_eq!(same.stats.lod_error_m, 0.0);
    assert_eq!(same.paths, exact.paths);
    for bad in [-0.1, f32::NAN, f32::INFINITY] {
        let e = AcousticScene::simplified(&scene, bad).unwrap_err();
        assert!(e.to_string().contains("lod_error_m"), "{bad}: {e}");
    }
}

/// A bound beyond the whole scene still answers, on one rectangle (the
/// room's plane of least spread); a simplified scene refuses new vertices
/// and keeps what it has.
#[test]
fn huge_bounds_answer_and_new_vertices_are_refused() {
    let scene = cluttered_box();
    let flat = AcousticScene::simplified(&scene, 1e30).unwrap();
    let response = respond(&flat);
    assert_eq!(response.stats.lod_error_m, 1e30);
    assert_eq!(flat.bvh().triangle_count(), 2);
    let mut lod = AcousticScene::simplified(&scene, BOUND_M).unwrap();
    let before = respond(&lod).paths;
    let object = &scene.objects[0];
    let e = lod
        .update_mesh(0, &object.mesh, &object.materials, 0.5)
        .unwrap_err();
    assert!(e.to_string().contains("simplified"), "{e}");
    assert_eq!(lod.revision(), 0);
    assert_eq!(respond(&lod).paths, before);
}

/// Simplified on the exact scene's own trees (what the service does), the
/// answer is that of a scene simplified from scratch, to the bit; a
/// simplified scene is not simplified again, and bound 0 replaces nothing.
#[test]
fn simplified_on_the_scenes_own_trees_answers_the_same() {
    let scene = cluttered_box();
    let exact = AcousticScene::new(&scene);
    let fresh = respond(&AcousticScene::simplified(&scene, BOUND_M).unwrap());
    let lod = exact
        .simplified_from(&scene, BOUND_M)
        .unwrap()
        .expect("clutter replaced");
    let reused = respond(&lod);
    assert_eq!(reused.stats.lod_error_m, BOUND_M);
    assert_eq!(reused.paths, fresh.paths);
    let e = lod.simplified_from(&scene, BOUND_M).unwrap_err();
    assert!(e.to_string().contains("simplified"), "{e}");
    assert!(exact.simplified_from(&scene, 0.0).unwrap().is_none());
}

/// The energy of a response's paths, dB.
fn path_energy_db(response: &Response) -> f64 {
    let energy: f64 = response
        .paths
        .iter()
        .map(|p| f64::from(p.pressure_gain[0]).powi(2))
        .sum();
    10.0 * energy.log10()
}

/// A listener walking 1 m in 1 cm steps hears the simplified box's paths
/// change smoothly: no step moves their energy by more than 0.3 dB (0.20
/// measured; the exact cluttered floor, whose tilted faces each reflect
/// over a small patch, moves it by up to 0.46). A path that a crack
/// between polygons drops and gives back from step to step would jump by
/// a first-order reflection's share, about a decibel.
#[test]
fn a_slowly_moving_listener_hears_no_flicker() {
    let lod = AcousticScene::simplified(&cluttered_box(), BOUND_M).unwrap();
    let options = options();
    let source = Vec3::from_array(SOURCE.map(|v| v as f32));
    let energies: Vec<f64> = (0..100)
        .map(|step| {
            let listener = Vec3::new(5.0 + 0.01 * step as f32, 2.0, 1.2);
            let response = simulate(&lod, &[source], &[listener], &options)
                .unwrap()
                .remove(0);
            path_energy_db(&response)
        })
        .collect();
    let worst = energies
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 0.3, "a step of {worst} dB");
}
