//! Frustum tracing checked against the independent reference
//! (`acoustics::brute_force`, which shares no validation, grouping or gain
//! code with the tracer) and against closed forms.
//!
//! Every room has a material per planar face that differs in every band,
//! so a path credited to the wrong wall, a wrong band or a missing factor
//! shows in the gains. Paths are compared one by one: the same sequence of
//! events (reflection or transmission, material), image source, length,
//! delay and gain in every band to 1e-6, no false and no missing path.

mod common;

use std::collections::HashMap;

use frusta_engine::acoustics::brute_force::{BruteForce, ReferencePath};
use frusta_engine::acoustics::signal::AirConditions;
use frusta_engine::acoustics::SoundPath;
use frusta_engine::acoustics::{simulate, AcousticScene, CellAssignment, SimulationOptions};
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, MaterialId, Scene, SceneObject, BAND_COUNT};
use glam::{DVec3, Quat, Vec3};

use common::box_images;

/// Relative tolerance of lengths, delays and gains.
const REL: f64 = 1e-6;
const SIZE: Vec3 = Vec3::new(10.0, 6.0, 3.0);

fn bundled(name: &str) -> Scene {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.json"));
    Scene::load(&path).unwrap()
}

fn object(name: &str, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> SceneObject {
    let mesh = TriangleMesh::new(positions, triangles).unwrap();
    SceneObject {
        name: name.into(),
        materials: vec![0; mesh.triangle_count()],
        mesh,
        transform: RigidTransform::IDENTITY,
        dynamic: false,
    }
}

fn box_object(name: &str, min: Vec3, max: Vec3, subdivisions: u32) -> SceneObject {
    let mut room = BoxRoom::new(min, max);
    room.subdivisions = subdivisions;
    let mesh = room.generate().unwrap();
    object(name, mesh.positions, mesh.triangles)
}

/// Gives every plane of the scene its own material, different in every
/// band; planes whose triangles transmitted keep transmitting (with new
/// coefficients). Planes are told apart by the world-space normal and
/// offset rounded to 1e-5, so a wall split into triangles is one plane.
fn material_per_plane(mut scene: Scene) -> Scene {
    let mut planes: HashMap<[i64; 4], MaterialId> = HashMap::new();
    let mut materials = Vec::new();
    let old = scene.materials.clone();
    for o in &mut scene.objects {
        for t in 0..o.mesh.triangle_count() {
            let [a, b, c] = o
                .mesh
                .corners(t)
                .map(|p| o.transform.rotation * Vec3::from(p) + o.transform.translation);
            let n = (b - a).cross(c - a).normalize_or_zero();
            // One sign per plane: the first clearly non-zero component positive.
            let leading = n.to_array().into_iter().find(|x| x.abs() > 1e-3);
            let n = if leading.is_some_and(|x| x < 0.0) {
                -n
            } else {
                n
            };
            let key = [n.x, n.y, n.z, n.dot(a)].map(|x| (f64::from(x) * 1e5).round() as i64);
            let transmits = old[usize::from(o.materials[t])].transmits();
            let id = *planes.entry(key).or_insert_with(|| {
                let k = materials.len();
                let absorption: [f32; BAND_COUNT] = std::array::from_fn(|b| {
                    0.03 + 0.4 * ((k as f32 * 0.618).fract()) + 0.04 * b as f32
                });
                let transmission = if transmits {
                    std::array::from_fn(|b| (0.02 + 0.015 * b as f32).min(absorption[b]))
                } else {
                    [0.0; BAND_COUNT]
                };
                materials.push(
                    Material {
                        name: format!("plane{k}"),
                        absorption,
                        scattering: [0.0; BAND_COUNT],
                        transmission,
                    }
                    .validated()
                    .unwrap(),
                );
                k as MaterialId
            });
            o.materials[t] = id;
        }
    }
    scene.materials = materials;
    scene
}

/// The box of the propagation tests.
fn shoebox() -> Scene {
    Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects: vec![box_object("room", Vec3::ZERO, SIZE, 2)],
    }
}

/// The same box turned about a skew axis and moved: no wall is
/// axis-aligned in world space.
fn rotated_box() -> Scene {
    let mut scene = shoebox();
    scene.objects[0].transform = RigidTransform::new(
        Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
        Vec3::new(3.0, -2.0, 5.0),
    )
    .unwrap();
    scene
}

