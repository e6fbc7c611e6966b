//! Hard shadows of a directional light (the sun): full ray tracing against
//! the closed-form shadow of a box, and selective ray tracing against full
//! ray tracing, pixel for pixel, on thin geometry, grazing and
//! axis-aligned light, extreme scales, moving light over a deforming
//! occluder, and points in the air.

mod common;

use common::shadow_scenes::{
    block, box_at_extreme_scales, camera, check, floor, hull_distance, scene, still, wire_and_slats,
};
use frusta_engine::shadows::{DirectionalLight, Light, Method, ShadowOptions, ShadowScene};
use glam::{DVec2, DVec3, Quat, Vec3};

fn sun(direction: Vec3) -> Light {
    Light::Directional(DirectionalLight { direction })
}

#[test]
fn a_box_over_a_floor_casts_its_exact_shadow_in_sunlight() {
    let half = Vec3::new(0.5, 0.4, 0.3);
    let centre = Vec3::new(0.2, -0.1, 1.2);
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 6)),
        still("box", block(half, centre, 2)),
    ]);
    let direction = Vec3::new(-0.4, -0.5, -1.0);
    let cam = camera(Vec3::new(0.5, -5.0, 3.0), Vec3::new(0.0, 0.0, 0.3));
    let (selective, full, plain_wrong) = check(&world, &cam, &sun(direction), 256);
    // The floor's shadow is the hull of the box's corners moved along the
    // light's direction onto z = 0.
    let d = direction.as_dvec3();
    let corners: Vec<DVec2> = (0..8)
        .map(|k| {
            let s = DVec3::new(
                [-1.0, 1.0][k & 1],
                [-1.0, 1.0][(k >> 1) & 1],
                [-1.0, 1.0][k >> 2],
            );
            let c = centre.as_dvec3() + s * half.as_dvec3();
            (c + d * (c.z / -d.z)).truncate()
        })
        .collect();
    let g = ShadowScene::new(&world).gbuffer(&cam).unwrap();
    let mut checked = 0;
    for (r, v) in g.receivers.iter().zip(&full.visibility) {
        let Some(r) = r else { continue };
        if r.object != 0 {
            continue;
        }
        let distance = hull_distance(&corners, r.point.as_dvec3().truncate());
        if distance.abs() < 1e-4 {
            continue;
        }
        let expected = if distance < 0.0 { 0.0 } else { 1.0 };
        assert_eq!(*v, expected, "floor point {:?}", r.point);
        checked += 1;
    }
    assert!(checked > 10_000, "{checked} floor pixels checked");
    assert!(full.visibility.iter().filter(|v| **v == 0.0).count() > 500);
    assert!(
        selective.stats.pip_fraction() < 0.3,
        "{:?}",
        selective.stats
    );
    assert!(
        plain_wrong > 0,
        "a 256 texel shadow map should miss some edge pixels"
    );
}

#[test]
fn a_thin_wire_and_slats_in_sunlight_are_traced() {
    let world = scene(wire_and_slats());
    let cam = camera(Vec3::new(0.0, -4.5, 3.5), Vec3::new(0.0, -0.3, 0.0));
    for direction in [Vec3::new(0.05, -0.1, -1.0), Vec3::new(0.6, 0.3, -1.0)] {
        let (_, full, plain_wrong) = check(&world, &cam, &sun(direction), 128);
        assert!(full.visibility.iter().filter(|v| **v == 0.0).count() > 200);
        assert!(
            plain_wrong > 50,
            "the shadow map should lose the wire: {plain_wrong}"
        );
    }
}

#[test]
fn grazing_axis_aligned_and_upward_sunlight() {
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 8)),
        still("box", block(Vec3::splat(0.3), Vec3::new(0.0, 0.0, 0.3), 3)),
    ]);
    let cam = camera(Vec3::new(1.0, -4.0, 2.0), Vec3::ZERO);
    for direction in [
        // Along the box's faces and edges, down the axes.
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        // A thousandth above the floor's plane, exactly in it, and from
        // below it.
        Vec3::new(1.0, 0.05, -0.001),
        Vec3::new(1.0, 0.05, 0.0),
        Vec3::new(0.2, 0.1, 1.0),
    ] {
        check(&world, &cam, &sun(direction), 256);
    }
}

#[test]
fn sunlight_at_tiny_and_huge_scales_far_from_the_origin() {
    for (world, cam, _, _) in box_at_extreme_scales() {
        check(&world, &cam, &sun(Vec3::new(-0.3, -0.6, -1.0)), 256);
    }
}

#[test]
fn a_moving_sun_over_a_deforming_occluder() {
    let base = block(Vec3::new(0.6, 0.2, 0.2), Vec3::new(0.0, 0.0, 1.0), 6);
    let mut world = scene(vec![
        still("floor", floor(3.0, 0.0, 5)),
        still("bar", base.clone()),
    ]);
    let cam = camera(Vec3::new(0.0, -4.0, 3.0), Vec3::ZERO);
    for frame in 0..4 {
        let a = 0.4 * frame as f32;
        let twisted = common::deformed(&base, |p| {
            let q = Quat::from_rotation_x(a * p.x) * (p - Vec3::Z) + Vec3::Z;
            q + Vec3::new(0.0, 0.0, 0.1 * (3.0 * p.x).sin() * frame as f32)
        });
        world
            .update_mesh(1, &twisted, &vec![0; twisted.triangle_count()], 0.5)
            .unwrap();
        let direction = Vec3::new(-0.5 * a.cos(), -0.5 * a.sin(), -1.0);
        check(&world, &cam, &sun(direction), 192);
    }
}

#[test]
fn points_in_the_air_and_on_surfaces_see_the_sun_as_rays_say() {
    let world = scene(wire_and_slats());
    let shadows = ShadowScene::new(&world);
    let mut points = Vec::new();
    for i in 0..24 {
        for j in 0..24 {
            for k in 0..6 {
                let f = |n: usize, m: usize| n as f32 / (m - 1) as f32;
                points.push(Vec3::new(
                    -2.0 + 4.0 * f(i, 24),
                    -2.0 + 4.0 * f(j, 24),
                    -0.5 + 3.0 * f(k, 6),
                ));
            }
        }
    }
    let light = sun(Vec3::new(0.2, -0.1, -1.0));
    let answer = |method| {
        let options = ShadowOptions {
            method,
            shadow_map_size: 128,
            ..ShadowOptions::default()
        };
        shadows
            .visibility(&world, &light, &points, &options)
            .unwrap()
    };
    let full = answer(Method::Full);
    let selective = answer(Method::Selective);
    assert_eq!(selective.fraction, full.fraction);
    let hidden = full.fraction.iter().filter(|v| **v == 0.0).count();
    assert!(hidden > 20 && hidden < points.len() / 2, "{hidden} hidden");
    assert!(selective.stats.pip_pixels < selective.stats.receivers);
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
