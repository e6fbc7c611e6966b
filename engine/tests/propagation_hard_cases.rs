//! Hard cases for frustum tracing, each checked against the exact
//! image-source reference: convex rooms (every image source found, exact
//! delays and gains), reciprocity, degenerate positions and geometry,
//! extreme scales, invalid input, and moving listeners and objects.

use frusta_engine::acoustics::path::{Event, ValidPath};
use frusta_engine::acoustics::propagation::{
    arrival, simulate, SimulationOptions, SurfaceShare::Reflected,
};
use frusta_engine::acoustics::reference::image_sources;
use frusta_engine::acoustics::signal::AirConditions;
use frusta_engine::acoustics::{AcousticScene, CellAssignment, TraceOptions};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene, SceneObject};
use glam::{DQuat, DVec3, Quat, Vec3};

const SIZE: DVec3 = DVec3::new(10.0, 6.0, 3.0);
const S: DVec3 = DVec3::new(2.0, 3.5, 1.2);
const L: DVec3 = DVec3::new(7.3, 1.9, 1.7);

/// Distinct image sources of a box up to `order`: the lattice points with
/// `|i| + |j| + |k| <= order` (an octahedral number).
fn box_image_count(order: usize) -> usize {
    let n = order;
    (2 * n + 1) * (2 * n * n + 2 * n + 3) / 3
}

fn box_mesh(min: Vec3, max: Vec3, subdivisions: u32) -> frusta_engine::scene::RawMesh {
    let mut room = BoxRoom::new(min, max);
    room.subdivisions = subdivisions;
    room.generate().unwrap()
}

fn shoebox_scaled(scale: f64, absorption: f32) -> Scene {
    shoebox_tessellated(scale, 1, absorption)
}

/// The shoebox scaled by `scale`, each wall split `subdivisions` times
/// each way.
fn shoebox_tessellated(scale: f64, subdivisions: u32, absorption: f32) -> Scene {
    Scene::single_object(
        "room",
        box_mesh(Vec3::ZERO, (SIZE * scale).as_vec3(), subdivisions),
        Material::uniform("walls", absorption).unwrap(),
    )
    .unwrap()
}

fn shoebox(absorption: f32) -> Scene {
    shoebox_scaled(1.0, absorption)
}

/// The shoebox with a different material on each of its six walls, so that
/// gains tell the walls apart.
fn shoebox_six_materials() -> Scene {
    let raw = box_mesh(Vec3::ZERO, SIZE.as_vec3(), 1);
    let mesh = TriangleMesh::new(raw.positions, raw.triangles).unwrap();
    let materials: Vec<u16> = (0..mesh.triangle_count())
        .map(|t| {
            let n = mesh.face_normal(t);
            let axis = n.abs().max_position();
            (2 * axis + usize::from(n[axis] > 0.0)) as u16
        })
        .collect();
    Scene {
        materials: (0..6)
            .map(|i| Material::uniform(&format!("m{i}"), 0.05 + 0.13 * i as f32).unwrap())
            .collect(),
        objects: vec![SceneObject {
            name: "room".into(),
            mesh,
            materials,
            transform: RigidTransform::IDENTITY,
            dynamic: false,
        }],
    }
}

fn options(order: u32, sampling: u32) -> TraceOptions {
    TraceOptions {
        max_order: order,
        sampling,
        energy_threshold: 0.0,
        ..TraceOptions::default()
    }
}