/// The box under a linear map that keeps faces planar but makes no two
/// walls perpendicular. Its coefficients are dyadic, so the mapped f32
/// vertices are exact and each wall's triangles exactly coplanar.
fn skewed_box() -> Scene {
    let mut scene = shoebox();
    let o = &mut scene.objects[0];
    let map = glam::Mat3::from_cols(
        Vec3::new(1.0, 0.125, 0.0),
        Vec3::new(0.25, 1.0, 0.0625),
        Vec3::new(0.125, -0.125, 1.0),
    );
    let positions = o.mesh.positions().iter().map(|&p| map * p).collect();
    o.mesh.set_positions(positions).unwrap();
    scene
}

/// The box with a free-standing pillar (four sides, floor to ceiling).
fn pillar_room() -> Scene {
    let mut scene = shoebox();
    let pillar = box_object(
        "pillar",
        Vec3::new(4.5, 2.2, 0.0),
        Vec3::new(5.3, 3.0, 3.0),
        1,
    );
    // Keep the sides only: its top and bottom would lie on the ceiling
    // and the floor.
    let sides: Vec<[u32; 3]> = (0..pillar.mesh.triangle_count())
        .filter(|&t| pillar.mesh.face_normal(t).z.abs() < 0.5)
        .map(|t| pillar.mesh.triangles()[t])
        .collect();
    scene
        .objects
        .push(object("pillar", pillar.mesh.positions().to_vec(), sides));
    scene
}

/// The box with small boxes standing on its floor, their sides and tops
/// split in 2 x 2 (a seat block's detail): triangles much smaller than a
/// frustum's cells, and seen only in part.
fn cluttered_box() -> Scene {
    let mut scene = shoebox();
    let boxes = [
        (Vec3::new(3.0, 1.0, 0.0), Vec3::new(3.6, 1.5, 0.6)),
        (Vec3::new(6.0, 4.0, 0.0), Vec3::new(6.5, 4.8, 0.45)),
        (Vec3::new(5.0, 2.5, 0.0), Vec3::new(5.3, 2.8, 1.0)),
        (Vec3::new(7.5, 1.0, 0.0), Vec3::new(8.2, 1.4, 0.3)),
    ];
    for (k, (min, max)) in boxes.into_iter().enumerate() {
        let name = format!("box {k}");
        let b = box_object(&name, min, max, 2);
        // Its bottom would lie on the floor.
        let kept: Vec<[u32; 3]> = (0..b.mesh.triangle_count())
            .filter(|&t| {
                b.mesh.face_normal(t).z.abs() < 0.5
                    || b.mesh.positions()[b.mesh.triangles()[t][0] as usize].z > 0.0
            })
            .map(|t| b.mesh.triangles()[t])
            .collect();
        scene
            .objects
            .push(object(&name, b.mesh.positions().to_vec(), kept));
    }
    scene
}

