//! The hybrid impulse response (exact paths, then the stochastic tail)
//! against answers that share no code with it: the closed-form image
//! sources of a shoebox, summed here in f64 to convergence, with their own
//! Schroeder integration and line fits; and Eyring's formula for rooms
//! whose walls scatter everything.

use std::time::{Duration, Instant};

use frusta_engine::acoustics::signal::Channels;
use frusta_engine::acoustics::{
    simulate, simulate_until, AcousticScene, Cancel, Response, SimulationOptions, Tail, TailOptions,
};
use frusta_engine::scene::generate::BoxRoom;
use frusta_engine::scene::{Material, Scene, BAND_COUNT};
use frusta_engine::Error;
use glam::Vec3;

const ROOM: [f64; 3] = [10.0, 6.0, 3.0];
const SOURCE: [f64; 3] = [2.0, 3.0, 1.5];
const LISTENER: [f64; 3] = [7.0, 2.0, 1.2];
/// The 1 kHz band.
const BAND: usize = 4;

fn shoebox(absorption: f32, scattering: f32) -> AcousticScene {
    let room = BoxRoom::new(Vec3::ZERO, Vec3::from_array(ROOM.map(|v| v as f32)));
    let mut walls = Material::uniform("walls", absorption).unwrap();
    walls.scattering = [scattering; BAND_COUNT];
    AcousticScene::new(&Scene::single_object("room", room.generate().unwrap(), walls).unwrap())
}

/// One band at 1 kHz, no air: what the tests below compare.
fn options(max_order: u32, tail: Tail) -> SimulationOptions {
    SimulationOptions {
        max_order,
        bands_hz: vec![1000.0],
        air: None,
        tail,
        ..Default::default()
    }
}

fn point(p: [f64; 3]) -> Vec3 {
    Vec3::from_array(p.map(|v| v as f32))
}

fn respond(scene: &AcousticScene, max_order: u32, tail: Tail) -> Response {
    let options = options(max_order, tail);
    simulate(scene, &[point(SOURCE)], &[point(LISTENER)], &options)
        .unwrap()
        .remove(0)
}

/// (time s, energy) of every shoebox image source arriving before
/// `until_s`, with `(1 − α)` per reflection: image index `m` on an axis
/// of length `L` lies at `m L + (x if m is even else L − x)` after `|m|`
/// reflections.
fn image_sources(absorption: f64, speed: f64, until_s: f64) -> Vec<(f64, f64, u32)> {
    image_sources_by_axis([absorption; 3], speed, until_s)
}

/// [`image_sources`] with absorption `absorption[axis]` on the two walls
/// across each axis (floor and ceiling across z).
fn image_sources_by_axis(absorption: [f64; 3], speed: f64, until_s: f64) -> Vec<(f64, f64, u32)> {
    let reach = until_s * speed;
    let mut out = Vec::new();
    let axis = |m: i64, axis: usize| {
        let l = ROOM[axis];
        let x = SOURCE[axis];
        m as f64 * l + if m % 2 == 0 { x } else { l - x }
    };
    let limit = |a: usize| (reach / ROOM[a]).ceil() as i64 + 1;
    for mx in -limit(0)..=limit(0) {
        let dx = axis(mx, 0) - LISTENER[0];
        if dx.abs() > reach {
            continue;
        }
        for my in -limit(1)..=limit(1) {
            let dy = axis(my, 1) - LISTENER[1];
            if dx * dx + dy * dy > reach * reach {
                continue;
            }
            for mz in -limit(2)..=limit(2) {
                let dz = axis(mz, 2) - LISTENER[2];
                let d2 = dx * dx + dy * dy + dz * dz;
                if d2 > reach * reach {
                    continue;
                }
                let order = (mx.abs() + my.abs() + mz.abs()) as u32;
                let energy = [mx, my, mz]
                    .iter()
                    .zip(absorption)
                    .map(|(m, a)| (1.0 - a).powi(m.abs() as i32))
                    .product::<f64>()
                    / d2;
                out.push((d2.sqrt() / speed, energy, order));
            }
        }
    }
    out
}