fn events(p: &ValidPath) -> Vec<Event> {
    p.vertices.iter().map(|v| v.event).collect()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

fn assert_finite_path(p: &ValidPath) {
    assert!(p.length.is_finite() && p.length >= 0.0, "{p:?}");
    assert!(p.image_source.is_finite(), "{p:?}");
    assert!(p.vertices.iter().all(|v| v.point.is_finite()), "{p:?}");
}

/// Traces `s` to `l` and checks the result against the reference exactly:
/// no false paths, no missing paths, no duplicates, equal lengths and
/// per-band gains (to 1e-6 relative). Returns the traced paths.
fn check_exact(
    scene: &AcousticScene,
    s: DVec3,
    l: DVec3,
    order: u32,
    sampling: u32,
    what: &str,
) -> Vec<ValidPath> {
    check_against_reference(scene, s, l, &options(order, sampling), 0, what)
}

/// [`check_exact`] with any trace options, allowing up to `may_miss`
/// reference paths to be missing (sampled cells).
fn check_against_reference(
    scene: &AcousticScene,
    s: DVec3,
    l: DVec3,
    options: &TraceOptions,
    may_miss: usize,
    what: &str,
) -> Vec<ValidPath> {
    let traced = scene.find_paths(s, &[l], options).paths.remove(0);
    let exact = image_sources(
        scene.bvh(),
        scene.surfaces(),
        scene.materials(),
        s,
        l,
        options.max_order as usize,
    );
    for p in traced.iter().chain(&exact) {
        assert_finite_path(p);
    }
    // Each event sequence exactly once.
    let mut seqs: Vec<Vec<Event>> = traced.iter().map(events).collect();
    seqs.sort();
    seqs.dedup();
    assert_eq!(seqs.len(), traced.len(), "{what}: duplicate traced paths");
    let false_paths: Vec<_> = traced
        .iter()
        .filter(|t| !exact.iter().any(|e| events(e) == events(t)))
        .map(|t| (events(t), t.length))
        .collect();
    assert!(
        false_paths.is_empty(),
        "{what}: false paths {false_paths:?}"
    );
    let missing: Vec<_> = exact
        .iter()
        .filter(|e| !traced.iter().any(|t| events(e) == events(t)))
        .map(|e| (events(e), e.image_source, e.length))
        .collect();
    assert!(
        missing.len() <= may_miss,
        "{what}: {} of {} reference paths missing: {missing:?}",
        missing.len(),
        exact.len()
    );
    let air = AirConditions::default();
    let speed = air.speed_of_sound();
    for e in &exact {
        let Some(t) = traced.iter().find(|t| events(t) == events(e)) else {
            continue;
        };
        assert!(
            rel(t.length, e.length) <= 1e-6,
            "{what}: length {t:?} {e:?}"
        );
        assert!(
            t.image_source.distance(e.image_source) <= 1e-6 * e.length.max(1e-3),
            "{what}: image source {t:?} {e:?}"
        );
        for a in [None, Some(&air)] {
            let (at, ae) = (
                arrival(scene, t, l, speed, a, Reflected),
                arrival(scene, e, l, speed, a, Reflected),
            );
            assert!(rel(at.delay_s, ae.delay_s) <= 1e-6, "{what}");
            for (gt, ge) in at.pressure_gain.iter().zip(&ae.pressure_gain) {
                assert!(gt.is_finite() && *gt >= 0.0, "{what}: gain {gt}");
                assert!(
                    rel(f64::from(*gt), f64::from(*ge)) <= 1e-6,
                    "{what}: gain {gt} vs {ge}"
                );
            }
        }
    }
    traced
}

/// Image sources must be distinct (each counted once).
fn assert_distinct_images(paths: &[ValidPath], what: &str) {
    for (i, a) in paths.iter().enumerate() {
        for b in &paths[i + 1..] {
            assert!(
                a.image_source.distance(b.image_source) > 1e-9 * a.length.max(1.0),
                "{what}: image source {} counted twice: {:?} and {:?}",
                a.image_source,
                events(a),
                events(b)
            );
        }
    }
}

// ---------------------------------------------------------------- 1. convex

#[test]
fn shoebox_order_6_every_image_source_with_exact_gains() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let paths = check_exact(&scene, S, L, 6, 8, "shoebox");
    assert_eq!(paths.len(), box_image_count(6));
    assert_distinct_images(&paths, "shoebox");
}

