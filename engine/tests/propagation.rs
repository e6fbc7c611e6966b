//! Frustum tracing against the exact image-source reference.

use frusta_engine::acoustics::path::ValidPath;
use frusta_engine::acoustics::reference::image_sources;
use frusta_engine::acoustics::{AcousticScene, TraceOptions};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene};
use glam::{DVec3, Vec3};

fn shoebox(subdivisions: u32, absorption: f32) -> Scene {
    let mut room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0));
    room.subdivisions = subdivisions;
    Scene::single_object(
        "room",
        room.generate().unwrap(),
        Material::uniform("walls", absorption).unwrap(),
    )
    .unwrap()
}

fn bundled(name: &str) -> Scene {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.json"));
    Scene::load(&path).unwrap()
}

/// Compares traced paths with the reference: returns (found, exact, false).
fn compare(
    scene: &AcousticScene,
    s: DVec3,
    l: DVec3,
    order: u32,
    sampling: u32,
) -> (usize, usize, usize, Vec<ValidPath>) {
    let options = TraceOptions {
        max_order: order,
        sampling,
        energy_threshold: 0.0,
        ..TraceOptions::default()
    };
    let traced = scene.find_paths(s, &[l], &options).paths.remove(0);
    let exact = image_sources(
        scene.bvh(),
        scene.surfaces(),
        scene.materials(),
        s,
        l,
        order as usize,
    );
    let matches = |a: &ValidPath, b: &ValidPath| {
        a.vertices
            .iter()
            .map(|v| v.event)
            .eq(b.vertices.iter().map(|v| v.event))
    };
    let found = exact
        .iter()
        .filter(|e| traced.iter().any(|t| matches(t, e)))
        .count();
    let false_paths = traced
        .iter()
        .filter(|t| !exact.iter().any(|e| matches(t, e)))
        .count();
    let missing: Vec<ValidPath> = exact
        .iter()
        .filter(|e| !traced.iter().any(|t| matches(t, e)))
        .cloned()
        .collect();
    (found, exact.len(), false_paths, missing)
}

#[test]
fn shoebox_finds_every_image_source_to_order_6() {
    for subdivisions in [1, 3] {
        let scene = AcousticScene::new(&shoebox(subdivisions, 0.2));
        let (s, l) = (DVec3::new(2.0, 3.5, 1.2), DVec3::new(7.3, 1.9, 1.7));
        let (found, exact, false_paths, missing) = compare(&scene, s, l, 6, 8);
        assert_eq!(false_paths, 0);
        assert_eq!(
            found,
            exact,
            "missing {:?}",
            missing.iter().map(|m| m.image_source).collect::<Vec<_>>()
        );
    }
}

#[test]
fn l_room_and_two_rooms_recall() {
    for (name, s, l, order) in [
        (
            "l-room",
            DVec3::new(1.0, 9.0, 1.5),
            DVec3::new(11.0, 5.0, 1.2),
            4,
        ),
        (
            "two-rooms",
            DVec3::new(1.5, 2.0, 1.5),
            DVec3::new(8.0, 1.0, 1.2),
            3,
        ),
    ] {
        let scene = AcousticScene::new(&bundled(name));
        let (found, exact, false_paths, _) = compare(&scene, s, l, order, 16);
        println!("{name}: {found}/{exact}");
        assert_eq!(false_paths, 0);
        assert!(
            found as f64 >= 0.99 * exact as f64,
            "{name}: {found}/{exact}"
        );
    }
}

#[test]
fn sampled_cells_find_the_box_image_sources() {
    let scene = AcousticScene::new(&shoebox(4, 0.2));
    let (s, l) = (DVec3::new(2.0, 3.5, 1.2), DVec3::new(7.3, 1.9, 1.7));
    let run = |cells| {
        let options = TraceOptions {
            max_order: 4,
            sampling: 8,
            energy_threshold: 0.0,
            cells,
            ..TraceOptions::default()
        };
        scene.find_paths(s, &[l], &options)
    };
    let sampled = run(frusta_engine::acoustics::CellAssignment::Sampled);
    let conservative = run(frusta_engine::acoustics::CellAssignment::Conservative);
    // Walls are large next to cells here, so sample rays miss nothing.
    assert_eq!(sampled.paths[0].len(), 129);
    let lengths = |p: &[ValidPath]| p.iter().map(|x| x.length).collect::<Vec<_>>();
    assert_eq!(lengths(&sampled.paths[0]), lengths(&conservative.paths[0]));
}

