//! Hard shadows of point, spot and directional lights: selective ray
//! tracing against full ray tracing, pixel for pixel, on scenes whose
//! shadows are hard for a shadow map (thin wires, slats, grazing light,
//! lights inside geometry, moving lights and deforming occluders), and
//! full ray tracing against the closed-form shadow of a box under a point
//! light and in sunlight.

mod common;

use common::object;
use common::shadow_scenes::{
    assert_box_shadow, block, box_at_extreme_scales, camera, check, check_over_a_deforming_bar,
    floor, scene, seen, still, wire_and_slats,
};
use frusta_engine::bvh::SceneBvh;
use frusta_engine::geometry::shapes::cube;
use frusta_engine::geometry::RigidTransform;
use frusta_engine::shadows::{
    Camera, DirectionalLight, Light, Method, PointLight, ShadowImage, ShadowOptions, ShadowScene,
    SpotLight,
};
use glam::{DVec3, Quat, Vec3};

fn render(
    world: &SceneBvh,
    camera: &Camera,
    light: Vec3,
    method: Method,
    size: u32,
) -> ShadowImage {
    common::shadow_scenes::render(world, camera, &point(light), method, size)
}

fn point(position: Vec3) -> Light {
    Light::Point(PointLight { position })
}

fn sun(direction: Vec3) -> Light {
    Light::Directional(DirectionalLight { direction })
}

#[test]
fn a_box_over_a_floor_casts_its_exact_shadow() {
    // The floor's shadow is the hull of the box's corners projected from
    // the light onto z = 0.
    let light = Vec3::new(0.6, 0.3, 3.5);
    let l = light.as_dvec3();
    let onto_floor = |c: DVec3| (l + (c - l) * (l.z / (l.z - c.z))).truncate();
    assert_box_shadow(&point(light), onto_floor, 1000);
}

#[test]
fn a_box_over_a_floor_casts_its_exact_shadow_in_sunlight() {
    // The floor's shadow is the hull of the box's corners moved along the
    // light's direction onto z = 0.
    let direction = Vec3::new(-0.4, -0.5, -1.0);
    let d = direction.as_dvec3();
    let onto_floor = |c: DVec3| (c + d * (c.z / -d.z)).truncate();
    assert_box_shadow(&sun(direction), onto_floor, 500);
}

#[test]
fn a_thin_wire_and_slats_that_a_shadow_map_drops_are_traced() {
    let world = scene(wire_and_slats());
    let cam = camera(Vec3::new(0.0, -4.5, 3.5), Vec3::new(0.0, -0.3, 0.0));
    for light in [
        point(Vec3::new(0.1, 0.2, 3.0)),
        sun(Vec3::new(0.05, -0.1, -1.0)),
        sun(Vec3::new(0.6, 0.3, -1.0)),
    ] {
        let (_, full, plain_wrong) = check(&world, &cam, &light, 128);
        assert!(full.visibility.iter().filter(|v| **v == 0.0).count() > 200);
        assert!(
            plain_wrong > 50,
            "the shadow map should lose the wire and slats: {plain_wrong}"
        );
    }
}

#[test]
fn grazing_light_and_receivers_seen_edge_on() {
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 8)),
        still("box", block(Vec3::splat(0.3), Vec3::new(0.0, 0.0, 0.3), 3)),
    ]);
    let cam = camera(Vec3::new(1.0, -4.0, 2.0), Vec3::ZERO);
    // The light a millimetre above the floor, and exactly in its plane.
    for light in [
        Vec3::new(-3.9, 0.05, 0.001),
        Vec3::new(-3.9, 0.05, 0.0),
        Vec3::new(-10.0, 0.0, 0.3),
    ] {
        check(&world, &cam, &point(light), 256);
    }
    for direction in [
        // Sunlight down the box's faces and edges, a thousandth above the
        // floor's plane, exactly in it, and from below it.
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.05, -0.001),
        Vec3::new(1.0, 0.05, 0.0),
        Vec3::new(0.2, 0.1, 1.0),
    ] {
        check(&world, &cam, &sun(direction), 256);
    }
}