#[test]
fn shoebox_simulate_matches_reference_delays_and_gains() {
    let scene = AcousticScene::new(&shoebox_six_materials());
    let (s, l) = (S.as_vec3(), L.as_vec3());
    let opts = SimulationOptions {
        max_order: 6,
        energy_threshold: 0.0,
        ..SimulationOptions::default()
    };
    let r = simulate(&scene, &[s], &[l], &opts).unwrap().remove(0);
    let (s, l) = (s.as_dvec3(), l.as_dvec3());
    let exact = image_sources(scene.bvh(), scene.surfaces(), scene.materials(), s, l, 6);
    assert_eq!(exact.len(), box_image_count(6));
    assert_eq!(r.paths.len(), exact.len());
    let air = AirConditions::default();
    for e in &exact {
        let a = arrival(&scene, e, l, r.speed_of_sound_m_s, Some(&air), Reflected);
        let p = r
            .paths
            .iter()
            .find(|p| DVec3::from_array(p.image_source).distance(e.image_source) < 1e-9 * e.length)
            .unwrap_or_else(|| panic!("missing {e:?}"));
        assert_eq!(p.order, e.order());
        assert!(rel(p.distance_m, e.length) <= 1e-6);
        assert!(rel(p.delay_s, e.length / r.speed_of_sound_m_s) <= 1e-6);
        assert!(rel(p.delay_s, a.delay_s) <= 1e-6);
        assert_eq!(p.pressure_gain.len(), r.bands_hz.len());
        for (band, g) in p.pressure_gain.iter().enumerate() {
            assert!(rel(f64::from(*g), f64::from(a.pressure_gain[band])) <= 1e-6);
        }
    }
    assert!(r
        .impulse_response
        .channels
        .iter()
        .flatten()
        .all(|x| x.is_finite()));
}

/// The shoebox turned by a non-axis rotation and moved: the same image set,
/// now with oblique planes everywhere.
#[test]
fn rotated_box_order_6_every_image_source() {
    let rotation = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let translation = DVec3::new(3.0, -2.0, 5.0);
    let mut scene = shoebox(0.2);
    scene.objects[0].transform =
        RigidTransform::new(rotation.as_quat(), translation.as_vec3()).unwrap();
    let scene = AcousticScene::new(&scene);
    let world = |p: DVec3| rotation * p + translation;
    let paths = check_exact(&scene, world(S), world(L), 6, 8, "rotated box");
    assert_eq!(paths.len(), box_image_count(6));
    assert_distinct_images(&paths, "rotated box");
    // The lengths are those of the axis-aligned box.
    let plain = AcousticScene::new(&shoebox(0.2));
    let exact = image_sources(plain.bvh(), plain.surfaces(), plain.materials(), S, L, 6);
    for (a, b) in paths.iter().zip(&exact) {
        assert!(
            rel(a.length, b.length) <= 1e-5,
            "{} vs {}",
            a.length,
            b.length
        );
    }
}

/// A skewed convex hexahedron: the box with its ceiling shrunk, so the
/// four side walls lean inwards (no two walls parallel but floor/ceiling).
#[test]
fn skewed_convex_room_order_6_exact() {
    let mut raw = box_mesh(Vec3::ZERO, SIZE.as_vec3(), 1);
    for p in &mut raw.positions {
        if p.z > 2.9 {
            p.x = 1.0 + 0.8 * p.x;
            p.y = 0.5 + 0.7 * p.y;
        }
    }
    let scene = AcousticScene::new(
        &Scene::single_object("room", raw, Material::uniform("w", 0.1).unwrap()).unwrap(),
    );
    assert_eq!(scene.surfaces().group_count(), 6);
    let paths = check_exact(&scene, S, L, 6, 8, "skewed room");
    assert!(paths.len() > 100, "{}", paths.len());
    assert_distinct_images(&paths, "skewed room");
}

// ---------------------------------------------------------- 2. reciprocity

#[test]
fn reciprocity_same_lengths_and_gains() {
    let scene = AcousticScene::new(&shoebox_six_materials());
    let forward = check_exact(&scene, S, L, 5, 8, "s->l");
    let backward = check_exact(&scene, L, S, 5, 8, "l->s");
    assert_eq!(forward.len(), backward.len());
    assert_eq!(forward.len(), box_image_count(5));
    let speed = 343.0;
    for f in &forward {
        // The reverse path meets the same walls in reverse order.
        let mut rev = events(f);
        rev.reverse();
        let b = backward
            .iter()
            .find(|b| events(b) == rev)
            .unwrap_or_else(|| panic!("no reverse of {:?}", events(f)));
        assert!(
            rel(f.length, b.length) <= 1e-9,
            "{} vs {}",
            f.length,
            b.length
        );
        let (gf, gb) = (
            arrival(&scene, f, L, speed, None, Reflected).pressure_gain,
            arrival(&scene, b, S, speed, None, Reflected).pressure_gain,
        );
        for (x, y) in gf.iter().zip(&gb) {
            assert!(rel(f64::from(*x), f64::from(*y)) <= 1e-6, "{x} vs {y}");
        }
    }
}

