//! Scenes for the shadow tests: floors, boxes, a camera.

use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::geometry::shapes::cube;
use frusta_engine::geometry::{RigidTransform, TriangleMesh};
use frusta_engine::scene::{Material, Scene, SceneObject};
use frusta_engine::shadows::{Camera, Light, Method, ShadowImage, ShadowOptions, ShadowScene};
use glam::{DVec2, DVec3, Vec3};

use super::{deformed, grid_triangles, object};

/// A floor `[-h, h]^2` at height `z`, `n x n` quads, facing up.
pub fn floor(h: f32, z: f32, n: usize) -> TriangleMesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let at = |k: usize| -h + 2.0 * h * k as f32 / n as f32;
            positions.push(Vec3::new(at(i), at(j), z));
        }
    }
    TriangleMesh::new(positions, grid_triangles(n, n)).unwrap()
}

/// A box of half sizes `half` centred at `at`, each face `n x n` quads.
pub fn block(half: Vec3, at: Vec3, n: u32) -> TriangleMesh {
    let c = cube(1.0, n);
    deformed(&c, |p| p * half + at)
}

pub fn scene(objects: Vec<SceneObject>) -> SceneBvh {
    let scene = Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects,
    };
    SceneBvh::build(&scene, &BuildOptions::default())
}

pub fn still(name: &str, mesh: TriangleMesh) -> SceneObject {
    object(name, mesh, RigidTransform::IDENTITY)
}

/// A 192 x 144 camera at `at` looking at `look`.
pub fn camera(at: Vec3, look: Vec3) -> Camera {
    Camera::looking_at(at, look, 192, 144)
}

/// The convex hull of `points`, counter-clockwise, by gift wrapping in
/// `f64`.
pub fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    let start = points.iter().copied().fold(
        points[0],
        |a, b| if (b.x, b.y) < (a.x, a.y) { b } else { a },
    );
    let mut hull = vec![start];
    loop {
        let last = *hull.last().unwrap();
        let mut next = points[0];
        for &q in points {
            let cross = (next - last).perp_dot(q - last);
            if next == last
                || cross < 0.0
                || (cross == 0.0 && last.distance(q) > last.distance(next))
            {
                next = q;
            }
        }
        if next == start {
            break;
        }
        hull.push(next);
    }
    hull
}

/// A floor under a 1 mm wire across the scene and a row of 1 cm slats:
/// geometry a shadow map drops.
pub fn wire_and_slats() -> Vec<SceneObject> {
    let mut objects = vec![still("floor", floor(4.0, 0.0, 4))];
    objects.push(still(
        "wire",
        block(Vec3::new(3.0, 0.0005, 0.0005), Vec3::new(0.0, 0.5, 1.0), 1),
    ));
    for k in 0..12 {
        let x = -1.5 + 0.25 * k as f32;
        objects.push(still(
            &format!("slat{k}"),
            block(Vec3::new(0.005, 1.0, 0.02), Vec3::new(x, -1.0, 1.5), 1),
        ));
    }
    objects
}

/// The visibility of the pixels of `image` that see a surface of `world`
/// through `camera`.
pub fn seen(world: &SceneBvh, camera: &Camera, image: &ShadowImage) -> Vec<f32> {
    let g = ShadowScene::new(world).gbuffer(camera).unwrap();
    g.receivers
        .iter()
        .zip(&image.visibility)
        .filter_map(|(r, v)| r.map(|_| *v))
        .collect()
}

/// A box over a floor shrunk to a millimetre scale, grown ten
/// thousandfold, and moved 30 km from the origin: each world, its camera,
/// where its light goes, and its scale.
pub fn box_at_extreme_scales() -> Vec<(SceneBvh, Camera, Vec3, f32)> {
    [
        (1e-3f32, Vec3::ZERO),
        (1e4, Vec3::ZERO),
        (1.0, Vec3::new(3e4, -2e4, 1e4)),
    ]
    .into_iter()
    .map(|(scale, offset)| {
        let f = |p: Vec3| p * scale + offset;
        let world = scene(vec![
            still("floor", deformed(&floor(4.0, 0.0, 4), f)),
            still(
                "box",
                deformed(&block(Vec3::splat(0.4), Vec3::new(0.0, 0.0, 1.0), 2), f),
            ),
        ]);
        let cam = camera(f(Vec3::new(0.5, -5.0, 3.0)), f(Vec3::ZERO));
        (world, cam, f(Vec3::new(0.3, 0.6, 3.0)), scale)
    })
    .collect()
}

/// The shadows of `light` through `camera` by `method`, with light-map
/// faces of `size` texels.
pub fn render(
    world: &SceneBvh,
    camera: &Camera,
    light: &Light,
    method: Method,
    size: u32,
) -> ShadowImage {
    let options = ShadowOptions {
        method,
        shadow_map_size: size,
        ..ShadowOptions::default()
    };
    ShadowScene::new(world)
        .shadows(world, camera, light, &options)
        .unwrap()
}