#[test]
fn lights_inside_and_on_geometry() {
    // A closed room seen from inside, with a box in it; lights inside the
    // box, inside the room, and on the box's face.
    let room = common::deformed(&cube(1.0, 2), |p| Vec3::new(-p.x, p.y, p.z) * 3.0);
    let world = scene(vec![
        still("room", room),
        still("box", block(Vec3::splat(0.5), Vec3::new(0.5, 0.5, -1.0), 2)),
    ]);
    let cam = camera(Vec3::new(-2.5, -2.5, 2.0), Vec3::new(0.5, 0.5, -1.5));
    for light in [
        Vec3::new(0.5, 0.5, -1.0),
        Vec3::new(-1.0, 1.5, 2.0),
        Vec3::new(0.5, 0.5, -0.5),
    ] {
        check(&world, &cam, &point(light), 128);
    }
}

#[test]
fn a_moving_light_and_sun_over_a_deforming_occluder() {
    check_over_a_deforming_bar(|a| point(Vec3::new(1.5 * a.cos(), 1.5 * a.sin(), 3.0)));
    check_over_a_deforming_bar(|a| sun(Vec3::new(-0.5 * a.cos(), -0.5 * a.sin(), -1.0)));
}

#[test]
fn tiny_and_huge_scales_far_from_the_origin() {
    for (world, cam, light, _) in box_at_extreme_scales() {
        check(&world, &cam, &point(light), 256);
        check(&world, &cam, &sun(Vec3::new(-0.3, -0.6, -1.0)), 256);
    }
}

#[test]
fn a_rotated_instance_shadows_as_its_world_mesh_does() {
    let transform = RigidTransform::new(
        Quat::from_rotation_z(0.7) * Quat::from_rotation_x(0.3),
        Vec3::new(0.3, 0.1, 1.4),
    )
    .unwrap();
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 4)),
        object(
            "box",
            block(Vec3::new(0.5, 0.3, 0.2), Vec3::ZERO, 2),
            transform,
        ),
    ]);
    let cam = camera(Vec3::new(0.5, -5.0, 3.0), Vec3::ZERO);
    check(&world, &cam, &point(Vec3::new(-0.5, 0.4, 3.2)), 256);
}

#[test]
fn a_light_a_millimetre_from_a_turned_wall() {
    // Floor and walls welded into one closed room, turned so no wall is
    // axis-aligned; the light hangs 1 mm inside a wall, and receivers at
    // the wall's foot sit beside light-facing triangles that nearly
    // contain the light.
    let turn = Quat::from_rotation_z(0.3);
    let room = common::deformed(&cube(1.0, 4), |p| turn * (Vec3::new(-p.x, p.y, p.z) * 3.0));
    let world = scene(vec![
        still("room", room),
        still(
            "box",
            block(Vec3::splat(0.4), turn * Vec3::new(1.0, 0.5, -2.6), 2),
        ),
    ]);
    let cam = camera(
        turn * Vec3::new(-2.5, -2.0, 1.5),
        turn * Vec3::new(2.5, 0.5, -2.5),
    );
    for (x, z) in [(2.999, 1.0), (2.999, -2.9), (2.99999, 0.0)] {
        check(&world, &cam, &point(turn * Vec3::new(x, 0.5, z)), 128);
    }
}

/// Points on a grid through a box (seats, listeners), points on the
/// floor and on the slats, and the light itself.
fn points_in(lo: Vec3, hi: Vec3, n: usize) -> Vec<Vec3> {
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let f = |a: usize| (a as f32 + 0.5) / n as f32;
                out.push(lo + (hi - lo) * Vec3::new(f(i), f(j), f(k)));
            }
        }
    }
    out
}