// ------------------------------------------------------------ 3. hard cases

#[test]
fn source_or_listener_one_mm_from_a_wall() {
    let scene = AcousticScene::new(&shoebox(0.2));
    for (s, l, what) in [
        (DVec3::new(1e-3, 3.5, 1.2), L, "source near x=0"),
        (S, DVec3::new(7.3, 6.0 - 1e-3, 1.7), "listener near y=6"),
        (DVec3::new(2.0, 3.5, 3.0 - 1e-3), L, "source near ceiling"),
    ] {
        let paths = check_exact(&scene, s, l, 6, 8, what);
        assert_eq!(paths.len(), box_image_count(6), "{what}");
    }
}

#[test]
fn source_in_a_corner() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let s = DVec3::splat(1e-3);
    let paths = check_exact(&scene, s, L, 5, 8, "corner");
    assert_eq!(paths.len(), box_image_count(5));
    let s = SIZE - DVec3::splat(1e-3);
    let paths = check_exact(&scene, s, L, 5, 8, "far corner");
    assert_eq!(paths.len(), box_image_count(5));
}

/// Sampled cells in hard positions: never a false or duplicate path, exact
/// lengths and gains for what is found, and, where walls are large next to
/// cells, every image source at any scale and 1 mm from a wall. What sample
/// rays cannot see is a surface seen under less than a cell: paths hugging
/// the edges of a corner 1 mm away, and floor reflections 0.1 mm above the
/// floor, where the floor fills a sliver of the cell towards the listener
/// (sample rays there meet the far wall). Walls of two triangles are
/// classified against the samples; walls of 512 put more triangles in each
/// frustum than classification is worth, so the sample rays are cast.
#[test]
fn sampled_cells_in_hard_positions() {
    let sampled = TraceOptions {
        cells: CellAssignment::Sampled,
        ..options(4, 8)
    };
    for subdivisions in [1, 16] {
        let box_scene = AcousticScene::new(&shoebox_tessellated(1.0, subdivisions, 0.2));
        let stats = box_scene.find_paths(S, &[L], &sampled).stats;
        assert_eq!(stats.sample_rays > 0, subdivisions > 1, "{stats:?}");
        for (s, l, may_miss, what) in [
            (DVec3::new(1e-3, 3.5, 1.2), L, 0, "source 1 mm from x=0"),
            (DVec3::splat(1e-3), L, 2, "source 1 mm from a corner"),
            (
                S,
                DVec3::new(7.3, 6.0 - 1e-3, 1.7),
                0,
                "listener 1 mm from y=6",
            ),
            (
                DVec3::new(0.5, 3.0, 1e-4),
                DVec3::new(9.5, 3.2, 1e-4),
                26,
                "grazing the floor",
            ),
            (S, DVec3::new(7.3, S.y, S.z), 0, "on primary split planes"),
        ] {
            let what = format!("{what}, walls split {subdivisions} times");
            let paths = check_against_reference(&box_scene, s, l, &sampled, may_miss, &what);
            assert!(paths.len() + may_miss >= box_image_count(4), "{what}");
        }
        for scale in [1e-3, 1e3] {
            let scene = AcousticScene::new(&shoebox_tessellated(scale, subdivisions, 0.2));
            let what = format!("scale {scale}, walls split {subdivisions} times");
            let paths = check_against_reference(&scene, S * scale, L * scale, &sampled, 0, &what);
            assert_eq!(paths.len(), box_image_count(4), "{what}");
        }
    }
}