/// EDT and T20 of an echogram by Schroeder backward integration on a
/// 0.1 ms grid from the first arrival and least-squares lines over 0 to
/// −10 dB and −5 to −25 dB.
fn decay_times(echogram: &[(f64, f64)]) -> (f64, f64) {
    let step = 1e-4;
    let start = echogram.iter().map(|e| e.0).fold(f64::INFINITY, f64::min);
    let end = echogram.iter().map(|e| e.0).fold(0.0, f64::max);
    let n = ((end - start) / step) as usize + 2;
    let mut bins = vec![0.0; n];
    for &(t, e) in echogram {
        bins[((t - start) / step) as usize] += e;
    }
    let mut remaining = vec![0.0; n + 1];
    for i in (0..n).rev() {
        remaining[i] = remaining[i + 1] + bins[i];
    }
    let level: Vec<f64> = remaining[..n]
        .iter()
        .map(|&r| 10.0 * (r / remaining[0]).log10())
        .collect();
    let fit = |top: f64, bottom: f64| {
        let points: Vec<(f64, f64)> = level
            .iter()
            .enumerate()
            .skip_while(|(_, &l)| l > top)
            .take_while(|(_, &l)| l >= bottom)
            .map(|(i, &l)| (i as f64 * step, l))
            .collect();
        let k = points.len() as f64;
        let (sx, sy) = points
            .iter()
            .fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
        let (mx, my) = (sx / k, sy / k);
        let (num, den) = points.iter().fold((0.0, 0.0), |(a, b), p| {
            (a + (p.0 - mx) * (p.1 - my), b + (p.0 - mx).powi(2))
        });
        -60.0 / (num / den)
    };
    (fit(0.0, -10.0), fit(-5.0, -25.0))
}

/// The response's echogram at 1 kHz: its paths, then its tail.
fn echogram(r: &Response) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = r
        .paths
        .iter()
        .map(|p| (p.delay_s, f64::from(p.pressure_gain[0]).powi(2)))
        .collect();
    if let Some(tail) = &r.late_energy {
        out.extend(tail.echogram(BAND));
    }
    out
}

fn within(what: &str, got: f64, want: f64, tolerance: f64) {
    let error = (got - want).abs() / want;
    eprintln!("{what}: {got:.4} against {want:.4}");
    assert!(
        error <= tolerance,
        "{what}: {got:.3} against {want:.3} ({:.1} % off, at most {:.0} % allowed)",
        error * 100.0,
        tolerance * 100.0
    );
}

#[test]
fn specular_shoebox_decay_matches_converged_image_sources() {
    let scene = shoebox(0.1, 0.0);
    let response = respond(&scene, 4, Tail::default());
    let speed = response.speed_of_sound_m_s;
    let length = TailOptions::default().max_length_s;
    // Converged: another half second of images moves neither value by 0.5 %.
    let reference = |until: f64| {
        let images: Vec<(f64, f64)> = image_sources(0.1, speed, until)
            .into_iter()
            .map(|(t, e, _)| (t, e))
            .collect();
        decay_times(&images)
    };
    let (edt, t20) = reference(length);
    let (edt_short, t20_short) = reference(length - 0.5);
    within("reference EDT convergence", edt_short, edt, 0.005);
    within("reference T20 convergence", t20_short, t20, 0.005);
    let (got_edt, got_t20) = decay_times(&echogram(&response));
    within("EDT", got_edt, edt, 0.05);
    within("T20", got_t20, t20, 0.05);
    // The parameters the response reports say the same.
    let reported = &response.parameters[0].parameters;
    within("reported EDT", reported.edt_s.unwrap(), edt, 0.05);
    within("reported T20", reported.t20_s.unwrap(), t20, 0.05);
}

