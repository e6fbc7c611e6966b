//! The exact reference: the image-source method over every sequence of
//! surface events up to a maximum order, each validated exactly.
//!
//! Exponential in the order (groups^order sequences), so it serves as ground
//! truth for tests and benchmarks at low orders, not as a solver. It shares
//! [`validate`](super::path::validate) with the frustum tracer; the tests
//! check that function itself against the closed-form image sources of a
//! box room.

use glam::DVec3;
use rayon::prelude::*;

use super::path::{dedup_paths, validate, Event, ValidPath};
use super::surfaces::Surfaces;
use crate::query::SceneBvh;
use crate::scene::Material;

/// Every valid path from `source` to `listener` of order at most
/// `max_order`, sorted by length. `materials` decides which groups also
/// transmit.
pub fn image_sources(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    materials: &[Material],
    source: DVec3,
    listener: DVec3,
    max_order: usize,
) -> Vec<ValidPath> {
    let events: Vec<Event> = surfaces
        .groups()
        .flat_map(|(g, group)| {
            let transmits = materials
                .get(group.material as usize)
                .is_some_and(Material::transmits);
            std::iter::once(Event::reflection(g)).chain(transmits.then(|| Event::transmission(g)))
        })
        .collect();
    let mut paths: Vec<ValidPath> = validate(bvh, surfaces, source, listener, &[])
        .into_iter()
        .collect();
    if max_order > 0 {
        paths.par_extend(events.par_iter().flat_map_iter(|&first| {
            let mut found = Vec::new();
            let mut prefix = vec![first];
            extend(
                bvh,
                surfaces,
                &events,
                source,
                listener,
                max_order,
                &mut prefix,
                &mut found,
            );
            found
        }));
    }
    paths.sort_by(|a, b| a.length.total_cmp(&b.length));
    dedup_paths(&mut paths);
    paths
}

/// Validates `prefix` and every continuation of it, depth first.
#[allow(clippy::too_many_arguments)]
fn extend(
    bvh: &SceneBvh,
    surfaces: &Surfaces,
    events: &[Event],
    source: DVec3,
    listener: DVec3,
    max_order: usize,
    prefix: &mut Vec<Event>,
    found: &mut Vec<ValidPath>,
) {
    found.extend(validate(bvh, surfaces, source, listener, prefix));
    if prefix.len() == max_order {
        return;
    }
    let last = prefix.last().map(|e| e.group());
    for &e in events {
        // Meeting the same plane twice in a row is not a path.
        if Some(e.group()) == last {
            continue;
        }
        prefix.push(e);
        extend(
            bvh, surfaces, events, source, listener, max_order, prefix, found,
        );
        prefix.pop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::generate::BoxRoom;
    use crate::scene::Scene;
    use glam::Vec3;

    /// The closed-form image sources of an axis-aligned box: per axis,
    /// positions `2 k L ± x` with `|k|`-dependent reflection counts.
    fn box_images(size: DVec3, s: DVec3, max_order: i32) -> Vec<DVec3> {
        let mut out = Vec::new();
        let r = max_order;
        for i in -r..=r {
            for j in -r..=r {
                for k in -r..=r {
                    if i.abs() + j.abs() + k.abs() > r {
                        continue;
                    }
                    let coord = |n: i32, l: f64, x: f64| {
                        // n reflections along one axis: even n shifts, odd n mirrors.
                        let m = n.div_euclid(2);
                        if n % 2 == 0 {
                            2.0 * f64::from(m) * l + x
                        } else {
                            2.0 * f64::from(m + 1) * l - x
                        }
                    };
                    out.push(DVec3::new(
                        coord(i, size.x, s.x),
                        coord(j, size.y, s.y),
                        coord(k, size.z, s.z),
                    ));
                }
            }
        }
        out
    }

    #[test]
    fn box_room_matches_the_closed_form_image_sources() {
        let size = DVec3::new(10.0, 6.0, 3.0);
        let scene = crate::acoustics::test_shoebox(2, 0.1);
        let bvh = SceneBvh::build(&scene, &BuildOptions::default());
        let surfaces = Surfaces::new(&bvh);
        let (s, l) = (DVec3::new(2.0, 3.5, 1.2), DVec3::new(7.3, 1.9, 1.7));
        let paths = image_sources(&bvh, &surfaces, &scene.materials, s, l, 4);
        assert_eq!(paths.len(), 129);
        let mut expected = box_images(size, s, 4);
        expected.sort_by(|a, b| a.distance(l).total_cmp(&b.distance(l)));
        for (p, e) in paths.iter().zip(&expected) {
            assert!(
                (p.length - e.distance(l)).abs() < 1e-9 * p.length,
                "{} vs {}",
                p.length,
                e.distance(l)
            );
            assert!((p.image_source.distance(l) - p.length).abs() < 1e-9 * p.length);
        }
    }

    #[test]
    fn an_occluder_removes_the_paths_it_blocks() {
        let size = Vec3::new(10.0, 6.0, 3.0);
        let room = BoxRoom::new(Vec3::ZERO, size).generate().unwrap();
        let mut scene =
            Scene::single_object("room", room, Material::uniform("w", 0.1).unwrap()).unwrap();
        // A free-standing panel between source and listener blocks the direct path.
        let panel = crate::geometry::TriangleMesh::new(
            vec![
                Vec3::new(5.0, 2.0, 0.5),
                Vec3::new(5.0, 4.0, 0.5),
                Vec3::new(5.0, 4.0, 2.5),
                Vec3::new(5.0, 2.0, 2.5),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        scene.objects.push(crate::scene::SceneObject {
            name: "panel".into(),
            mesh: panel,
            materials: vec![0, 0],
            transform: Default::default(),
            dynamic: false,
        });
        let bvh = SceneBvh::build(&scene, &BuildOptions::default());
        let surfaces = Surfaces::new(&bvh);
        let (s, l) = (DVec3::new(2.0, 3.0, 1.5), DVec3::new(8.0, 3.0, 1.5));
        let paths = image_sources(&bvh, &surfaces, &scene.materials, s, l, 1);
        assert!(
            paths.iter().all(|p| p.order() == 1),
            "direct path must be blocked"
        );
        // Floor, ceiling and side walls pass around the panel; both end
        // walls' paths run along y = 3, z = 1.5 through it.
        assert_eq!(paths.len(), 4);
    }
}
