//! Builder invariants on random and degenerate inputs, and ray queries
//! against brute force.

mod common;

use common::{all_methods, Rng};
use frusta_engine::bvh::traverse::STACK_SIZE;
use frusta_engine::bvh::{BuildMethod, BuildOptions, Bvh, MeshBvh};
use frusta_engine::geometry::{Aabb, Ray, TriangleMesh, WatertightRay};
use glam::{Vec3, Vec3A};
use proptest::prelude::*;

fn assert_valid(bvh: &Bvh, boxes: &[Aabb], options: &BuildOptions) {
    let mut seen = vec![false; boxes.len()];
    for &p in bvh.prim_ids() {
        assert!(!seen[p as usize], "primitive {p} twice");
        seen[p as usize] = true;
    }
    assert!(seen.iter().all(|&s| s), "a primitive is missing");
    for node in bvh.nodes() {
        if node.is_leaf() {
            assert!(node.count() <= options.max_leaf_size);
            for slot in node.first()..node.first() + node.count() {
                let b = boxes[bvh.prim_ids()[slot as usize] as usize];
                assert!(b.is_empty() || node.aabb().contains(&b));
            }
        } else {
            let l = node.first() as usize;
            for child in &bvh.nodes()[l..l + 2] {
                assert!(child.aabb().is_empty() || node.aabb().contains(&child.aabb()));
            }
        }
    }
    assert!(bvh.depth() < STACK_SIZE, "depth {}", bvh.depth());
}