/// A room whose floor and ceiling absorb most and whose walls little:
/// its late decay rides on the few near-horizontal rays between the walls
/// (flutter), the hardest case for a handful of seeds. Every seed must
/// land within 5 % (one just-noticeable difference) of the image sources,
/// not only their mean (both cut at the tail's 2 s). With the starting
/// lattice turned at random, which leaves a varying few rays near the
/// horizontal, and the sphere held within the listener's clearance, seed
/// 0 missed T20 by 5.2 %; now the worst is 3.3 %.
#[test]
fn every_seed_of_a_fluttering_shoebox_matches_its_image_sources() {
    let (walls, floor_and_ceiling) = (0.05, 0.6);
    let mut scene = Scene::single_object(
        "room",
        BoxRoom::new(Vec3::ZERO, Vec3::from_array(ROOM.map(|v| v as f32)))
            .generate()
            .unwrap(),
        Material::uniform("walls", walls as f32).unwrap(),
    )
    .unwrap();
    scene
        .materials
        .push(Material::uniform("floor and ceiling", floor_and_ceiling as f32).unwrap());
    let object = &mut scene.objects[0];
    for t in 0..object.mesh.triangle_count() {
        if object.mesh.face_normal(t).z.abs() > 0.5 {
            object.materials[t] = 1;
        }
    }
    let scene = AcousticScene::new(&scene);
    let length = 2.0;
    let mut reference = None;
    for seed in 0..4 {
        let tail = Tail::Stochastic(TailOptions {
            seed,
            max_length_s: length,
            ..TailOptions::default()
        });
        let response = respond(&scene, 3, tail);
        let (edt, t20) = *reference.get_or_insert_with(|| {
            let speed = response.speed_of_sound_m_s;
            let absorption = [walls, walls, floor_and_ceiling];
            let images: Vec<(f64, f64)> = image_sources_by_axis(absorption, speed, length)
                .into_iter()
                .map(|(t, e, _)| (t, e))
                .collect();
            decay_times(&images)
        });
        let (got_edt, got_t20) = decay_times(&echogram(&response));
        within(&format!("seed {seed} EDT"), got_edt, edt, 0.05);
        within(&format!("seed {seed} T20"), got_t20, t20, 0.05);
    }
}

#[test]
fn diffuse_shoebox_decay_matches_eyring() {
    let absorption: f64 = 0.1;
    let scene = shoebox(absorption as f32, 1.0);
    let response = respond(&scene, 4, Tail::default());
    let [x, y, z] = ROOM;
    let (volume, area) = (x * y * z, 2.0 * (x * y + y * z + z * x));
    let eyring = 24.0 * 10f64.ln() * volume
        / (response.speed_of_sound_m_s * -area * (1.0 - absorption).ln());
    let (_, t20) = decay_times(&echogram(&response));
    within("T20 against Eyring", t20, eyring, 0.05);
    // Every wall scatters everything: no specular reflection is left.
    assert!(response
        .paths
        .iter()
        .all(|p| p.order == 0 || p.pressure_gain[0] == 0.0));
}

#[test]
fn the_tail_holds_nothing_the_exact_paths_hold() {
    let (absorption, scattering): (f64, f64) = (0.2, 0.3);
    let max_order = 2;
    let specular = shoebox(absorption as f32, 0.0);
    let response = respond(&specular, max_order, Tail::default());
    let speed = response.speed_of_sound_m_s;
    // Before the first image beyond the exact order can reach the
    // listener's sphere, a specular room's tail is silent.
    let images = image_sources(absorption, speed, 0.2);
    let first_late = images
        .iter()
        .filter(|i| i.2 > max_order)
        .map(|i| i.0)
        .fold(f64::INFINITY, f64::min);
    let tail = response.late_energy.as_ref().expect("a tail");
    let radius = response.stats.tail.as_ref().unwrap().receiver_radius_m;
    let silent_until = first_late - radius / speed;
    let early: f64 = tail
        .echogram(BAND)
        .filter(|(t, _)| t + 0.5e-3 < silent_until)
        .map(|e| e.1)
        .sum();
    assert_eq!(early, 0.0, "tail energy before {silent_until} s");
    // The exact part carries each reflection's specular share: with
    // scattering s, (1 − α)(1 − s) per reflection, image for image.
    let scattering_room = shoebox(absorption as f32, scattering as f32);
    let response = respond(&scattering_room, max_order, Tail::default());
    let mut want: Vec<f64> = images
        .iter()
        .filter(|i| i.2 <= max_order)
        .map(|i| i.1 * (1.0 - scattering).powi(i.2 as i32))
        .collect();
    let mut got: Vec<f64> = response
        .paths
        .iter()
        .map(|p| f64::from(p.pressure_gain[0]).powi(2))
        .collect();
    want.sort_by(f64::total_cmp);
    got.sort_by(f64::total_cmp);
    assert_eq!(got.len(), want.len(), "paths up to order {max_order}");
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() <= 1e-5 * w, "path energy {g} against {w}");
    }
    // With no tail the paths keep all the reflected energy, as before.
    let exact = respond(&scattering_room, max_order, Tail::None);
    assert!(exact.late_energy.is_none() && exact.stats.tail.is_none());
    let total = |r: &Response| -> f64 {
        r.paths
            .iter()
            .map(|p| f64::from(p.pressure_gain[0]).powi(2))
            .sum()
    };
    let reflected: f64 = images
        .iter()
        .filter(|i| i.2 <= max_order)
        .map(|i| i.1)
        .sum();
    assert!((total(&exact) - reflected).abs() <= 1e-5 * reflected);
}