mod cached {
    use std::time::{Duration, Instant};

    use frusta_engine::acoustics::{
        simulate, simulate_cached, simulate_until, AcousticScene, BeamCache, CellAssignment,
        Response, SimulationOptions, SoundPath, Tail, TailOptions,
    };
    use frusta_engine::geometry::RigidTransform;
    use frusta_engine::Error;
    use glam::Vec3;

    use super::{bundled, shoebox};

    /// Beams are kept for the very source position only: these tests
    /// hold cached answers to be the fresh ones, bit for bit.
    fn options(max_order: u32) -> SimulationOptions {
        SimulationOptions {
            max_order,
            sample_rate: 8_000,
            source_reuse_m: 0.0,
            ..Default::default()
        }
    }

    /// Everything but the timings and the counts of frusta and proposals:
    /// a one-off trace hands its last-order frusta only triangles that show
    /// its listeners, a kept one every triangle, for listeners to come.
    fn assert_same(cached: &[Response], fresh: &[Response]) {
        assert_eq!(cached.len(), fresh.len());
        for (c, f) in cached.iter().zip(fresh) {
            assert_eq!((c.source, c.listener), (f.source, f.listener));
            assert_eq!(c.paths, f.paths);
            assert_eq!(c.parameters, f.parameters);
            assert_eq!(c.impulse_response, f.impulse_response);
            assert_eq!(c.stats.paths, f.stats.paths);
        }
    }

    /// Runs both and checks they agree; returns whether the beams of every
    /// source were reused.
    fn step(
        scene: &AcousticScene,
        sources: &[Vec3],
        listeners: &[Vec3],
        options: &SimulationOptions,
        cache: &mut BeamCache,
    ) -> bool {
        let cached =
            simulate_cached(scene, sources, listeners, options, cache, None, None).unwrap();
        assert_same(
            &cached,
            &simulate(scene, sources, listeners, options).unwrap(),
        );
        cached.iter().all(|r| r.stats.beams_reused)
    }

    #[test]
    fn a_trace_over_the_beam_cap_keeps_nothing_and_still_answers_exactly() {
        let scene = AcousticScene::new(&shoebox(2, 0.2));
        let source = [Vec3::new(2.0, 3.5, 1.2)];
        let options = options(3);
        let mut capped = BeamCache::with_max_beams(10);
        for x in [6.0, 6.5, 7.0] {
            let listener = [Vec3::new(x, 2.0, 1.5)];
            assert!(!step(&scene, &source, &listener, &options, &mut capped));
        }
        // Past the cap unwidened (these options keep frusta for the very
        // position only), calls trace as one-off traces do, their last
        // order pruned to the listener.
        let listener = [Vec3::new(7.5, 2.0, 1.5)];
        let cached = simulate_cached(
            &scene,
            &source,
            &listener,
            &options,
            &mut capped,
            None,
            None,
        )
        .unwrap();
        let fresh = simulate(&scene, &source, &listener, &options).unwrap();
        assert_eq!(cached[0].stats.frusta, fresh[0].stats.frusta);
        let mut roomy = BeamCache::default();
        step(
            &scene,
            &source,
            &[Vec3::new(6.0, 2.0, 1.5)],
            &options,
            &mut roomy,
        );
        assert!(step(
            &scene,
            &source,
            &[Vec3::new(6.5, 2.0, 1.5)],
            &options,
            &mut roomy
        ));
    }

    #[test]
    fn a_moving_listener_reuses_the_beams_and_hears_what_simulate_gives() {
        let rooms = [
            (
                AcousticScene::new(&shoebox(2, 0.2)),
                Vec3::new(2.0, 3.5, 1.2),
                Vec3::new(7.3, 1.9, 1.7),
                Vec3::new(0.5, 0.6, 0.05),
            ),
            (
                AcousticScene::new(&bundled("l-room")),
                Vec3::new(10.5, 2.0, 1.5),
                Vec3::new(9.0, 4.0, 1.7),
                Vec3::new(-1.0, 0.6, 0.0),
            ),
        ];
        for (scene, source, start, stride) in rooms {
            let mut cache = BeamCache::default();
            let options = options(3);
            for i in 0..6 {
                let listener = start + stride * i as f32;
                // Two listeners, one of them fixed, in the later steps.
                let listeners = if i < 3 {
                    vec![listener]
                } else {
                    vec![listener, start]
                };
                let reused = step(&scene, &[source], &listeners, &options, &mut cache);
                assert_eq!(reused, i > 0, "step {i}");
            }
        }
    }

