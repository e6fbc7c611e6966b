//! Properties on the standard test meshes of `../shared/data/meshes/`.
//! Skipped with a message where the folder is absent; `.ci/run` requires it.

mod common;

use common::{all_methods, meshes_dir, standard_meshes, Rng};
use frusta_engine::bvh::MeshBvh;
use frusta_engine::geometry::{Ray, TriangleMesh, WatertightRay};
use frusta_engine::scene::Scene;
use glam::Vec3;

fn load(name: &str) -> Option<TriangleMesh> {
    let path = meshes_dir()?.join(name);
    Some(Scene::load(&path).unwrap().world_mesh().unwrap())
}

/// Spot is a closed manifold: every line through it crosses its surface an
/// even number of times, so a ray from outside that enters must leave.
#[test]
fn lines_cross_the_closed_spot_mesh_an_even_number_of_times() {
    let Some(spot) = load("spot.obj") else { return };
    let bounds = spot.bounds();
    let (lo, hi) = (Vec3::from(bounds.min), Vec3::from(bounds.max));
    let radius = (hi - lo).length();
    let centre = (lo + hi) * 0.5;
    let mut rng = Rng(17);
    // Aim at random surface vertices and random points inside the box.
    let mut targets: Vec<Vec3> = spot.positions().iter().step_by(7).copied().collect();
    targets
        .extend((0..20_000).map(|_| lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32())));
    for options in all_methods() {
        let bvh = MeshBvh::build(&spot, &options);
        let mut odd = 0;
        for &target in &targets {
            let origin = centre + rng.direction() * radius * 2.0;
            let mut n = 0;
            bvh.for_each_hit(&Ray::new(origin, target - origin), |_, _| n += 1);
            odd += n % 2;
        }
        assert_eq!(
            odd,
            0,
            "{:?}: {odd} of {} lines leaked",
            options.method,
            targets.len()
        );
    }
}

/// On the bunny (open, with holes) the nearest hit equals brute force.
#[test]
fn bunny_closest_hits_match_brute_force() {
    let Some(bunny) = load("stanford-bunny.obj") else {
        return;
    };
    let bounds = bunny.bounds();
    let (lo, hi) = (Vec3::from(bounds.min), Vec3::from(bounds.max));
    let mut rng = Rng(23);
    let rays: Vec<Ray> = (0..300)
        .map(|_| {
            Ray::new(
                lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32()),
                rng.direction(),
            )
        })
        .collect();
    for options in all_methods() {
        let bvh = MeshBvh::build(&bunny, &options);
        for ray in &rays {
            let w = WatertightRay::new(ray);
            let brute = (0..bunny.triangle_count())
                .filter_map(|t| {
                    let [a, b, c] = bunny.corners(t);
                    w.intersect(a, b, c, ray.t_min, ray.t_max).map(|h| h.t)
                })
                .min_by(f32::total_cmp);
            assert_eq!(
                bvh.closest_hit(ray).map(|h| h.t),
                brute,
                "{:?} {ray:?}",
                options.method
            );
        }
    }
}

/// Every standard mesh loads, builds with every method and refits.
#[test]
fn every_standard_mesh_builds_and_refits() {
    for (name, mesh) in standard_meshes() {
        for options in all_methods() {
            let mut bvh = MeshBvh::build(&mesh, &options);
            assert_eq!(bvh.triangle_count(), mesh.triangle_count());
            let report = bvh.refit(&mesh).unwrap();
            assert!(
                report.degradation.abs() < 1e-3,
                "{name}: refit in place changed the tree"
            );
        }
    }
}