/// Pixels where two images differ.
pub fn wrong(a: &ShadowImage, b: &ShadowImage) -> usize {
    a.visibility
        .iter()
        .zip(&b.visibility)
        .filter(|(x, y)| x != y)
        .count()
}

/// Selective against full: no pixel may differ. Returns both and the plain
/// shadow map's count of wrong pixels.
pub fn check(
    world: &SceneBvh,
    camera: &Camera,
    light: &Light,
    size: u32,
) -> (ShadowImage, ShadowImage, usize) {
    let full = render(world, camera, light, Method::Full, size);
    let selective = render(world, camera, light, Method::Selective, size);
    let plain = render(world, camera, light, Method::ShadowMap, size);
    assert_eq!(
        wrong(&selective, &full),
        0,
        "selective differs from full ray tracing"
    );
    let plain_wrong = wrong(&plain, &full);
    let shadowed = full.visibility.iter().filter(|v| **v == 0.0).count();
    let lit = full.visibility.len() - shadowed;
    eprintln!(
        "{} x {}: {shadowed} shadowed, {lit} lit or empty; selective traced {:.1}% of {} receivers; shadow map wrong on {}",
        camera.width,
        camera.height,
        100.0 * selective.stats.pip_fraction(),
        full.stats.receivers,
        plain_wrong
    );
    (selective, full, plain_wrong)
}

/// Signed distance of `p` outside the convex hull of `points` (negative
/// inside).
pub fn hull_distance(points: &[DVec2], p: DVec2) -> f64 {
    let hull = convex_hull(points);
    // Counter-clockwise hull: outside is where any edge sees p on its
    // right.
    (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            -(b - a).perp_dot(p - a) / a.distance(b)
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Checks the shadows of `light` on a box over a floor against the
/// closed form and full ray tracing: selective equals full on every pixel,
/// which traces under 30% of them; every floor pixel is shadowed inside
/// the hull of the box's corners moved by `onto_floor` onto z = 0 (z
/// dropped) and lit outside, pixels within 1e-4 of its edge skipped; more
/// than `min_shadowed` pixels are shadowed, and a plain 256 texel shadow
/// map gets some edge pixels wrong.
pub fn assert_box_shadow(light: &Light, onto_floor: impl Fn(DVec3) -> DVec2, min_shadowed: usize) {
    let (half, centre) = (Vec3::new(0.5, 0.4, 0.3), Vec3::new(0.2, -0.1, 1.2));
    let world = scene(vec![
        still("floor", floor(4.0, 0.0, 6)),
        still("box", block(half, centre, 2)),
    ]);
    let cam = camera(Vec3::new(0.5, -5.0, 3.0), Vec3::new(0.0, 0.0, 0.3));
    let (selective, full, plain_wrong) = check(&world, &cam, light, 256);
    let shadow: Vec<DVec2> = (0..8)
        .map(|k| {
            let s = DVec3::new(
                [-1.0, 1.0][k & 1],
                [-1.0, 1.0][(k >> 1) & 1],
                [-1.0, 1.0][k >> 2],
            );
            onto_floor(centre.as_dvec3() + s * half.as_dvec3())
        })
        .collect();
    let g = ShadowScene::new(&world).gbuffer(&cam).unwrap();
    let mut checked = 0;
    for (r, v) in g.receivers.iter().zip(&full.visibility) {
        let Some(r) = r else { continue };
        if r.object != 0 {
            continue;
        }
        let d = hull_distance(&shadow, r.point.as_dvec3().truncate());
        if d.abs() < 1e-4 {
            continue;
        }
        let expected = if d < 0.0 { 0.0 } else { 1.0 };
        assert_eq!(*v, expected, "floor point {:?}", r.point);
        checked += 1;
    }
    assert!(checked > 10_000, "{checked} floor pixels checked");
    let shadowed = full.visibility.iter().filter(|v| **v == 0.0).count();
    assert!(shadowed > min_shadowed, "{shadowed} shadowed");
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

/// A bar over a floor twisting and bending over four frames, each checked
/// by [`check`] under `light(a)` for the frame's angle `a`.
pub fn check_over_a_deforming_bar(light: impl Fn(f32) -> Light) {
    let base = block(Vec3::new(0.6, 0.2, 0.2), Vec3::new(0.0, 0.0, 1.0), 6);
    let mut world = scene(vec![
        still("floor", floor(3.0, 0.0, 5)),
        still("bar", base.clone()),
    ]);
    let cam = camera(Vec3::new(0.0, -4.0, 3.0), Vec3::ZERO);
    for frame in 0..4 {
        let a = 0.4 * frame as f32;
        let twisted = deformed(&base, |p| {
            let q = glam::Quat::from_rotation_x(a * p.x) * (p - Vec3::Z) + Vec3::Z;
            q + Vec3::new(0.0, 0.0, 0.1 * (3.0 * p.x).sin() * frame as f32)
        });
        world
            .update_mesh(1, &twisted, &vec![0; twisted.triangle_count()], 0.5)
            .unwrap();
        check(&world, &cam, &light(a), 192);
    }
}