#[test]
fn listener_on_primary_frustum_boundaries() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let d = DVec3::new(1.0, 1.0, 1.0) * 1.5;
    for (l, what) in [
        // Same y and z: on the split planes of the +x cube face.
        (DVec3::new(7.3, S.y, S.z), "split plane"),
        // Same z only: on a split plane.
        (DVec3::new(7.3, 1.9, S.z), "one split plane"),
        // On the cube's corner diagonal.
        (S + d, "corner diagonal"),
        // On the edge between two cube faces (x = y offsets).
        (S + DVec3::new(2.0, 2.0, 0.3), "cube edge"),
    ] {
        for split in [1, 2] {
            let opts = TraceOptions {
                primary_split: split,
                ..options(5, 8)
            };
            let traced = scene.find_paths(S, &[l], &opts).paths.remove(0);
            let exact = image_sources(scene.bvh(), scene.surfaces(), scene.materials(), S, l, 5);
            // Level with the source, some images are reached only through a
            // wall edge (see `paths_through_a_wall_edge_are_counted_once`).
            assert_eq!(exact.len(), box_image_count(5), "{what}");
            assert_eq!(
                traced.iter().filter(|p| p.order() == 0).count(),
                1,
                "{what}: direct path"
            );
            assert_eq!(traced.len(), exact.len(), "{what} split {split}");
            assert_distinct_images(&traced, what);
        }
        check_exact(&scene, S, l, 5, 8, what);
    }
}

#[test]
fn grazing_incidence() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let (s, l) = (DVec3::new(0.5, 3.0, 1e-4), DVec3::new(9.5, 3.2, 1e-4));
    let paths = check_exact(&scene, s, l, 5, 8, "grazing floor");
    assert_eq!(paths.len(), box_image_count(5));
    // The floor reflection is present and nearly as long as the direct path.
    let floor = paths
        .iter()
        .find(|p| p.order() == 1 && p.vertices[0].point.z.abs() < 1e-6)
        .expect("floor reflection");
    assert!(floor.length - s.distance(l) < 1e-6);
    let (s, l) = (DVec3::new(0.5, 1e-4, 0.3), DVec3::new(9.5, 1e-4, 2.7));
    check_exact(&scene, s, l, 5, 8, "grazing side wall");
}

fn with_extra_triangles(extra: &[[Vec3; 3]]) -> Scene {
    let mut raw = box_mesh(Vec3::ZERO, SIZE.as_vec3(), 2);
    for tri in extra {
        let base = raw.positions.len() as u32;
        raw.positions.extend_from_slice(tri);
        raw.triangles.push([base, base + 1, base + 2]);
        raw.triangle_names.push(None);
    }
    Scene::single_object("room", raw, Material::uniform("w", 0.2).unwrap()).unwrap()
}

#[test]
fn coplanar_duplicate_floor() {
    let raw = box_mesh(Vec3::ZERO, SIZE.as_vec3(), 2);
    let floor: Vec<[Vec3; 3]> = raw
        .triangles
        .iter()
        .map(|t| t.map(|i| raw.positions[i as usize]))
        .filter(|t| t.iter().all(|p| p.z == 0.0))
        .collect();
    assert_eq!(floor.len(), 8);
    let scene = AcousticScene::new(&with_extra_triangles(&floor));
    let paths = check_exact(&scene, S, L, 5, 8, "doubled floor");
    assert_eq!(paths.len(), box_image_count(5));
    assert_distinct_images(&paths, "doubled floor");
}

#[test]
fn zero_area_triangles() {
    let degenerate = [
        // Collinear, inside the room.
        [
            Vec3::new(3.0, 3.0, 1.0),
            Vec3::new(4.0, 3.0, 1.0),
            Vec3::new(5.0, 3.0, 1.0),
        ],
        // Repeated corner, on the floor.
        [
            Vec3::new(3.0, 1.0, 0.0),
            Vec3::new(3.0, 1.0, 0.0),
            Vec3::new(6.0, 2.0, 0.0),
        ],
        // A point, on the path between S and L.
        [(S + L).as_vec3() * 0.5; 3],
    ];
    let scene = AcousticScene::new(&with_extra_triangles(&degenerate));
    let paths = check_exact(&scene, S, L, 5, 8, "zero-area");
    assert_eq!(paths.len(), box_image_count(5));
}

