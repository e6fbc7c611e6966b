//! Soft shadows of area lights: selective against full ray tracing with
//! the same samples, pixel for pixel (thin geometry, grazing and
//! wall-crossing lights, lights inside geometry, moving lights, deforming
//! and rotated occluders, extreme scales), and full ray tracing against
//! the closed-form penumbra of a box under a rectangle light.

mod common;

use common::object;
use common::shadow_scenes::{
    block, box_at_extreme_scales, camera, convex_hull, floor, scene, seen, still, wire_and_slats,
};
use frusta_engine::bvh::SceneBvh;
use frusta_engine::geometry::shapes::cube;
use frusta_engine::geometry::RigidTransform;
use frusta_engine::shadows::{
    AreaLight, AreaShape, Camera, Light, Method, ShadowImage, ShadowOptions, ShadowScene,
};
use glam::{DVec2, Quat, Vec3};

fn render(
    world: &SceneBvh,
    camera: &Camera,
    light: &AreaLight,
    method: Method,
    samples: u32,
) -> ShadowImage {
    let options = ShadowOptions {
        method,
        samples,
        seed: 11,
        ..ShadowOptions::default()
    };
    ShadowScene::new(world)
        .soft_shadows(world, camera, light, &options)
        .unwrap()
}

/// Selective against full: no pixel may differ. Returns both.
fn check(
    world: &SceneBvh,
    camera: &Camera,
    light: &AreaLight,
    samples: u32,
) -> (ShadowImage, ShadowImage) {
    let full = render(world, camera, light, Method::Full, samples);
    let selective = render(world, camera, light, Method::Selective, samples);
    let differ = selective
        .visibility
        .iter()
        .zip(&full.visibility)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "selective differs from full ray tracing");
    let umbra = full.visibility.iter().filter(|v| **v == 0.0).count();
    let penumbra = full
        .visibility
        .iter()
        .filter(|v| **v > 0.0 && **v < 1.0)
        .count();
    eprintln!(
        "{light:?}: {umbra} umbra, {penumbra} penumbra pixels; selective traced {:.1}% of {} receivers",
        100.0 * selective.stats.pip_fraction(),
        full.stats.receivers,
    );
    (selective, full)
}

fn rectangle(centre: Vec3, u: Vec3, v: Vec3) -> AreaLight {
    AreaLight {
        centre,
        shape: AreaShape::Rectangle { u, v },
    }
}

/// Area of the convex polygon `p` (counter-clockwise).
fn area(p: &[DVec2]) -> f64 {
    (0..p.len())
        .map(|i| p[i].perp_dot(p[(i + 1) % p.len()]))
        .sum::<f64>()
        / 2.0
}

