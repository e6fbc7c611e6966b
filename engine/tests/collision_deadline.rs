//! Collision queries stop at their deadline or when cancelled: every kind
//! of test fails with the deadline (or cancellation) error instead of
//! running on, and the same query without either finds its contacts.

mod common;

use std::time::Instant;

use common::object;
use frusta_engine::bvh::{BuildOptions, SceneBvh};
use frusta_engine::collision::continuous::EndPose;
use frusta_engine::collision::{CollisionQuery, CollisionTest};
use frusta_engine::geometry::{shapes, RigidTransform};
use frusta_engine::scene::{Material, Scene};
use frusta_engine::{Cancel, Error};
use glam::{Quat, Vec3};

/// Two dense balls through each other: thousands of pairs of leaves.
fn world() -> SceneBvh {
    let at = |x: f32| RigidTransform::new(Quat::IDENTITY, Vec3::new(x, 0.0, 0.0)).unwrap();
    let scene = Scene {
        materials: vec![Material::uniform("m", 0.1).unwrap()],
        objects: vec![
            object("a", shapes::icosphere(1.0, 4), at(0.0)),
            object("b", shapes::icosphere(1.0, 4), at(0.8)),
        ],
    };
    SceneBvh::build(&scene, &BuildOptions::default())
}

#[test]
fn every_kind_of_query_stops_at_a_passed_deadline() {
    let world = world();
    let moved = RigidTransform::new(Quat::IDENTITY, Vec3::new(0.5, 0.0, 0.0)).unwrap();
    for test in [
        CollisionTest::Discrete,
        CollisionTest::Proximity { distance: 0.05 },
        CollisionTest::Continuous { tolerance: None },
    ] {
        for (pairs, selves) in [(vec![(0, 1)], vec![]), (vec![], vec![0])] {
            if !selves.is_empty() && matches!(test, CollisionTest::Proximity { .. }) {
                continue; // proximity has no self form
            }
            let query = CollisionQuery {
                test,
                pairs: pairs.clone(),
                selves: selves.clone(),
            };
            let ends = [(1, EndPose::Moved(&moved))];
            let late = query.run_during(&world, &ends, Some(Instant::now()), None);
            assert!(
                matches!(late, Err(Error::DeadlineExceeded { .. })),
                "{test:?} {pairs:?} {selves:?}: {late:?}"
            );
            // A client that left: cancelled, with no deadline at all.
            let cancel = Cancel::new();
            cancel.cancel();
            for left in [
                query.run_during(&world, &ends, None, Some(&cancel)),
                query.run(&world, None, Some(&cancel)),
            ] {
                assert_eq!(left, Err(Error::Cancelled), "{test:?} {pairs:?} {selves:?}");
            }
            let found = query.run_during(&world, &ends, None, None).unwrap();
            // The balls meet; a ball alone does not meet itself.
            assert_eq!(!found.is_empty(), !pairs.is_empty(), "{test:?}");
        }
    }
}