#[test]
fn hybrid_energy_matches_image_sources_in_total() {
    let absorption = 0.3;
    let scene = shoebox(absorption as f32, 0.0);
    let response = respond(&scene, 3, Tail::default());
    let want: f64 = image_sources(absorption, response.speed_of_sound_m_s, 3.0)
        .iter()
        .map(|i| i.1)
        .sum();
    let got: f64 = echogram(&response).iter().map(|e| e.1).sum();
    within("total energy", got, want, 0.03);
}

#[test]
fn a_seed_gives_the_same_tail_on_any_thread_count() {
    let scene = shoebox(0.2, 0.5);
    let tail = Tail::Stochastic(TailOptions {
        rays: 2000,
        ..Default::default()
    });
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| respond(&scene, 2, tail.clone()))
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.late_energy, two.late_energy);
    assert_eq!(one.impulse_response, two.impulse_response);
    let other = respond(
        &scene,
        2,
        Tail::Stochastic(TailOptions {
            rays: 2000,
            seed: 1,
            ..Default::default()
        }),
    );
    assert_ne!(one.late_energy, other.late_energy);
}

/// Energy conservation, exact for any room shape: with no absorption the
/// source's energy (4π in the unit of the direct sound at 1 m) ends up
/// spread evenly through the volume, so a listener receives
/// `4π c Δt / V` in any interval Δt once the field is mixed.
#[test]
fn lossless_diffuse_room_holds_its_energy() {
    let scene = shoebox(0.0, 1.0);
    let tail = Tail::Stochastic(TailOptions {
        max_length_s: 1.0,
        ..Default::default()
    });
    let r = respond(&scene, 2, tail);
    let volume: f64 = ROOM.iter().product();
    let (t1, t2) = (0.3, 0.95);
    let got: f64 = r
        .late_energy
        .as_ref()
        .unwrap()
        .echogram(BAND)
        .filter(|e| e.0 >= t1 && e.0 < t2)
        .map(|e| e.1)
        .sum();
    let want = 4.0 * std::f64::consts::PI * r.speed_of_sound_m_s * (t2 - t1) / volume;
    within("lossless energy", got, want, 0.03);
}

#[test]
fn binaural_tails_are_decorrelated_and_as_loud_as_mono() {
    let scene = shoebox(0.2, 0.5);
    let run = |channels| {
        let options = SimulationOptions {
            max_order: 2,
            air: None,
            channels,
            ..Default::default()
        };
        simulate(&scene, &[point(SOURCE)], &[point(LISTENER)], &options)
            .unwrap()
            .remove(0)
            .impulse_response
    };
    let mono = run(Channels::Mono);
    let binaural = run(Channels::Binaural);
    // After 0.2 s only the tail sounds.
    let late =
        |signal: &[f32]| -> Vec<f64> { signal[9600..].iter().map(|&v| f64::from(v)).collect() };
    let energy = |s: &[f64]| s.iter().map(|v| v * v).sum::<f64>();
    let (left, right) = (late(&binaural.channels[0]), late(&binaural.channels[1]));
    let m = energy(&late(&mono.channels[0]));
    // Each ear draws its own random signs, whose cross terms within a
    // band filter's ringing make the energies agree statistically only.
    within("left ear's late energy", energy(&left), m, 0.12);
    within("right ear's late energy", energy(&right), m, 0.12);
    let n = left.len().min(right.len());
    let cross: f64 = left[..n].iter().zip(&right[..n]).map(|(a, b)| a * b).sum();
    let correlation = cross / (energy(&left[..n]) * energy(&right[..n])).sqrt();
    assert!(
        correlation.abs() < 0.1,
        "interaural correlation {correlation}"
    );
}