/// `subject` (convex, counter-clockwise) clipped to the convex `clip`.
fn intersection(subject: &[DVec2], clip: &[DVec2]) -> Vec<DVec2> {
    let mut out = subject.to_vec();
    for i in 0..clip.len() {
        let (a, b) = (clip[i], clip[(i + 1) % clip.len()]);
        let inside = |p: DVec2| (b - a).perp_dot(p - a);
        let input = std::mem::take(&mut out);
        for k in 0..input.len() {
            let (p, q) = (input[k], input[(k + 1) % input.len()]);
            let (sp, sq) = (inside(p), inside(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                out.push(p + (q - p) * (sp / (sp - sq)));
            }
        }
        if out.len() < 3 {
            return Vec::new();
        }
    }
    out
}

#[test]
fn a_box_under_a_rectangle_light_casts_its_closed_form_penumbra() {
    let half = Vec3::new(0.5, 0.4, 0.3);
    let centre = Vec3::new(0.2, -0.1, 1.2);
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 6)),
        still("box", block(half, centre, 2)),
    ]);
    let (lc, lu, lv) = (Vec3::new(0.6, 0.3, 3.5), 0.4, 0.25);
    let light = rectangle(lc, Vec3::X * lu, Vec3::Y * lv);
    let cam = camera(Vec3::new(0.5, -5.0, 3.0), Vec3::new(0.0, 0.0, 0.3));
    let samples = 8;
    let (selective, full) = check(&world, &cam, &light, samples);
    // From a floor point, the box hides the part of the light inside the
    // hull of its corners projected from the point onto the light's plane.
    let rect = |grow: f64| {
        let (x, y, u, v) = (lc.x as f64, lc.y as f64, lu as f64 + grow, lv as f64 + grow);
        [
            DVec2::new(x - u, y - v),
            DVec2::new(x + u, y - v),
            DVec2::new(x + u, y + v),
            DVec2::new(x - u, y + v),
        ]
    };
    let g = ShadowScene::new(&world).gbuffer(&cam).unwrap();
    let (mut lit, mut umbra, mut penumbra, mut error_sum, mut worst) = (0, 0, 0, 0.0, 0.0f64);
    for (r, v) in g.receivers.iter().zip(&full.visibility) {
        let Some(r) = r.filter(|r| r.object == 0) else {
            continue;
        };
        let p = r.point.as_dvec3();
        let shadow: Vec<DVec2> = (0..8)
            .map(|k| {
                let s = glam::DVec3::new(
                    [-1.0, 1.0][k & 1],
                    [-1.0, 1.0][(k >> 1) & 1],
                    [-1.0, 1.0][k >> 2],
                );
                let c = centre.as_dvec3() + s * half.as_dvec3();
                let t = (lc.z as f64 - p.z) / (c.z - p.z);
                (p + (c - p) * t).truncate()
            })
            .collect();
        let shadow = convex_hull(&shadow);
        let blocked = |grow: f64| area(&intersection(&rect(grow), &shadow)) / area(&rect(grow));
        let v = *v as f64;
        if blocked(1e-3) == 0.0 {
            assert_eq!(v, 1.0, "lit floor point {p}");
            lit += 1;
        } else if blocked(1e-3) > 1.0 - 1e-12 && blocked(-1e-3) > 1.0 - 1e-12 {
            assert_eq!(v, 0.0, "umbra floor point {p}");
            umbra += 1;
        } else {
            let e = (v - (1.0 - blocked(0.0))).abs();
            error_sum += e;
            worst = worst.max(e);
            penumbra += 1;
        }
    }
    eprintln!("closed form: {lit} lit, {umbra} umbra, {penumbra} penumbra; mean error {:.4}, worst {worst:.3}", error_sum / penumbra as f64);
    assert!(lit > 10_000 && umbra > 300 && penumbra > 500);
    // 64 stratified samples: an edge crosses at most 2 x 8 strata, each
    // off by at most 1/64.
    assert!(error_sum / (penumbra as f64) < 0.02 && worst <= 0.25 + 1e-9);
    // Both proofs work: fewer receivers traced than are not lit.
    let not_lit = full.visibility.iter().filter(|v| **v < 1.0).count() as u64;
    assert!(
        selective.stats.pip_pixels < not_lit,
        "{:?}",
        selective.stats
    );
    assert!(
        selective.stats.pip_fraction() < 0.3,
        "{:?}",
        selective.stats
    );
    assert_eq!(selective.stats.rays, selective.stats.pip_pixels * 64);
}

#[test]
fn thin_geometry_under_disk_and_sphere_lights() {
    let world = scene(wire_and_slats());
    let cam = camera(Vec3::new(0.0, -4.5, 3.5), Vec3::new(0.0, -0.3, 0.0));
    let centre = Vec3::new(0.1, 0.2, 3.0);
    for shape in [
        AreaShape::Disk {
            normal: Vec3::new(0.2, 0.0, -1.0),
            radius: 0.3,
        },
        AreaShape::Sphere { radius: 0.05 },
    ] {
        check(&world, &cam, &AreaLight { centre, shape }, 4);
    }
}

#[test]
fn grazing_wall_crossing_and_enclosed_lights() {
    // A closed room seen from inside with a box in it.
    let room = common::deformed(&cube(1.0, 2), |p| Vec3::new(-p.x, p.y, p.z) * 3.0);
    let world = scene(vec![
        still("room", room),
        still("box", block(Vec3::splat(0.5), Vec3::new(0.5, 0.5, -1.0), 2)),
    ]);
    let cam = camera(Vec3::new(-2.5, -2.5, 2.0), Vec3::new(0.5, 0.5, -1.5));
    let lights = [
        // Through the wall x = 3, half outside the room.
        rectangle(Vec3::new(3.0, 0.0, 1.0), Vec3::X * 0.4, Vec3::Y * 0.3),
        // Flat on the floor z = -3, and a hair above it: grazing.
        rectangle(Vec3::new(-1.0, 1.0, -3.0), Vec3::X * 0.5, Vec3::Y * 0.5),
        rectangle(Vec3::new(-1.0, 1.0, -2.999), Vec3::X * 0.5, Vec3::Y * 0.5),
        // Around a corner of the box, and inside the box.
        AreaLight {
            centre: Vec3::new(1.0, 1.0, -0.5),
            shape: AreaShape::Sphere { radius: 0.2 },
        },
        AreaLight {
            centre: Vec3::new(0.5, 0.5, -1.0),
            shape: AreaShape::Sphere { radius: 0.2 },
        },
        // On the ceiling, facing down.
        AreaLight {
            centre: Vec3::new(0.0, -1.0, 3.0),
            shape: AreaShape::Disk {
                normal: -Vec3::Z,
                radius: 0.5,
            },
        },
    ];
    for light in &lights {
        check(&world, &cam, light, 3);
    }
}