#[test]
fn open_scene_single_floor_plane() {
    let floor = TriangleMesh::new(
        vec![
            Vec3::new(-50.0, -50.0, 0.0),
            Vec3::new(50.0, -50.0, 0.0),
            Vec3::new(50.0, 50.0, 0.0),
            Vec3::new(-50.0, 50.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap();
    let scene = AcousticScene::new(&Scene {
        materials: vec![Material::uniform("ground", 0.3).unwrap()],
        objects: vec![SceneObject {
            name: "floor".into(),
            mesh: floor,
            materials: vec![0, 0],
            transform: RigidTransform::IDENTITY,
            dynamic: false,
        }],
    });
    let (s, l) = (DVec3::new(1.0, 2.0, 1.5), DVec3::new(-7.0, 4.0, 1.2));
    let paths = check_exact(&scene, s, l, 6, 8, "open floor");
    assert_eq!(paths.len(), 2);
    assert_eq!(paths[0].order(), 0);
    assert_eq!(paths[1].order(), 1);
    assert!(rel(paths[1].length, (l - DVec3::new(s.x, s.y, -s.z)).length()) < 1e-9);
    let r = simulate(
        &scene,
        &[s.as_vec3()],
        &[l.as_vec3()],
        &SimulationOptions {
            max_order: 6,
            // The floor's far edges diffract; this counts specular paths.
            diffraction_order: 0,
            ..SimulationOptions::default()
        },
    )
    .unwrap();
    assert_eq!(r[0].paths.len(), 2);
}

#[test]
fn source_and_listener_at_the_same_point() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let paths = check_exact(&scene, S, S, 4, 8, "coincident");
    // Every image with reflections on two perpendicular walls returns to
    // the source through their edge (see
    // `paths_through_a_wall_edge_are_counted_once`).
    assert_eq!(paths.len(), box_image_count(4));
    assert_distinct_images(&paths, "coincident");
    assert_eq!(paths[0].order(), 0);
    assert_eq!(paths[0].length, 0.0);
    let opts = SimulationOptions {
        max_order: 4,
        air: None,
        ..SimulationOptions::default()
    };
    let r = simulate(&scene, &[S.as_vec3()], &[S.as_vec3()], &opts)
        .unwrap()
        .remove(0);
    assert_eq!(r.paths.len(), paths.len());
    let direct = &r.paths[0];
    assert_eq!(direct.distance_m, 0.0);
    assert_eq!(direct.delay_s, 0.0);
    // Spreading held at its value at 1 mm.
    for g in &direct.pressure_gain {
        assert!((g - 1000.0).abs() < 1e-3, "{g}");
    }
    assert!(r
        .paths
        .iter()
        .flat_map(|p| &p.pressure_gain)
        .all(|g| g.is_finite()));
    assert!(r
        .impulse_response
        .channels
        .iter()
        .flatten()
        .all(|x| x.is_finite()));
    for p in &r.parameters {
        let json = serde_json::to_string(p).unwrap();
        assert!(!json.contains("NaN"), "{json}");
    }
}

#[test]
fn tiny_and_huge_scale() {
    let base = AcousticScene::new(&shoebox(0.2));
    let reference = check_exact(&base, S, L, 4, 8, "10 m");
    assert_eq!(reference.len(), box_image_count(4));
    // 10 m becomes 1 cm, then 10 km.
    for scale in [1e-3, 1e3] {
        let scene = AcousticScene::new(&shoebox_scaled(scale, 0.2));
        let what = format!("scale {scale}");
        let paths = check_exact(&scene, S * scale, L * scale, 4, 8, &what);
        assert_eq!(paths.len(), reference.len(), "{what}");
        for (a, b) in paths.iter().zip(&reference) {
            assert!(rel(a.length, b.length * scale) <= 1e-5, "{what}");
        }
        let opts = SimulationOptions {
            max_order: 4,
            ..SimulationOptions::default()
        };
        let run = |opts: &SimulationOptions| {
            simulate(
                &scene,
                &[(S * scale).as_vec3()],
                &[(L * scale).as_vec3()],
                opts,
            )
        };
        if scale > 1.0 {
            // Arrivals after 60 s exceed the impulse response limit: a
            // clear error, not a panic. Order 1 stays within it.
            let e = run(&opts).unwrap_err();
            assert!(e.to_string().contains("60 s"), "{e}");
        }
        let opts = SimulationOptions {
            max_order: if scale > 1.0 { 1 } else { 4 },
            ..opts
        };
        let r = run(&opts).unwrap().remove(0);
        let expected = reference
            .iter()
            .filter(|p| p.order() as u32 <= opts.max_order);
        assert_eq!(r.paths.len(), expected.clone().count(), "{what}");
        let reference: Vec<&ValidPath> = expected.collect();
        for (p, b) in r.paths.iter().zip(reference) {
            assert!(rel(p.delay_s, b.length * scale / r.speed_of_sound_m_s) <= 1e-5);
            assert!(p.pressure_gain.iter().all(|g| g.is_finite()));
        }
    }
}

#[test]
fn non_finite_positions_are_errors() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let opts = SimulationOptions::default();
    let good = S.as_vec3();
    for bad in [
        Vec3::new(f32::NAN, 1.0, 1.0),
        Vec3::new(1.0, f32::INFINITY, 1.0),
        Vec3::new(1.0, 1.0, f32::NEG_INFINITY),
    ] {
        let e = simulate(&scene, &[bad], &[good], &opts).unwrap_err();
        assert!(e.to_string().contains("source"), "{e}");
        let e = simulate(&scene, &[good], &[bad], &opts).unwrap_err();
        assert!(e.to_string().contains("listener"), "{e}");
    }
}

#[test]
fn invalid_options_are_errors() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let (s, l) = (S.as_vec3(), L.as_vec3());
    for (opts, word) in [
        (
            SimulationOptions {
                sampling: Some(0),
                ..SimulationOptions::default()
            },
            "sampling",
        ),
        (
            SimulationOptions {
                sampling: Some(65),
                ..SimulationOptions::default()
            },
            "sampling",
        ),
        (
            SimulationOptions {
                bands_hz: vec![1234.0],
                ..SimulationOptions::default()
            },
            "1234",
        ),
        (
            SimulationOptions {
                bands_hz: vec![1000.0, 1234.0],
                ..SimulationOptions::default()
            },
            "1234",
        ),
    ] {
        let e = simulate(&scene, &[s], &[l], &opts).unwrap_err();
        assert!(e.to_string().contains(word), "{e}");
    }
}