fn boxes_strategy() -> impl Strategy<Value = Vec<Aabb>> {
    let coord = prop_oneof![-100.0f32..100.0, Just(0.0f32), Just(1.0f32), -1e-6f32..1e-6,];
    prop::collection::vec((coord.clone(), coord.clone(), coord, 0.0f32..5.0), 1..600).prop_map(
        |v| {
            v.into_iter()
                .map(|(x, y, z, s)| {
                    Aabb::new(Vec3A::new(x, y, z), Vec3A::new(x + s, y, z + s * 0.5))
                })
                .collect()
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn builders_keep_every_primitive_once_inside_its_boxes(boxes in boxes_strategy()) {
        for options in all_methods() {
            let bvh = Bvh::build(&boxes, &options);
            assert_valid(&bvh, &boxes, &options);
        }
    }
}

#[test]
fn identical_and_empty_boxes_give_shallow_valid_trees() {
    let same = vec![Aabb::new(Vec3A::ONE, Vec3A::splat(2.0)); 50_000];
    let mut mixed = same.clone();
    mixed.extend(std::iter::repeat_n(Aabb::EMPTY, 1000));
    for boxes in [same, mixed] {
        for options in all_methods() {
            let bvh = Bvh::build(&boxes, &options);
            assert_valid(&bvh, &boxes, &options);
            assert!(
                bvh.depth() <= 20,
                "{:?} depth {}",
                options.method,
                bvh.depth()
            );
        }
    }
    assert!(Bvh::build(&[], &BuildOptions::default()).nodes().is_empty());
}

fn triangle_soup(rng: &mut Rng, n: usize) -> TriangleMesh {
    let mut positions = Vec::new();
    for _ in 0..n {
        let c = Vec3::new(
            rng.range(-10.0, 10.0),
            rng.range(-10.0, 10.0),
            rng.range(-10.0, 10.0),
        );
        for _ in 0..3 {
            positions.push(c + rng.direction() * rng.range(0.1, 1.5));
        }
    }
    let triangles = (0..n as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    TriangleMesh::new(positions, triangles).unwrap()
}

#[test]
fn closest_and_any_hit_agree_with_brute_force() {
    let mut rng = Rng(5);
    let soup = triangle_soup(&mut rng, 3000);
    let rays: Vec<Ray> = (0..4000)
        .map(|i| {
            let o = Vec3::new(
                rng.range(-12.0, 12.0),
                rng.range(-12.0, 12.0),
                rng.range(-12.0, 12.0),
            );
            let r = Ray::new(o, rng.direction() * rng.range(0.5, 3.0));
            if i % 3 == 0 {
                r.with_range(0.5, rng.range(1.0, 8.0))
            } else {
                r
            }
        })
        .collect();
    for options in all_methods() {
        let bvh = MeshBvh::build(&soup, &options);
        for ray in &rays {
            let tri_ray = WatertightRay::new(ray);
            let brute = (0..soup.triangle_count())
                .filter_map(|t| {
                    let [a, b, c] = soup.corners(t);
                    tri_ray
                        .intersect(a, b, c, ray.t_min, ray.t_max)
                        .map(|h| h.t)
                })
                .min_by(|x, y| x.total_cmp(y));
            let hit = bvh.closest_hit(ray);
            assert_eq!(hit.map(|h| h.t), brute, "{:?} {ray:?}", options.method);
            if let Some(h) = hit {
                let [a, p, q] = soup.corners(h.triangle as usize);
                let point = a * (1.0 - h.u - h.v) + p * h.u + q * h.v;
                assert!((point - ray.at(h.t)).length() < 1e-3, "barycentrics off");
            }
            assert_eq!(bvh.any_hit(ray), brute.is_some());
        }
    }
}

#[test]
fn invalid_rays_hit_nothing_and_never_panic() {
    let cube = frusta_engine::geometry::shapes::cube(1.0, 2);
    let bvh = MeshBvh::build(&cube, &BuildOptions::default());
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    for ray in [
        Ray::new(Vec3::new(nan, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::ZERO, Vec3::new(nan, 1.0, 0.0)),
        Ray::new(Vec3::ZERO, Vec3::new(inf, 0.0, 0.0)),
        Ray::new(Vec3::splat(inf), Vec3::X),
        Ray::new(Vec3::ZERO, Vec3::ZERO),
        Ray::new(Vec3::ZERO, Vec3::X).with_range(nan, 1.0),
    ] {
        assert!(bvh.closest_hit(&ray).is_none());
        assert!(!bvh.any_hit(&ray));
    }
    // A direction with denormal components is still a valid ray.
    assert!(bvh
        .closest_hit(&Ray::new(Vec3::ZERO, Vec3::new(1e-40, 1.0, -1e-42)))
        .is_some());
    // An empty range hits nothing.
    assert!(bvh
        .closest_hit(&Ray::new(Vec3::ZERO, Vec3::X).with_range(2.0, 1.0))
        .is_none());
}

/// A scene of one object takes its mesh walk's checks alone (no check of
/// its own): invalid rays must still hit nothing through a rotation and a
/// translation, which keep a ray's non-finite or zero parts so, and a
/// valid one still hits.
#[test]
fn invalid_rays_hit_nothing_in_a_one_object_scene_that_is_moved() {
    use frusta_engine::bvh::SceneBvh;
    use frusta_engine::geometry::RigidTransform;
    use frusta_engine::scene::{Material, Scene};
    use glam::Quat;
    let turn = Quat::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 0.7);
    let scene = Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects: vec![common::object(
            "cube",
            frusta_engine::geometry::shapes::cube(1.0, 2),
            RigidTransform::new(turn, Vec3::new(3.0, -2.0, 1.0)).unwrap(),
        )],
    };
    let world = SceneBvh::build(&scene, &BuildOptions::default());
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    for ray in [
        Ray::new(Vec3::new(nan, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::ZERO, Vec3::new(nan, 1.0, 0.0)),
        Ray::new(Vec3::ZERO, Vec3::new(inf, 0.0, 0.0)),
        Ray::new(Vec3::splat(inf), Vec3::X),
        Ray::new(Vec3::new(3.0, -2.0, 1.0), Vec3::ZERO),
        Ray::new(Vec3::ZERO, Vec3::X).with_range(nan, 1.0),
    ] {
        assert!(world.closest_hit(&ray).is_none(), "{ray:?}");
        assert!(world.closest_triangle(&ray).is_none(), "{ray:?}");
        assert!(!world.any_hit(&ray), "{ray:?}");
    }
    let centre = Ray::new(Vec3::new(3.0, -2.0, 1.0), Vec3::X);
    assert!(world.closest_triangle(&centre).is_some());
}

#[test]
fn sah_trees_cost_less_than_morton_trees() {
    let mut rng = Rng(8);
    let soup = triangle_soup(&mut rng, 20_000);
    let cost = |m| MeshBvh::build(&soup, &BuildOptions::with_method(m)).sah_cost();
    let (sah, lbvh, hybrid) = (
        cost(BuildMethod::Sah),
        cost(BuildMethod::Lbvh),
        cost(BuildMethod::Hybrid),
    );
    assert!(sah < lbvh, "sah {sah} lbvh {lbvh}");
    assert!(hybrid < lbvh, "hybrid {hybrid} lbvh {lbvh}");
}

#[test]
fn zero_area_triangles_are_never_hit() {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::new(1.0, 1.0, 0.5),
    ];
    // Triangle 1 is a segment, triangle 2 a point, both in front of triangle 0.
    let mesh = TriangleMesh::new(positions, vec![[0, 1, 2], [3, 4, 4], [3, 3, 3]]).unwrap();
    let bvh = MeshBvh::build(&mesh, &BuildOptions::default());
    for d in [
        Vec3::Z,
        Vec3::new(0.0, 0.0, 1.0) + Vec3::new(0.5, 0.5, 0.0) * 1e-7,
    ] {
        let hit = bvh.closest_hit(&Ray::new(Vec3::ZERO, d)).unwrap();
        assert_eq!(hit.triangle, 0);
    }
}

/// A ray that runs exactly in the plane of box faces (zero direction
/// component, origin on the plane) still enters those boxes: here it meets
/// the edge shared by two walls whose leaf boxes both end at y = 0.
#[test]
fn rays_in_box_face_planes_are_kept() {
    let positions = vec![
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 1.0, 1.0),
    ];
    let triangles = vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]];
    let wall = TriangleMesh::new(positions, triangles).unwrap();
    for method in [BuildMethod::Sah, BuildMethod::Lbvh] {
        let options = BuildOptions {
            max_leaf_size: 1,
            ..BuildOptions::with_method(method)
        };
        let bvh = MeshBvh::build(&wall, &options);
        for (origin, dir) in [
            (Vec3::new(0.0, 0.0, 0.5), Vec3::X),
            (Vec3::new(0.0, 0.0, 0.5), Vec3::new(1.0, -0.0, 0.0)),
            (Vec3::new(2.0, 0.0, 0.25), Vec3::new(-1.0, 0.0, -0.0)),
        ] {
            let ray = Ray::new(origin, dir);
            let hit = bvh.closest_hit(&ray);
            assert_eq!(hit.map(|h| h.t), Some(1.0), "{method:?} {ray:?}");
            let mut n = 0;
            bvh.for_each_hit(&ray, |_, _| n += 1);
            assert_eq!(n, 1, "{method:?} {ray:?}");
        }
    }
}