    /// Conservative cells at order 4, N = 8, exact paths only, frusta kept
    /// for a source moving within `reach`.
    fn moving_source_options(reach: f64) -> SimulationOptions {
        SimulationOptions {
            max_order: 4,
            sampling: Some(8),
            cells: CellAssignment::Conservative,
            sample_rate: 8_000,
            tail: Tail::None,
            diffraction_order: 0,
            source_reuse_m: reach,
            ..Default::default()
        }
    }

    /// A floor of 128 triangles, each corner lifted off the plane by up to
    /// a micrometre (within the grouping's tolerance: one plane group),
    /// under a source and a listener 3 cm above it and 8 m apart. Paths
    /// graze the floor, where the line to the listener's image in the
    /// group's plane passes a triangle's own plane up to 0.3 mm from where
    /// it meets the group's. A one-off trace, whose last order is handed
    /// only the triangles that line passes through, finds every path that
    /// a kept trace (every triangle) finds.
    #[test]
    fn one_off_traces_find_the_grazing_paths_over_a_floor_off_its_plane() {
        let mut room =
            frusta_engine::scene::generate::BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0));
        room.subdivisions = 8;
        let mut mesh = room.generate().unwrap();
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            if p.z == 0.0 {
                p.z = 1e-6 * (((i * 7919) % 21) as f32 - 10.0) / 10.0;
            }
        }
        let scene = frusta_engine::scene::Scene::single_object(
            "room",
            mesh,
            frusta_engine::scene::Material::uniform("walls", 0.2).unwrap(),
        )
        .unwrap();
        let scene = AcousticScene::new(&scene);
        let (source, listener) = ([Vec3::new(1.0, 3.0, 0.03)], [Vec3::new(9.0, 3.2, 0.03)]);
        let options = SimulationOptions {
            cells: CellAssignment::Conservative,
            ..options(3)
        };
        let fresh = simulate(&scene, &source, &listener, &options).unwrap();
        let kept = simulate_cached(
            &scene,
            &source,
            &listener,
            &options,
            &mut BeamCache::default(),
            None,
            None,
        )
        .unwrap();
        assert_same(&kept, &fresh);
        let on_floor = fresh[0]
            .paths
            .iter()
            .filter(|p| p.surfaces.iter().any(|s| s.point[2].abs() < 1e-3))
            .count();
        assert!(on_floor >= 10, "{on_floor} paths meet the floor");
    }

    #[test]
    fn a_trace_too_large_to_keep_is_not_widened_again() {
        // Widened for a moving source, a trace costs more frusta than an
        // unwidened one; one that is not kept serves no moving source, so
        // the next ones are traced unwidened, also once one fits (kept for
        // its own position only).
        let scene = AcousticScene::new(&bundled("l-room"));
        let listener = [Vec3::new(11.0, 5.0, 1.2)];
        let options = moving_source_options(0.5);
        let (here, there) = (Vec3::new(1.0, 9.0, 1.5), Vec3::new(2.5, 9.0, 1.5));
        let near_there = there + Vec3::new(0.1, 0.0, 0.0);
        let frusta = |s: Vec3, options: &SimulationOptions, cache: &mut BeamCache| {
            simulate_cached(&scene, &[s], &listener, options, cache, None, None).unwrap()[0]
                .stats
                .frusta
        };
        // Kept for this very position: unwidened.
        let unwidened = |s: Vec3| {
            let options = SimulationOptions {
                source_reuse_m: 0.0,
                ..options.clone()
            };
            frusta(s, &options, &mut BeamCache::default())
        };
        // Room for an unwidened trace's frusta (primaries included), not
        // for a widened one's.
        let mut cache = BeamCache::with_max_beams(unwidened(there) as usize);
        let mut cached = |s: Vec3| frusta(s, &options, &mut cache);
        assert!(cached(here) > unwidened(there));
        assert_eq!(cached(there), unwidened(there));
        assert_eq!(cached(near_there), unwidened(near_there));
    }

    #[test]
    fn a_moving_source_reuses_its_beams_within_reach_and_finds_no_false_path() {
        let scene = AcousticScene::new(&bundled("l-room"));
        let listener = [Vec3::new(11.0, 5.0, 1.2)];
        let options = moving_source_options(0.25);
        let same = |a: &SoundPath, b: &SoundPath| {
            a.order == b.order && (a.distance_m - b.distance_m).abs() < 1e-9
        };
        let mut cache = BeamCache::default();
        let (mut found, mut total) = (0, 0);
        for i in 0..9 {
            let step = 0.04 * i as f32;
            let source = [Vec3::new(1.0 + step, 9.0, 1.5)];
            let moving =
                simulate_cached(&scene, &source, &listener, &options, &mut cache, None, None)
                    .unwrap()
                    .remove(0);
            // Traced at 1.0 m, reused to 0.24 m from there, traced again
            // at 0.28 m and reused from there.
            let traced_at = if i < 7 { 0.0 } else { 0.28 };
            assert_eq!(moving.stats.beams_reused, i != 0 && i != 7, "step {i}");
            assert!(
                (moving.stats.beams_offset_m - f64::from(step - traced_at)).abs() < 1e-5,
                "step {i}: {}",
                moving.stats.beams_offset_m
            );
            // Against a fresh trace with conservative cells, which finds
            // every path (checked against the reference above).
            let fresh = simulate(&scene, &source, &listener, &options)
                .unwrap()
                .remove(0);
            for p in &moving.paths {
                assert!(fresh.paths.iter().any(|f| same(p, f)), "step {i}: {p:?}");
            }
            found += fresh
                .paths
                .iter()
                .filter(|f| moving.paths.iter().any(|p| same(p, f)))
                .count();
            total += fresh.paths.len();
        }
        println!("moving source: {found} of {total} paths");
        // Paths that open only after a move wait for the next trace, so
        // not every path is promised; on this walk the kept frusta find
        // all 604. Their windows are cut to their triangles widened by
        // how far the triangles may shift within the reach
        // (`TraceInput::apex_reach`); cut without the widening, they found
        // 600 (99.3%).
        assert!(found as f64 >= 0.995 * total as f64, "{found} of {total}");
        // Asked again from where it last reused the beams, the source has
        // stopped: it is traced there, then answered from that trace.
        let here = [Vec3::new(1.0 + 0.04 * 8.0, 9.0, 1.5)];
        let again = |cache: &mut BeamCache| {
            simulate_cached(&scene, &here, &listener, &options, cache, None, None).unwrap()
        };
        assert!(!again(&mut cache)[0].stats.beams_reused);
        let r = again(&mut cache);
        assert!(r[0].stats.beams_reused && r[0].stats.beams_offset_m == 0.0);
        // Without a reach every move is traced.
        let exact = SimulationOptions {
            source_reuse_m: 0.0,
            ..options
        };
        let source = [Vec3::new(1.3, 9.0, 1.5)];
        let r =
            simulate_cached(&scene, &source, &listener, &exact, &mut cache, None, None).unwrap();
        assert!(!r[0].stats.beams_reused);
    }

    /// A short tail of few rays, sources kept within 0.25 m.
    fn tailed(rays: u32, max_length_s: f64) -> SimulationOptions {
        SimulationOptions {
            tail: Tail::Stochastic(TailOptions {
                rays,
                max_length_s,
                ..Default::default()
            }),
            source_reuse_m: 0.25,
            ..options(2)
        }
    }

    #[test]
    fn a_moving_source_renews_its_tail_a_chunk_at_a_time_and_ends_on_the_fresh_one() {
        let scene = AcousticScene::new(&shoebox(1, 0.2));
        let listener = [Vec3::new(7.3, 1.9, 1.7)];
        let moving = tailed(256, 0.3);
        let mut cache = BeamCache::default();
        let mut tail_at = |x: f32| {
            let source = [Vec3::new(x, 3.5, 1.2)];
            let r = simulate_cached(&scene, &source, &listener, &moving, &mut cache, None, None)
                .unwrap()
                .remove(0);
            (r.stats.tail.clone().unwrap(), r)
        };
        assert!(!tail_at(2.0).0.walk_reused);
        // Three moves of 5 cm: each walks one chunk again from the new
        // position, the others are from at most 15 cm away.
        for k in 1..=3 {
            let x = 2.0 + 0.05 * k as f32;
            let (t, _) = tail_at(x);
            assert!(t.walk_reused, "move {k}");
            assert!(
                (t.walk_offset_m - f64::from(x - 2.0)).abs() < 1e-6,
                "move {k}: {}",
                t.walk_offset_m
            );
        }
        // Standing still, the seven chunks walked elsewhere are renewed,
        // one a call; then the tail is the one a fresh walk from there
        // gives.
        let still = [Vec3::new(2.15, 3.5, 1.2)];
        let fresh = simulate(&scene, &still, &listener, &moving)
            .unwrap()
            .remove(0);
        for call in 0..8 {
            let (t, r) = tail_at(2.15);
            assert!(t.walk_reused);
            if call < 6 {
                assert!(t.walk_offset_m > 0.0, "call {call}");
                assert_ne!(r.impulse_response, fresh.impulse_response);
            } else {
                assert_eq!(t.walk_offset_m, 0.0, "call {call}");
                assert_eq!(r.impulse_response, fresh.impulse_response);
                assert_eq!(r.parameters, fresh.parameters);
            }
        }
        // Moving on steadily, no ray started more than the reach away.
        for k in 1..=12 {
            let x = 2.15 + 0.05 * k as f32;
            let (t, _) = tail_at(x);
            assert!(
                t.walk_reused && t.walk_offset_m <= 0.25,
                "{x}: {}",
                t.walk_offset_m
            );
        }
        // A jump past the reach walks afresh.
        assert!(!tail_at(4.0).0.walk_reused);
    }

    #[test]
    fn sources_near_each_other_end_with_beams_and_walks_of_their_own() {
        let scene = AcousticScene::new(&shoebox(1, 0.2));
        let sources = [Vec3::new(2.0, 3.5, 1.2), Vec3::new(2.1, 3.5, 1.2)];
        let listener = [Vec3::new(7.3, 1.9, 1.7)];
        let options = tailed(128, 0.2);
        let mut cache = BeamCache::default();
        let mut call = || {
            simulate_cached(
                &scene, &sources, &listener, &options, &mut cache, None, None,
            )
            .unwrap()
        };
        call();
        call();
        let fresh = simulate(&scene, &sources, &listener, &options).unwrap();
        let r = call();
        for (r, f) in r.iter().zip(&fresh) {
            assert!(r.stats.beams_reused && r.stats.beams_offset_m == 0.0);
            let t = r.stats.tail.as_ref().unwrap();
            assert!(t.walk_reused && t.walk_offset_m == 0.0);
            assert_eq!(r.impulse_response, f.impulse_response);
        }
    }

    #[test]
    fn a_new_source_new_options_or_a_moved_object_retrace() {
        let mut scene = AcousticScene::new(&shoebox(1, 0.2));
        let (source, listener) = (Vec3::new(2.0, 3.5, 1.2), Vec3::new(7.3, 1.9, 1.7));
        let mut cache = BeamCache::default();
        let base = options(3);
        assert!(!step(&scene, &[source], &[listener], &base, &mut cache));
        assert!(step(&scene, &[source], &[listener], &base, &mut cache));
        // The source moved by one ulp.
        let nudged = Vec3::new(f32::from_bits(2.0f32.to_bits() + 1), 3.5, 1.2);
        assert!(!step(&scene, &[nudged], &[listener], &base, &mut cache));
        // Only the latest call's sources are kept.
        assert!(!step(&scene, &[source], &[listener], &base, &mut cache));
        for changed in [
            SimulationOptions {
                max_order: 2,
                ..base.clone()
            },
            SimulationOptions {
                cells: CellAssignment::Sampled,
                ..base.clone()
            },
        ] {
            assert!(!step(&scene, &[source], &[listener], &changed, &mut cache));
            assert!(step(&scene, &[source], &[listener], &changed, &mut cache));
        }
        // Options that only shape the response keep the beams.
        let louder = SimulationOptions {
            air: None,
            ..base.clone()
        };
        assert!(!step(&scene, &[source], &[listener], &base, &mut cache));
        assert!(step(&scene, &[source], &[listener], &louder, &mut cache));
        let revision = scene.revision();
        scene
            .set_transform(
                0,
                RigidTransform::from_translation(Vec3::new(0.5, 0.0, 0.0)),
            )
            .unwrap();
        assert_ne!(scene.revision(), revision);
        assert!(!step(&scene, &[source], &[listener], &base, &mut cache));
        assert!(step(&scene, &[source], &[listener], &base, &mut cache));
        let mut damped = scene.materials().to_vec();
        damped[0].absorption = [0.9; 8];
        scene.set_materials(damped).unwrap();
        assert!(!step(&scene, &[source], &[listener], &base, &mut cache));
        // The table may grow but not shrink: triangles refer to it.
        assert!(scene.set_materials(Vec::new()).is_err());
        // A second source (the first is kept), then only it: its beams are
        // kept.
        let other = Vec3::new(8.0, 2.0, 2.0);
        assert!(!step(
            &scene,
            &[source, other],
            &[listener],
            &base,
            &mut cache
        ));
        assert!(step(&scene, &[other], &[listener], &base, &mut cache));
    }

    #[test]
    fn a_cancelled_simulation_stops_at_once() {
        let hall = AcousticScene::new(&bundled("hall-10k"));
        // Conservative order 4 in the hall traces millions of frusta.
        let options = options(4);
        let (source, listener) = (Vec3::new(3.0, 12.0, 2.5), Vec3::new(22.0, 9.0, 1.7));
        let cancel = frusta_engine::acoustics::Cancel::new();
        let later = cancel.clone();
        let stopper = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            later.cancel();
        });
        let mut cache = BeamCache::default();
        let start = Instant::now();
        let e = simulate_cached(
            &hall,
            &[source],
            &[listener],
            &options,
            &mut cache,
            None,
            Some(&cancel),
        )
        .unwrap_err();
        stopper.join().unwrap();
        assert!(matches!(e, Error::Cancelled), "{e}");
        // Seconds of work would remain; it stopped within a few frusta.
        assert!(
            start.elapsed() < Duration::from_secs(3),
            "{:?}",
            start.elapsed()
        );
    }

    #[test]
    fn a_deadline_stops_with_an_error_and_a_generous_one_changes_nothing() {
        let hall = AcousticScene::new(&bundled("hall-10k"));
        let sampled = SimulationOptions {
            cells: CellAssignment::Sampled,
            ..options(4)
        };
        let (source, listener) = (Vec3::new(3.0, 12.0, 2.5), Vec3::new(22.0, 9.0, 1.7));
        let mut cache = BeamCache::default();
        let soon = Instant::now() + Duration::from_millis(1);
        let e = simulate_cached(
            &hall,
            &[source],
            &[listener],
            &sampled,
            &mut cache,
            Some(soon),
            None,
        )
        .unwrap_err();
        assert!(
            matches!(e, Error::DeadlineExceeded { limit_ms: 0 | 1 }),
            "{e}"
        );
        // Nothing half-traced was kept.
        let room = AcousticScene::new(&shoebox(2, 0.2));
        let (source, listener) = (Vec3::new(2.0, 3.5, 1.2), Vec3::new(7.3, 1.9, 1.7));
        let late = Instant::now() + Duration::from_secs(3600);
        let options = options(3);
        let cached = simulate_cached(
            &room,
            &[source],
            &[listener],
            &options,
            &mut cache,
            Some(late),
            None,
        )
        .unwrap();
        assert!(!cached[0].stats.beams_reused);
        assert_same(
            &cached,
            &simulate(&room, &[source], &[listener], &options).unwrap(),
        );
        // The same without a cache.
        let hurried = Instant::now() + Duration::from_millis(1);
        let e = simulate_until(&hall, &[source], &[listener], &sampled, hurried, None).unwrap_err();
        assert!(matches!(e, Error::DeadlineExceeded { .. }), "{e}");
        assert_same(
            &simulate_until(&room, &[source], &[listener], &options, late, None).unwrap(),
            &cached,
        );
    }
}