#[test]
fn a_moving_light_over_a_rotated_deforming_occluder() {
    let base = block(Vec3::new(0.6, 0.2, 0.2), Vec3::ZERO, 6);
    let transform = RigidTransform::new(
        Quat::from_rotation_z(0.7) * Quat::from_rotation_x(0.3),
        Vec3::new(0.3, 0.1, 1.0),
    )
    .unwrap();
    let mut world = scene(vec![
        still("floor", floor(3.0, 0.0, 5)),
        object("bar", base.clone(), transform),
    ]);
    let cam = camera(Vec3::new(0.0, -4.0, 3.0), Vec3::ZERO);
    for frame in 0..3 {
        let a = 0.5 * frame as f32;
        let twisted = common::deformed(&base, |p| {
            Quat::from_rotation_x(a * p.x) * p
                + Vec3::new(0.0, 0.0, 0.1 * (3.0 * p.x).sin() * frame as f32)
        });
        world
            .update_mesh(1, &twisted, &vec![0; twisted.triangle_count()], 0.5)
            .unwrap();
        let u = Vec3::new(0.3 * a.cos(), 0.3 * a.sin(), 0.0);
        let light = rectangle(
            Vec3::new(1.5 * a.cos(), 1.5 * a.sin(), 3.0),
            u,
            Vec3::new(0.0, 0.1, 0.1),
        );
        check(&world, &cam, &light, 4);
    }
}

#[test]
fn tiny_and_huge_scales_far_from_the_origin() {
    for (world, cam, centre, scale) in box_at_extreme_scales() {
        let light = rectangle(centre, Vec3::X * 0.3 * scale, Vec3::Y * 0.2 * scale);
        check(&world, &cam, &light, 3);
    }
}

#[test]
fn points_see_an_area_light_as_their_rays_say() {
    // Seats on a grid around and under a table, and the light's centre.
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 4)),
        still(
            "table",
            block(Vec3::new(1.0, 0.6, 0.03), Vec3::new(0.0, 0.0, 0.9), 2),
        ),
    ]);
    let light = rectangle(Vec3::new(0.3, 0.2, 3.0), Vec3::X * 0.5, Vec3::Y * 0.5);
    let mut points = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            for z in [0.3, 1.2] {
                points.push(Vec3::new(-2.0 + 0.1 * i as f32, -2.0 + 0.1 * j as f32, z));
            }
        }
    }
    points.push(light.centre);
    let shadows = ShadowScene::new(&world);
    let answer = |method| {
        let options = ShadowOptions {
            method,
            samples: 4,
            ..ShadowOptions::default()
        };
        shadows
            .visibility(&world, &Light::Area(light), &points, &options)
            .unwrap()
    };
    let (full, selective) = (answer(Method::Full), answer(Method::Selective));
    assert_eq!(selective.fraction, full.fraction);
    let umbra = full.fraction.iter().filter(|f| **f == 0.0).count();
    let penumbra = full
        .fraction
        .iter()
        .filter(|f| **f > 0.0 && **f < 1.0)
        .count();
    assert!(umbra > 50 && penumbra > 50, "{umbra} {penumbra}");
    assert!(
        selective.stats.pip_fraction() < 0.25,
        "{:?}",
        selective.stats
    );
}

#[test]
fn a_light_through_the_floor_lights_it_by_half() {
    // A vertical panel half above, half below a bare floor: stratified
    // rows split at the floor, so every floor pixel sees exactly half of
    // the samples, the upper half from above and the lower from below
    // (not all of them: a surface takes light only on its seen side).
    let world = scene(vec![still("floor", floor(4.0, 0.0, 2))]);
    let light = rectangle(Vec3::new(0.0, 0.0, 0.0), Vec3::X * 0.5, Vec3::Z * 0.5);
    for (eye, seen_fraction) in [
        (Vec3::new(0.5, -3.0, 3.0), 0.5),
        (Vec3::new(0.5, -3.0, -3.0), 0.5),
    ] {
        let cam = camera(eye, Vec3::ZERO);
        let (_, full) = check(&world, &cam, &light, 4);
        let seen = seen(&world, &cam, &full);
        assert!(seen.len() > 10_000);
        let odd: Vec<&f32> = seen
            .iter()
            .filter(|v| **v != seen_fraction)
            .take(5)
            .collect();
        assert!(odd.is_empty(), "seen from {eye}: {odd:?}");
    }
}