#[test]
fn the_tail_stops_at_the_deadline_and_when_cancelled() {
    let scene = shoebox(0.05, 0.2);
    let options = SimulationOptions {
        max_order: 0,
        bands_hz: vec![1000.0],
        tail: Tail::Stochastic(TailOptions {
            rays: frusta_engine::acoustics::tail::MAX_RAYS,
            max_length_s: 10.0,
            ..Default::default()
        }),
        ..Default::default()
    };
    let (s, l) = (point(SOURCE), point(LISTENER));
    // The whole tail takes tens of seconds; the deadline cuts it short.
    let start = Instant::now();
    let deadline = start + Duration::from_millis(200);
    let e = simulate_until(&scene, &[s], &[l], &options, deadline, None).unwrap_err();
    assert!(matches!(e, Error::DeadlineExceeded { .. }), "{e}");
    assert!(
        start.elapsed() < Duration::from_secs(3),
        "{:?}",
        start.elapsed()
    );
    let cancel = Cancel::new();
    cancel.cancel();
    let far = Instant::now() + Duration::from_secs(600);
    let e = simulate_until(&scene, &[s], &[l], &options, far, Some(&cancel)).unwrap_err();
    assert!(matches!(e, Error::Cancelled), "{e}");
}

/// Diffuse rain is sent only where a shadow ray finds the listener
/// visible: two closed boxes side by side, the source in one and the
/// listener in the other, hear nothing of each other.
#[test]
fn walls_block_the_rain() {
    let mut mesh = BoxRoom::new(Vec3::ZERO, Vec3::new(5.0, 6.0, 3.0))
        .generate()
        .unwrap();
    mesh.append(
        BoxRoom::new(Vec3::new(5.2, 0.0, 0.0), Vec3::new(10.2, 6.0, 3.0))
            .generate()
            .unwrap(),
    );
    let mut walls = Material::uniform("walls", 0.2).unwrap();
    walls.scattering = [0.5; BAND_COUNT];
    let scene = AcousticScene::new(&Scene::single_object("rooms", mesh, walls).unwrap());
    let options = SimulationOptions {
        max_order: 1,
        bands_hz: vec![1000.0],
        air: None,
        ..Default::default()
    };
    let r = simulate(
        &scene,
        &[Vec3::new(2.0, 3.0, 1.5)],
        &[Vec3::new(7.5, 3.0, 1.5)],
        &options,
    )
    .unwrap()
    .remove(0);
    let tail = r.late_energy.expect("a tail");
    assert!(r.stats.tail.unwrap().shadow_rays > 0);
    assert_eq!(tail.energy(BAND), 0.0);
    assert!(r.paths.is_empty());
}