/// The bundled two rooms with a door panel in the opening (x 5..5.2,
/// y 1.5..2.5, z 0..2), halfway through the wall.
fn two_rooms_with_door() -> Scene {
    let mut scene = bundled("two-rooms");
    let (x, y0, y1, z1) = (5.1, 1.5, 2.5, 2.0);
    let mut door = object(
        "door",
        vec![
            Vec3::new(x, y0, 0.0),
            Vec3::new(x, y1, 0.0),
            Vec3::new(x, y1, z1),
            Vec3::new(x, y0, z1),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    scene
        .materials
        .push(Material::uniform("door", 0.5).unwrap());
    let id = (scene.materials.len() - 1) as MaterialId;
    scene.materials[usize::from(id)].transmission = [0.1; BAND_COUNT];
    door.materials = vec![id; 2];
    scene.objects.push(door);
    scene
}

struct Case {
    name: &'static str,
    scene: Scene,
    /// Source and listener pairs, in world space.
    pairs: Vec<(Vec3, Vec3)>,
    order: u32,
}

fn cases() -> Vec<Case> {
    let rotated = rotated_box().objects[0].transform;
    let moved = |p: Vec3| rotated.rotation * p + rotated.translation;
    let skew = glam::Mat3::from_cols(
        Vec3::new(1.0, 0.125, 0.0),
        Vec3::new(0.25, 1.0, 0.0625),
        Vec3::new(0.125, -0.125, 1.0),
    );
    let box_pairs = [
        (Vec3::new(2.0, 3.5, 1.2), Vec3::new(7.3, 1.9, 1.7)),
        (Vec3::new(8.1, 0.7, 2.3), Vec3::new(1.3, 4.6, 0.4)),
    ];
    vec![
        Case {
            name: "shoebox",
            scene: shoebox(),
            pairs: box_pairs.to_vec(),
            order: 5,
        },
        Case {
            name: "rotated box",
            scene: rotated_box(),
            pairs: box_pairs.map(|(s, l)| (moved(s), moved(l))).to_vec(),
            order: 4,
        },
        Case {
            name: "skewed box",
            scene: skewed_box(),
            pairs: box_pairs.map(|(s, l)| (skew * s, skew * l)).to_vec(),
            order: 4,
        },
        Case {
            name: "l-room",
            scene: bundled("l-room"),
            pairs: vec![
                (Vec3::new(10.5, 2.0, 1.5), Vec3::new(2.5, 8.0, 1.7)),
                // Not (1, 9, 1.5) to (11, 5, 1.2): a fourth-order path
                // of that pair grazes the inner corner's edge exactly.
                (Vec3::new(1.1, 8.9, 1.5), Vec3::new(11.2, 4.7, 1.2)),
            ],
            order: 4,
        },
        Case {
            name: "two rooms with a door",
            scene: two_rooms_with_door(),
            pairs: vec![
                (Vec3::new(1.5, 1.2, 1.5), Vec3::new(8.5, 2.8, 1.6)),
                (Vec3::new(3.5, 2.3, 0.9), Vec3::new(6.0, 1.0, 2.2)),
            ],
            order: 4,
        },
        Case {
            name: "cluttered box",
            scene: cluttered_box(),
            pairs: vec![
                (Vec3::new(2.0, 3.5, 1.2), Vec3::new(7.3, 2.9, 1.7)),
                (Vec3::new(8.6, 0.7, 2.3), Vec3::new(1.3, 4.6, 0.4)),
            ],
            order: 3,
        },
        Case {
            name: "pillar room",
            scene: pillar_room(),
            pairs: vec![
                // Not (2, 2.7, 1.5): its path off the far wall grazes the
                // pillar's edge at (4.5, 2.2), within f32 rounding.
                (Vec3::new(2.1, 2.75, 1.45), Vec3::new(7.9, 2.45, 1.62)),
                (Vec3::new(4.9, 0.8, 1.1), Vec3::new(4.7, 5.2, 2.0)),
            ],
            order: 4,
        },
    ]
    .into_iter()
    .map(|c| Case {
        scene: material_per_plane(c.scene),
        ..c
    })
    .chain(std::iter::once(Case {
        name: "checkered box",
        scene: checkered(material_per_plane(shoebox())),
        pairs: box_pairs.to_vec(),
        order: 4,
    }))
    .collect()
}

/// Every other triangle of each wall gets a second material of its own:
/// coplanar triangles that differ, as a door or a window in a wall does.
fn checkered(mut scene: Scene) -> Scene {
    let planes = scene.materials.len();
    let seconds: Vec<Material> = scene
        .materials
        .iter()
        .map(|m| Material {
            name: format!("{}-b", m.name),
            absorption: m.absorption.map(|a| (a * 1.7 + 0.05).min(0.99)),
            ..m.clone()
        })
        .collect();
    scene.materials.extend(seconds);
    for o in &mut scene.objects {
        for (t, m) in o.materials.iter_mut().enumerate() {
            if t % 2 == 1 {
                *m += planes as MaterialId;
            }
        }
    }
    scene
}

fn options(order: u32, cells: CellAssignment, air: Option<AirConditions>) -> SimulationOptions {
    SimulationOptions {
        max_order: order,
        energy_threshold: 0.0,
        cells,
        air,
        sample_rate: 8_000,
        // The reference is specular.
        diffraction_order: 0,
        ..Default::default()
    }
}

/// ISO 9613-1 coefficients at the band centres 1000·2^(b−4) Hz, in dB/m.
fn air_coefficients(air: &AirConditions) -> [f64; BAND_COUNT] {
    std::array::from_fn(|b| air.attenuation_db_per_m(1000.0 * 2f64.powi(b as i32 - 4)))
}

/// The speed of sound the reference expects, from its formula (not the
/// engine's function).
fn speed_of_sound(air: &AirConditions) -> f64 {
    331.3 * (1.0 + air.temperature_c / 273.15).sqrt()
}

/// Whether a traced path and a reference path are the same: events of the
/// same kind on the same materials, and the same image source.
fn same_path(scene: &Scene, t: &SoundPath, r: &ReferencePath) -> bool {
    t.order == r.order()
        && DVec3::from(t.image_source).distance(r.image_source) <= REL * r.length
        && t.surfaces.iter().zip(&r.events).all(|(ts, re)| {
            (ts.event == "transmission") == re.transmission
                && ts.material == scene.materials[usize::from(re.material)].name
        })
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= REL * b.abs().max(1e-30)
}

/// Traced against reference, one by one: returns (matched, reference
/// count, false paths, description of the first disagreement).
fn compare(
    scene: &Scene,
    traced: &[SoundPath],
    reference: &[ReferencePath],
    speed: f64,
) -> (usize, usize, usize, Option<String>) {
    let mut used = vec![false; traced.len()];
    let mut first_error = None;
    let mut matched = 0;
    for r in reference {
        let Some(i) = (0..traced.len()).find(|&i| !used[i] && same_path(scene, &traced[i], r))
        else {
            first_error.get_or_insert_with(|| format!("missing {r:?}"));
            continue;
        };
        used[i] = true;
        matched += 1;
        let t = &traced[i];
        let mut wrong = Vec::new();
        if !close(t.distance_m, r.length) {
            wrong.push(format!("length {} vs {}", t.distance_m, r.length));
        }
        if !close(t.delay_s, r.length / speed) {
            wrong.push(format!("delay {} vs {}", t.delay_s, r.length / speed));
        }
        for (b, (&g, &e)) in t.pressure_gain.iter().zip(&r.pressure_gain).enumerate() {
            if !close(f64::from(g), e) {
                wrong.push(format!("band {b} gain {g} vs {e}"));
            }
        }
        for (ts, re) in t.surfaces.iter().zip(&r.events) {
            if DVec3::from(ts.point).distance(re.point) > 1e-4 {
                wrong.push(format!("point {:?} vs {}", ts.point, re.point));
            }
        }
        if !wrong.is_empty() {
            first_error.get_or_insert_with(|| format!("{}: {}", r.length, wrong.join(", ")));
        }
    }
    let false_paths = used.iter().filter(|u| !**u).count();
    if false_paths > 0 {
        let t = traced.iter().zip(&used).find(|(_, u)| !**u).unwrap().0;
        first_error.get_or_insert_with(|| format!("false path {t:?}"));
    }
    (matched, reference.len(), false_paths, first_error)
}

fn trace(scene: &AcousticScene, s: Vec3, l: Vec3, options: &SimulationOptions) -> Vec<SoundPath> {
    simulate(scene, &[s], &[l], options)
        .unwrap()
        .remove(0)
        .paths
}

#[test]
fn conservative_paths_equal_the_independent_reference_one_by_one() {
    let air = AirConditions::default();
    let coefficients = air_coefficients(&air);
    let mut failures = Vec::new();
    for case in cases() {
        let acoustic = AcousticScene::new(&case.scene);
        let reference = BruteForce::new(&case.scene);
        for (i, &(s, l)) in case.pairs.iter().enumerate() {
            // Air on for the first pair, off for the second.
            let air = (i == 0).then_some(air);
            let exact = reference.paths(
                s.as_dvec3(),
                l.as_dvec3(),
                case.order as usize,
                air.as_ref().map(|_| &coefficients),
            );
            let speed = speed_of_sound(&air.unwrap_or_default());
            // The default grid (2 x 2) and a fine one.
            for sampling in [None, Some(8)] {
                let options = SimulationOptions {
                    sampling,
                    ..options(case.order, CellAssignment::Conservative, air)
                };
                let traced = trace(&acoustic, s, l, &options);
                let (matched, total, false_paths, error) =
                    compare(&case.scene, &traced, &exact, speed);
                let n = options.sampling();
                println!(
                    "{} pair {i}, N = {n}: {matched}/{total} paths, {false_paths} false, order {}",
                    case.name, case.order
                );
                assert!(total >= 10, "{}: only {total} reference paths", case.name);
                if let Some(e) = error {
                    failures.push(format!("{} pair {i}, N = {n}: {e}", case.name));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn sampled_paths_are_all_real_and_their_recall_is_reported() {
    for case in cases() {
        let acoustic = AcousticScene::new(&case.scene);
        let reference = BruteForce::new(&case.scene);
        let (s, l) = case.pairs[0];
        let options = options(case.order, CellAssignment::Sampled, None);
        let traced = trace(&acoustic, s, l, &options);
        let exact = reference.paths(s.as_dvec3(), l.as_dvec3(), case.order as usize, None);
        let speed = speed_of_sound(&AirConditions::default());
        let (matched, total, false_paths, _) = compare(&case.scene, &traced, &exact, speed);
        println!(
            "{}: sampled recall {matched}/{total} = {:.3}",
            case.name,
            matched as f64 / total as f64
        );
        assert_eq!(false_paths, 0, "{}", case.name);
    }
}

/// The wall of the box a triangle lies on, `2 axis + (at max)`.
fn box_wall(mesh: &TriangleMesh, t: usize, size: Vec3) -> usize {
    let [a, b, c] = mesh.corners(t);
    let centre = Vec3::from((a + b + c) / 3.0);
    let axis = (0..3)
        .find(|&k| centre[k].abs() < 1e-3 || (centre[k] - size[k]).abs() < 1e-3)
        .unwrap();
    2 * axis + usize::from(centre[axis] > 1e-3)
}

#[test]
fn box_gains_at_orders_2_to_6_equal_the_closed_form() {
    let alpha = |w: usize, b: usize| 0.02 + 0.03 * w as f32 + 0.05 * b as f32;
    let mut scene = shoebox();
    scene.materials = (0..6)
        .map(|w| Material {
            name: format!("wall{w}"),
            absorption: std::array::from_fn(|b| alpha(w, b)),
            scattering: [0.0; BAND_COUNT],
            transmission: [0.0; BAND_COUNT],
        })
        .collect();
    let o = &mut scene.objects[0];
    o.materials = (0..o.mesh.triangle_count())
        .map(|t| box_wall(&o.mesh, t, SIZE) as MaterialId)
        .collect();
    let acoustic = AcousticScene::new(&scene);
    let reference = BruteForce::new(&scene);
    // Positions exact in f32, as the tracer takes them.
    let (s, l) = (
        Vec3::new(2.0, 3.5, 1.2).as_dvec3(),
        Vec3::new(7.3, 1.9, 1.7).as_dvec3(),
    );
    let expected = box_images(SIZE.as_dvec3(), s, l, 6);
    let gain = |counts: &[i32; 6], d: f64, b: usize| {
        (0..6)
            .map(|w| (1.0 - f64::from(alpha(w, b))).powf(f64::from(counts[w]) / 2.0))
            .product::<f64>()
            / d
    };
    let traced = trace(
        &acoustic,
        s.as_vec3(),
        l.as_vec3(),
        &options(6, CellAssignment::Conservative, None),
    );
    let exact = reference.paths(s, l, 6, None);
    assert_eq!(traced.len(), expected.len());
    assert_eq!(exact.len(), expected.len());
    // Images are matched by position: some lie at equal distances.
    for (image, counts) in &expected {
        let d = image.distance(l);
        let t = traced
            .iter()
            .find(|t| DVec3::from(t.image_source).distance(*image) < 1e-6 * d)
            .unwrap_or_else(|| panic!("traced: no image at {image}"));
        let r = exact
            .iter()
            .find(|r| r.image_source.distance(*image) < 1e-9 * d)
            .unwrap_or_else(|| panic!("reference: no image at {image}"));
        assert!(close(t.distance_m, d) && close(r.length, d));
        // Reflections per wall, from the events.
        let mut seen = [0; 6];
        for e in &t.surfaces {
            seen[e.material[4..].parse::<usize>().unwrap()] += 1;
        }
        assert_eq!(&seen, counts, "{image}");
        for b in 0..BAND_COUNT {
            let g = gain(counts, d, b);
            assert!(
                close(f64::from(t.pressure_gain[b]), g),
                "traced {image} band {b}"
            );
            assert!(
                (r.pressure_gain[b] - g).abs() <= 1e-12 * g,
                "reference {image} band {b}"
            );
        }
    }
}

#[test]
fn paths_are_reciprocal_in_non_convex_rooms() {
    for case in cases()
        .into_iter()
        .filter(|c| ["l-room", "two rooms with a door", "pillar room"].contains(&c.name))
    {
        let acoustic = AcousticScene::new(&case.scene);
        let options = options(case.order, CellAssignment::Conservative, None);
        for &(s, l) in &case.pairs {
            let forward = trace(&acoustic, s, l, &options);
            let backward = trace(&acoustic, l, s, &options);
            assert_eq!(forward.len(), backward.len(), "{}", case.name);
            for f in &forward {
                let materials: Vec<&str> = f.surfaces.iter().rev().map(|e| &*e.material).collect();
                let b = backward
                    .iter()
                    .find(|b| {
                        close(b.distance_m, f.distance_m)
                            && b.surfaces
                                .iter()
                                .map(|e| &*e.material)
                                .eq(materials.iter().copied())
                    })
                    .unwrap_or_else(|| panic!("{}: no reverse of {f:?}", case.name));
                for (x, y) in f.pressure_gain.iter().zip(&b.pressure_gain) {
                    assert!(close(f64::from(*x), f64::from(*y)), "{}", case.name);
                }
            }
        }
    }
}