#[test]
fn points_in_the_air_and_on_surfaces_see_the_light_and_sun_as_rays_say() {
    let mut objects = vec![
        still("floor", floor(4.0, 0.0, 4)),
        still(
            "box",
            block(Vec3::new(0.5, 0.4, 0.3), Vec3::new(0.2, -0.1, 1.2), 2),
        ),
    ];
    for k in 0..6 {
        let x = -1.5 + 0.5 * k as f32;
        objects.push(still(
            &format!("slat{k}"),
            block(Vec3::new(0.005, 1.0, 0.02), Vec3::new(x, 1.5, 1.5), 1),
        ));
    }
    let world = scene(objects);
    let shadows = ShadowScene::new(&world);
    let light = PointLight {
        position: Vec3::new(0.3, 0.2, 3.5),
    };
    let mut points = points_in(Vec3::new(-3.9, -3.9, 0.0), Vec3::new(3.9, 3.9, 2.0), 22);
    points.extend((0..200).map(|i| Vec3::new(-3.0 + 0.03 * i as f32, 0.1, 0.0)));
    points.extend((0..6).map(|k| Vec3::new(-1.5 + 0.5 * k as f32, 1.5, 1.52)));
    points.push(light.position);
    let answer = |light: &Light, method| {
        let options = ShadowOptions {
            method,
            shadow_map_size: 128,
            ..ShadowOptions::default()
        };
        shadows
            .visibility(&world, light, &points, &options)
            .unwrap()
    };
    let sunlight = sun(Vec3::new(0.2, -0.1, -1.0));
    let (full, selective) = (
        answer(&sunlight, Method::Full),
        answer(&sunlight, Method::Selective),
    );
    assert_eq!(selective.fraction, full.fraction);
    let hidden = full.fraction.iter().filter(|v| **v == 0.0).count();
    assert!(hidden > 150, "{hidden} hidden from the sun");
    let point_light = Light::Point(light);
    let (full, selective) = (
        answer(&point_light, Method::Full),
        answer(&point_light, Method::Selective),
    );
    assert_eq!(selective.fraction, full.fraction);
    let hidden = full.fraction.iter().filter(|v| **v == 0.0).count();
    assert!(
        hidden > 300 && hidden < points.len() - 3000,
        "{hidden} of {}",
        points.len()
    );
    let traced = selective.stats.pip_fraction();
    assert!(traced < 0.25, "traced {traced}");
    eprintln!(
        "{} points, {hidden} hidden, {:.1}% traced",
        points.len(),
        100.0 * traced
    );
    let bad = shadows.visibility(
        &world,
        &Light::Point(light),
        &[Vec3::new(f32::NAN, 0.0, 0.0)],
        &ShadowOptions::default(),
    );
    assert!(bad.is_err());
}

#[test]
fn a_surface_receives_light_only_on_the_side_it_is_seen_from() {
    // A floor seen from below, the light above: its seen side faces away.
    let world = scene(vec![still("floor", floor(4.0, 0.0, 2))]);
    let light = Vec3::new(0.0, 0.0, 3.0);
    for (eye, lit) in [
        (Vec3::new(0.5, -1.0, -3.0), 0.0),
        (Vec3::new(0.5, -1.0, 3.0), 1.0),
    ] {
        let cam = camera(eye, Vec3::ZERO);
        let (_, full, _) = check(&world, &cam, &point(light), 64);
        let seen = seen(&world, &cam, &full);
        assert!(seen.len() > 10_000);
        assert!(seen.iter().all(|v| *v == lit), "seen from {eye}");
    }
}