/// An open scene, a fully scattering floor: the tail is the first diffuse
/// reflection alone (scattered rays leave upwards), whose energy at the
/// listener is the double integral of Lambert's law over the floor,
/// `∫ (1 − α) (cos θ_s / r_s²) (cos θ_l / (π r_l²)) dA`, summed here on a
/// fine grid.
#[test]
fn open_floor_rain_matches_lamberts_integral() {
    let half = 100.0f32;
    let mesh = frusta_engine::scene::RawMesh {
        positions: vec![
            Vec3::new(-half, -half, 0.0),
            Vec3::new(half, -half, 0.0),
            Vec3::new(half, half, 0.0),
            Vec3::new(-half, half, 0.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        ..Default::default()
    };
    let absorption = 0.3;
    let mut floor = Material::uniform("floor", absorption as f32).unwrap();
    floor.scattering = [1.0; BAND_COUNT];
    let scene = AcousticScene::new(&Scene::single_object("floor", mesh, floor).unwrap());
    let (source, listener) = (
        glam::DVec3::new(0.0, 0.0, 1.5),
        glam::DVec3::new(4.0, 1.0, 1.2),
    );
    let options = SimulationOptions {
        max_order: 1,
        bands_hz: vec![1000.0],
        air: None,
        // The floor's far edges diffract, 100 m away; the rain is what
        // is checked.
        diffraction_order: 0,
        ..Default::default()
    };
    let r = simulate(&scene, &[source.as_vec3()], &[listener.as_vec3()], &options)
        .unwrap()
        .remove(0);
    let got = r.late_energy.unwrap().energy(BAND);
    let step = 0.05;
    let n = (2.0 * f64::from(half) / step) as i64;
    let mut want = 0.0;
    for i in 0..n {
        for j in 0..n {
            let p = glam::DVec3::new(
                -f64::from(half) + (i as f64 + 0.5) * step,
                -f64::from(half) + (j as f64 + 0.5) * step,
                0.0,
            );
            let (to_s, to_l) = (source - p, listener - p);
            let irradiance = to_s.z / to_s.length().powi(3);
            let lambert = to_l.z / (std::f64::consts::PI * to_l.length().powi(3));
            want += (1.0 - absorption) * irradiance * lambert * step * step;
        }
    }
    within("first diffuse reflection", got, want, 0.05);
    // The exact part holds the direct sound only: the floor reflects
    // nothing specularly.
    assert!(r
        .paths
        .iter()
        .all(|p| p.order == 0 || p.pressure_gain[0] == 0.0));
}

/// A stream's cache keeps the rays' walk of a source and hands it to
/// listeners that move: each moved listener's tail equals, to the bit,
/// one traced from scratch for it, and only the first call walks. Walks
/// are kept up to the cache's cap over all sources; the others are
/// traced each time, with the same answers.
#[test]
fn a_kept_walk_gives_moving_listeners_the_tail_a_fresh_trace_does() {
    use frusta_engine::acoustics::{simulate_cached, BeamCache};
    let room = BoxRoom::new(Vec3::ZERO, Vec3::from_array(ROOM.map(|v| v as f32)));
    let mut walls = Material::uniform("walls", 0.2).unwrap();
    walls.scattering = [0.4; BAND_COUNT];
    let scene =
        AcousticScene::new(&Scene::single_object("room", room.generate().unwrap(), walls).unwrap());
    let options = SimulationOptions {
        max_order: 2,
        bands_hz: vec![500.0, 1000.0],
        air: None,
        tail: Tail::Stochastic(TailOptions {
            rays: 2048,
            max_length_s: 1.0,
            ..Default::default()
        }),
        ..Default::default()
    };
    let sources = [
        Vec3::from_array(SOURCE.map(|v| v as f32)),
        Vec3::new(8.0, 4.0, 2.0),
    ];
    // Each response with whether its walk was reused, after checking it
    // against a fresh trace.
    let run = |cache: &mut BeamCache, sources: &[Vec3], listener: Vec3| -> Vec<bool> {
        let kept =
            simulate_cached(&scene, sources, &[listener], &options, cache, None, None).unwrap();
        let fresh = simulate(&scene, sources, &[listener], &options).unwrap();
        kept.iter()
            .zip(&fresh)
            .map(|(k, f)| {
                let (kt, ft) = (
                    k.stats.tail.as_ref().unwrap(),
                    f.stats.tail.as_ref().unwrap(),
                );
                assert_eq!(kt.reflections, ft.reflections);
                assert_eq!(
                    k.late_energy.as_ref().unwrap().bins,
                    f.late_energy.as_ref().unwrap().bins
                );
                assert_eq!(k.impulse_response, f.impulse_response);
                kt.walk_reused
            })
            .collect()
    };
    let mut cache = BeamCache::default();
    for (step, x) in [7.0f32, 7.3, 7.6].into_iter().enumerate() {
        let reused = run(&mut cache, &sources[..1], Vec3::new(x, 2.0, 1.2));
        assert_eq!(reused, [step > 0], "step {step}");
    }
    // Room for one walk only: the first source's is kept, the second's
    // traced every time.
    let one = cache_events(&sources[..1], &scene, &options);
    let mut small = BeamCache::default().with_max_tail_events(one);
    for (step, x) in [7.0f32, 7.3].into_iter().enumerate() {
        let reused = run(&mut small, &sources, Vec3::new(x, 2.0, 1.2));
        assert_eq!(reused, [step > 0, false], "step {step}");
    }
    // No room at all: nothing is kept.
    let mut none = BeamCache::default().with_max_tail_events(1000);
    for x in [7.0f32, 7.3] {
        assert_eq!(
            run(&mut none, &sources[..1], Vec3::new(x, 2.0, 1.2)),
            [false]
        );
    }
}

/// About the smallest cap that keeps the first source's walk (doubled
/// until a second call reuses it, then halved in on, to 1/64).
fn cache_events(sources: &[Vec3], scene: &AcousticScene, options: &SimulationOptions) -> usize {
    use frusta_engine::acoustics::{simulate_cached, BeamCache};
    let listener = Vec3::new(7.0, 2.0, 1.2);
    let holds = |cap: usize| {
        let mut cache = BeamCache::default().with_max_tail_events(cap);
        (0..2).any(|_| {
            let r = simulate_cached(scene, sources, &[listener], options, &mut cache, None, None)
                .unwrap();
            r[0].stats.tail.as_ref().unwrap().walk_reused
        })
    };
    let mut high = 1024;
    while !holds(high) {
        high *= 2;
    }
    let mut low = high / 2;
    for _ in 0..6 {
        let mid = (low + high) / 2;
        if holds(mid) {
            high = mid;
        } else {
            low = mid;
        }
    }
    high
}

/// In a room with no scattering the late energy rides on image sources,
/// each caught by a listener's sphere by chance. Spheres that grow with
/// the path's length like the rays' tubes catch each about once, so even
/// a few rays give the late energy of the exact image sources, seed after
/// seed (within 3 % on these seeds; a fixed sphere sized for a few
/// crossings per bin was 12 % off on two of them).
#[test]
fn few_rays_give_a_specular_rooms_late_energy() {
    let absorption = 0.1;
    let scene = shoebox(absorption as f32, 0.0);
    let window = 0.15..0.45;
    let late = |echogram: &[(f64, f64)]| -> f64 {
        echogram
            .iter()
            .filter(|e| window.contains(&e.0))
            .map(|e| e.1)
            .sum()
    };
    for seed in 0..4 {
        let options = TailOptions {
            rays: 2048,
            max_length_s: window.end + 0.05,
            seed,
            ..Default::default()
        };
        let response = respond(&scene, 4, Tail::Stochastic(options));
        let images: Vec<(f64, f64)> =
            image_sources(absorption, response.speed_of_sound_m_s, window.end)
                .into_iter()
                .map(|(t, e, _)| (t, e))
                .collect();
        within(
            &format!("seed {seed}: late energy"),
            late(&echogram(&response)),
            late(&images),
            0.05,
        );
    }
}

/// A listener's tail is its own: the same to the bit whether it is asked
/// for alone or beside another listener, in either order (the rain's
/// roulette draws by the event, not by the listener's place in the call).
#[test]
fn a_listeners_tail_does_not_depend_on_the_others_asked_with_it() {
    let scene = shoebox(0.2, 0.6);
    let options = options(
        2,
        Tail::Stochastic(TailOptions {
            rays: 2048,
            max_length_s: 1.0,
            ..Default::default()
        }),
    );
    let (source, a, b) = (point(SOURCE), point(LISTENER), Vec3::new(3.0, 4.5, 1.0));
    let alone = simulate(&scene, &[source], &[a], &options).unwrap();
    let second = simulate(&scene, &[source], &[b, a], &options).unwrap();
    assert!(second[0].stats.tail.as_ref().unwrap().shadow_rays > 0);
    assert!(alone[0].late_energy.as_ref().unwrap().energy(BAND) > 0.0);
    assert_eq!(alone[0].late_energy, second[1].late_energy);
}