// ---------------------------------------------------------------- 4. moving

#[test]
fn moving_listener_no_flicker_and_smooth_energy() {
    let scene = AcousticScene::new(&shoebox(0.2));
    let step = 0.02;
    for (start, dir) in [
        // Generic.
        (DVec3::new(3.013, 1.027, 0.811), DVec3::new(1.0, 0.6, 0.25)),
        // Step 0 sends image (-2, 0, -2) exactly through a wall edge.
        (DVec3::new(3.0, 1.0, 0.8), DVec3::new(1.0, 0.6, 0.25)),
        // Level with the source: every step lies on primary split planes
        // and sends paths through wall edges.
        (DVec3::new(3.0, S.y, S.z), DVec3::X),
    ] {
        moving_listener_line(&scene, start, dir.normalize(), step);
    }
}

fn moving_listener_line(scene: &AcousticScene, start: DVec3, dir: DVec3, step: f64) {
    let mut previous: Option<(f64, f64)> = None;
    for k in 0..60 {
        let l = start + dir * (step * k as f64);
        let paths = check_exact(scene, S, l, 4, 8, &format!("{start} step {k}"));
        assert_eq!(paths.len(), box_image_count(4), "step {k}");
        let energy: f64 = paths
            .iter()
            .map(|p| {
                let g = arrival(scene, p, l, 343.0, None, Reflected).pressure_gain[0];
                f64::from(g).powi(2)
            })
            .sum();
        assert!(energy.is_finite() && energy > 0.0);
        let direct = S.distance(l);
        if let Some((e0, d0)) = previous {
            // Each path's energy goes as 1/r^2 and its length changes by at
            // most `step`; no path is shorter than the direct one, so the
            // relative change of the sum is bounded by that of the nearest.
            let r = d0.min(direct) - step;
            let bound = (1.0 + step / r).powi(2) - 1.0;
            let change = (energy - e0).abs() / e0.min(energy);
            assert!(
                change <= bound * 1.0001,
                "step {k}: energy changed by {change}, bound {bound}"
            );
        }
        previous = Some((energy, direct));
    }
}