#[test]
fn auto_uses_the_light_map_only_where_it_pays() {
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 4)),
        still("box", block(Vec3::splat(0.4), Vec3::new(0.0, 0.0, 1.0), 2)),
    ]);
    let cam = camera(Vec3::new(0.5, -5.0, 3.0), Vec3::ZERO);
    let light = Vec3::new(0.3, 0.6, 3.0);
    let full = render(&world, &cam, light, Method::Full, 16);
    // 27,648 pixels: a 16-texel map (1,536 texels) for 128 triangles pays,
    // a 256-texel one (393,216 texels) does not.
    for (size, pays) in [(16, true), (256, false)] {
        let auto = render(&world, &cam, light, Method::Auto, size);
        assert_eq!(auto.visibility, full.visibility);
        assert_eq!(
            auto.stats.pip_pixels < auto.stats.receivers,
            pays,
            "{size}: {:?}",
            auto.stats
        );
        assert_eq!(auto.stats.light_map_ms > 0.0, pays);
    }
}

#[test]
fn a_spot_light_shadows_as_its_point_light_inside_its_cone_and_darkens_outside() {
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 6)),
        still(
            "box",
            block(Vec3::new(0.5, 0.4, 0.3), Vec3::new(0.2, -0.1, 1.2), 2),
        ),
    ]);
    let cam = camera(Vec3::new(0.5, -5.0, 3.0), Vec3::new(0.0, 0.0, 0.3));
    let position = Vec3::new(0.6, 0.3, 3.5);
    let direction = Vec3::new(-0.2, -0.3, -1.0);
    let half_angle_deg = 35.0f32;
    let spot = Light::Spot(SpotLight {
        position,
        direction,
        half_angle_deg,
    });
    let (_, full, _) = check(&world, &cam, &spot, 256);
    let (_, point_full, _) = check(&world, &cam, &point(position), 256);
    let g = ShadowScene::new(&world).gbuffer(&cam).unwrap();
    let (mut inside, mut outside) = (0, 0);
    for ((r, v), p) in g
        .receivers
        .iter()
        .zip(&full.visibility)
        .zip(&point_full.visibility)
    {
        let Some(r) = r else { continue };
        let out = r.point.as_dvec3() - position.as_dvec3();
        let angle = out.angle_between(direction.as_dvec3()).to_degrees();
        if (angle - f64::from(half_angle_deg)).abs() < 1e-4 {
            continue;
        }
        if angle < f64::from(half_angle_deg) {
            assert_eq!(v, p, "inside the cone at {:?}", r.point);
            inside += 1;
        } else {
            assert_eq!(*v, 0.0, "outside the cone at {:?}", r.point);
            outside += 1;
        }
    }
    assert!(
        inside > 5000 && outside > 5000,
        "{inside} inside, {outside} outside"
    );
}

#[test]
fn a_spot_light_of_no_cone_or_direction_is_refused() {
    let world = scene(vec![still("floor", floor(1.0, 0.0, 1))]);
    let cam = camera(Vec3::new(0.0, -2.0, 1.0), Vec3::ZERO);
    for (direction, half_angle_deg) in [
        (Vec3::NEG_Z, 0.0),
        (Vec3::NEG_Z, 181.0),
        (Vec3::NEG_Z, f32::NAN),
        (Vec3::ZERO, 30.0),
    ] {
        let spot = Light::Spot(SpotLight {
            position: Vec3::Z,
            direction,
            half_angle_deg,
        });
        let options = ShadowOptions::default();
        let r = ShadowScene::new(&world).shadows(&world, &cam, &spot, &options);
        assert!(r.is_err(), "{direction} {half_angle_deg}");
    }
}

#[test]
fn a_direction_of_zero_or_nan_is_refused() {
    let world = scene(vec![still("floor", floor(1.0, 0.0, 1))]);
    let cam = camera(Vec3::new(0.0, -2.0, 1.0), Vec3::ZERO);
    for direction in [
        Vec3::ZERO,
        Vec3::new(f32::NAN, 0.0, -1.0),
        Vec3::new(0.0, f32::INFINITY, 0.0),
    ] {
        let r = ShadowScene::new(&world).shadows(
            &world,
            &cam,
            &sun(direction),
            &ShadowOptions::default(),
        );
        assert!(r.is_err(), "{direction}");
    }
}