fn room_with_panel() -> Scene {
    let mut scene = shoebox(0.1);
    let panel = TriangleMesh::new(
        vec![
            Vec3::new(0.0, -1.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(0.0, -1.0, 1.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap();
    scene.objects.push(SceneObject {
        name: "panel".into(),
        mesh: panel,
        materials: vec![0, 0],
        transform: RigidTransform::from_translation(Vec3::new(5.0, 3.0, 1.5)),
        dynamic: true,
    });
    scene
}

#[test]
fn moving_panel_with_set_transform() {
    let built = room_with_panel();
    let mut scene = AcousticScene::new(&built);
    let (s, l) = (DVec3::new(2.0, 3.0, 1.5), DVec3::new(8.0, 3.0, 1.5));
    let mut blocked_count = 0;
    for (k, (dy, angle)) in [
        (0.0, 0.0),
        (0.5, 0.2),
        (1.5, 0.0),
        (-1.5, 0.4),
        (0.9, 0.0),
        (1.1, 0.0),
        (0.0, 0.6),
    ]
    .into_iter()
    .enumerate()
    {
        let t = RigidTransform::new(Quat::from_rotation_z(angle), Vec3::new(5.0, 3.0 + dy, 1.5))
            .unwrap();
        scene.set_transform(1, t).unwrap();
        let what = format!("panel pose {k}");
        let paths = check_exact(&scene, s, l, 3, 8, &what);
        // The direct path runs along y = 3, z = 1.5: blocked exactly when
        // the panel (half width 1, rotated about z) spans y = 3 at x = 5.
        let blocked = (dy as f64).abs() < f64::from(angle).cos() - 1e-3;
        let has_direct = paths.iter().any(|p| p.order() == 0);
        assert_eq!(has_direct, !blocked, "{what}");
        blocked_count += usize::from(blocked);
        // A scene built afresh with the panel there gives the same paths.
        let mut fresh = built.clone();
        fresh.objects[1].transform = t;
        let fresh = AcousticScene::new(&fresh);
        let again = fresh.find_paths(s, &[l], &options(3, 8)).paths.remove(0);
        assert_eq!(again.len(), paths.len(), "{what}");
        for (a, b) in again.iter().zip(&paths) {
            assert!(rel(a.length, b.length) <= 1e-9, "{what}");
        }
    }
    assert!(blocked_count >= 2);
}

/// Specular paths that pass exactly through the edge where two walls meet
/// (a corner reflector) are real (moving the listener a hair off gives the
/// path, with continuous length and gain) and must be counted once: with
/// the listener level with the source (same y and z) every image with one
/// reflection on a side wall and one on the floor or ceiling is such a
/// path, and so is every two-wall image when listener and source coincide.
#[test]
fn paths_through_a_wall_edge_are_counted_once() {
    let scene = AcousticScene::new(&shoebox(0.2));
    for (l, order) in [(DVec3::new(7.3, S.y, S.z), 5), (S, 4)] {
        let exact = image_sources(
            scene.bvh(),
            scene.surfaces(),
            scene.materials(),
            S,
            l,
            order,
        );
        assert_distinct_images(&exact, "edge");
        assert_eq!(exact.len(), box_image_count(order), "listener {l}");
        let paths = check_exact(&scene, S, l, order as u32, 8, "edge");
        assert_eq!(paths.len(), box_image_count(order), "listener {l}");
    }
}

#[test]
fn sources_and_listeners_beyond_the_coordinate_range_are_refused() {
    let scene = AcousticScene::new(&shoebox(0.1));
    let options = SimulationOptions::default();
    let inside = Vec3::new(2.0, 2.0, 1.0);
    for far in [Vec3::new(0.0, 1e16, 0.0), Vec3::new(-3e38, 1.0, 1.0)] {
        for (sources, listeners) in [([far], [inside]), ([inside], [far])] {
            let e = simulate(&scene, &sources, &listeners, &options).unwrap_err();
            assert!(
                matches!(e, frusta_engine::Error::InvalidPosition { .. }),
                "{e}"
            );
        }
    }
    let edge = Vec3::new(1e15, 1.0, 1.0);
    assert!(scene.check_point("source", edge).is_ok());
}
