//! Edge diffraction against the exact solution for a rigid half-plane:
//! the Biot–Tolstoy–Medwin impulse response of an infinite wedge
//! (Svensson, Fred & Vanderkooy, JASA 106, 1999), which with the
//! geometric field is the whole answer, transformed to frequency here by
//! quadrature in f64. The engine uses the uniform theory of diffraction
//! (an asymptotic theory, other formulas entirely); nothing here is
//! shared with it.

use std::f64::consts::{PI, TAU};

use frusta_engine::acoustics::diffraction::{diffracted_paths, DiffractedPath, DiffractionSearch};
use frusta_engine::acoustics::{simulate, AcousticScene, Response, SimulationOptions, Tail};
use frusta_engine::scene::{Material, RawMesh, Scene, BAND_COUNT, OCTAVE_BANDS_HZ};
use glam::{DVec3, Vec3};
use num_complex::Complex64;

const SPEED: f64 = 343.0;
/// Half the plate's side: its other edges are this far from the one
/// under test, so their paths arrive far later and are told apart.
const PLATE: f32 = 200.0;

/// A thin plate in the plane y = 0, below z = 0: its top edge, the x
/// axis, is the half-plane's edge.
fn plate() -> AcousticScene {
    let mesh = RawMesh {
        positions: vec![
            Vec3::new(-PLATE, 0.0, 0.0),
            Vec3::new(PLATE, 0.0, 0.0),
            Vec3::new(PLATE, 0.0, -PLATE),
            Vec3::new(-PLATE, 0.0, -PLATE),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        names: vec![],
        triangle_names: vec![None; 2],
    };
    let rigid = Material::uniform("rigid", 0.0).unwrap();
    AcousticScene::new(&Scene::single_object("plate", mesh, rigid).unwrap())
}

/// A point at distance `r` from the edge, angle `theta` from the plate
/// (turning from -z towards -y), `x` along the edge.
fn around(r: f64, theta: f64, x: f64) -> DVec3 {
    DVec3::new(x, -r * theta.sin(), -r * theta.cos())
}

/// The BTM impulse response of the edge (the x axis) of a wedge of open
/// angle `wedge`, at `tau` s after emission, for a source whose direct
/// sound is `δ(t - R/c)/R`. The factor is `cν/2π`: both halves of the
/// edge, either side of the apex point, contribute one `cν/4π` each. The
/// continuity test below pins it: at the shadow boundary the step of
/// each half must be a quarter of the direct sound.
fn btm(wedge: f64, s: (f64, f64, f64), l: (f64, f64, f64), tau: f64) -> f64 {
    let nu = PI / wedge;
    let (rs, ts, zs) = s;
    let (rl, tl, zl) = l;
    let arg = ((SPEED * tau).powi(2) - (rs * rs + rl * rl + (zs - zl).powi(2))) / (2.0 * rs * rl);
    if arg <= 1.0 {
        return 0.0;
    }
    let eta = arg.acosh();
    let beta: f64 = [PI + ts + tl, PI + ts - tl, PI - ts + tl, PI - ts - tl]
        .iter()
        .map(|&phi| (nu * phi).sin() / ((nu * eta).cosh() - (nu * phi).cos()))
        .sum();
    -SPEED * nu / (2.0 * PI) * beta / (rs * rl * eta.sinh())
}

/// The BTM response's spectrum at each frequency: `∫ h(t) e^{-iωt} dt`
/// from its onset `t0` to `t0 + 0.2 s` (it decays as `t^-3`), with
/// `t = t0 + u²` to lift the onset's `1/√(t - t0)`, on panels that grow
/// geometrically from the onset and then stay 5 µs wide, four-point
/// Gauss–Legendre each.
fn btm_spectrum(
    wedge: f64,
    s: (f64, f64, f64),
    l: (f64, f64, f64),
    freqs: &[f64],
) -> Vec<Complex64> {
    let (rs, _, zs) = s;
    let (rl, _, zl) = l;
    let t0 = ((rs + rl).powi(2) + (zs - zl).powi(2)).sqrt() / SPEED;
    let mut edges: Vec<f64> = vec![0.0];
    let mut t = 1e-13;
    while t < 5e-6 {
        edges.push(t);
        t *= 1.5;
    }
    while t < 0.2 {
        edges.push(t);
        t += 5e-6;
    }
    let gl = [
        (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    ];
    let mut nodes = Vec::new();
    for w in edges.windows(2) {
        let (u0, u1) = (w[0].sqrt(), w[1].sqrt());
        let (mid, half) = (0.5 * (u0 + u1), 0.5 * (u1 - u0));
        for (x, wt) in gl {
            let u = mid + half * x;
            let dt = u * u;
            nodes.push((t0 + dt, btm(wedge, s, l, t0 + dt) * 2.0 * u * wt * half));
        }
    }
    freqs
        .iter()
        .map(|&f| {
            let w = TAU * f;
            nodes
                .iter()
                .map(|&(t, v)| Complex64::from_polar(v, -w * t))
                .sum()
        })
        .collect()
}

/// Frequencies spread evenly in log over octave band `b`.
fn band_freqs(b: usize) -> Vec<f64> {
    let fc = f64::from(OCTAVE_BANDS_HZ[b]);
    (0..16)
        .map(|j| fc * 2f64.powf((j as f64 + 0.5) / 16.0 - 0.5))
        .collect()
}

/// The exact diffracted band level, dB re 1 at 1 m: the mean of |H|²
/// over the band.
fn exact_levels(wedge: f64, s: (f64, f64, f64), l: (f64, f64, f64)) -> [f64; BAND_COUNT] {
    std::array::from_fn(|b| {
        let h = btm_spectrum(wedge, s, l, &band_freqs(b));
        10.0 * (h.iter().map(|v| v.norm_sqr()).sum::<f64>() / h.len() as f64).log10()
    })
}

/// The engine's path around the plate's top edge.
fn engine_path(scene: &AcousticScene, source: DVec3, listener: DVec3) -> Option<DiffractedPath> {
    let search = DiffractionSearch {
        order: 1,
        speed_of_sound: SPEED,
        active_bands: [true; BAND_COUNT],
    };
    diffracted_paths(scene.edge_scene(), source, listener, &search)
        .into_iter()
        .find(|p| p.points[0].point.z.abs() < 1e-6 && p.points[0].point.x.abs() < 50.0)
}

/// The exact reference is itself checked: crossing the shadow boundary,
/// the geometric wave vanishes, and the diffracted wave makes up for it,
/// so the total is continuous.
#[test]
fn the_reference_is_continuous_across_the_shadow_boundary() {
    let (s, theta_s) = ((2.0, 0.5, 0.0), 0.5);
    let boundary = theta_s + PI;
    let freqs = [250.0, 1000.0, 4000.0];
    let lit_l = (3.0, boundary - 1e-3, 0.0);
    let shadow_l = (3.0, boundary + 1e-3, 0.0);
    let lit = btm_spectrum(TAU, s, lit_l, &freqs);
    let shadow = btm_spectrum(TAU, s, shadow_l, &freqs);
    let source = around(2.0, theta_s, 0.0);
    let listener = around(3.0, boundary - 1e-3, 0.0);
    let r = source.distance(listener);
    for (i, &f) in freqs.iter().enumerate() {
        let direct = Complex64::from_polar(1.0 / r, -TAU * f * r / SPEED);
        let total_lit = (lit[i] + direct).norm();
        let total_shadow = shadow[i].norm();
        assert!(
            (total_lit / total_shadow - 1.0).abs() < 0.02,
            "{f} Hz: lit {total_lit}, shadow {total_shadow}, direct {}",
            direct.norm()
        );
        // The diffracted wave steps by the direct wave, phase included.
        let step = shadow[i] - lit[i];
        assert!(
            (step - direct).norm() < 0.02 * direct.norm(),
            "{f} Hz: step {step}, direct {direct}"
        );
    }
}

/// The engine's diffracted wave against the exact one, per octave band,
/// at listeners deep in the shadow, beside the boundary on both sides,
/// in the lit region, and off the perpendicular (a skewed path).
#[test]
fn half_plane_diffraction_matches_the_exact_solution_within_1_db_per_band() {
    let scene = plate();
    let cases = [
        // (source r, angle, x), (listener r, angle, x)
        ((2.0, 0.5, 0.0), (3.0, 5.5, 0.0)),
        ((2.0, 0.5, 0.0), (3.0, 3.9, 0.0)),
        ((2.0, 0.5, 0.0), (3.0, 3.4, 0.0)),
        ((2.0, 0.5, 0.0), (3.0, 2.0, 0.0)),
        ((4.0, 1.0, -1.5), (2.5, 4.8, 2.0)),
        ((1.5, 0.2, 0.0), (6.0, 6.1, 3.0)),
        ((2.0, 0.5, -1.0), (3.0, 3.75, 2.5)),
        ((2.0, 0.5, -1.0), (3.0, 3.5, 2.0)),
    ];
    let mut worst = (0.0, String::new());
    for (s, l) in cases {
        let source = around(s.0, s.1, s.2);
        let listener = around(l.0, l.1, l.2);
        let exact = exact_levels(TAU, s, l);
        let path = engine_path(&scene, source, listener)
            .unwrap_or_else(|| panic!("no path for {s:?} {l:?}"));
        for b in 0..BAND_COUNT {
            let level = 20.0 * f64::from(path.gain[b].abs()).log10();
            let off = (level - exact[b]).abs();
            if off >= worst.0 {
                let hz = OCTAVE_BANDS_HZ[b];
                let case = format!(
                    "{s:?} {l:?} {hz} Hz: UTD {level:.2} dB, exact {:.2}",
                    exact[b]
                );
                worst = (off, case);
            }
        }
    }
    eprintln!("worst: {:.3} dB at {}", worst.0, worst.1);
    assert!(worst.0 <= 1.0, "{:.2} dB off at {}", worst.0, worst.1);
}

fn exact_only(diffraction_order: u32) -> SimulationOptions {
    SimulationOptions {
        max_order: 0,
        tail: Tail::None,
        air: None,
        sample_rate: 16_000,
        diffraction_order,
        ..Default::default()
    }
}

fn ir_energy(r: &Response) -> f64 {
    r.impulse_response.channels[0]
        .iter()
        .map(|&v| f64::from(v).powi(2))
        .sum()
}

/// A listener walking out of the plate's shadow hears the sum of the
/// direct and diffracted waves change smoothly: the diffracted wave's
/// sign flips at the boundary as the direct wave appears. With the
/// diffracted wave's sign ignored, the impulse response's energy would
/// jump by a factor of 9 (1.5² against 0.5²).
#[test]
fn the_impulse_response_is_continuous_across_the_shadow_boundary() {
    let scene = plate();
    let source = around(2.0, 0.5, 0.0);
    let boundary = 0.5 + PI;
    let energy = |angle: f64| {
        let listener = around(3.0, angle, 0.0);
        let r = simulate(
            &scene,
            &[source.as_vec3()],
            &[listener.as_vec3()],
            &exact_only(1),
        )
        .unwrap()
        .remove(0);
        (ir_energy(&r), r.paths.len())
    };
    let (lit, lit_paths) = energy(boundary - 1e-3);
    let (shadow, shadow_paths) = energy(boundary + 1e-3);
    assert!(
        lit_paths >= 2 && shadow_paths >= 1,
        "{lit_paths} {shadow_paths}"
    );
    assert!(
        (lit / shadow - 1.0).abs() < 0.1,
        "lit {lit}, shadow {shadow}"
    );
    // Deeper in, the shadow is far quieter than the lit side.
    let (deep, _) = energy(boundary + 1.0);
    assert!(deep < 0.1 * shadow, "{deep} {shadow}");
}

/// The bundled two-rooms scene: a source in one room, a listener in the
/// other out of sight through the door in the 0.2 m wall. Without
/// diffraction (and without reflections) it is silent; with it, sound
/// arrives around the door's jambs, longer than the straight line, lower
/// bands louder than higher ones, and quieter than in free field.
#[test]
fn an_occluded_source_is_heard_through_a_door_by_diffraction() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/two-rooms.json");
    let scene = AcousticScene::new(&Scene::load(&path).unwrap());
    let (source, listener) = (Vec3::new(2.5, 2.0, 1.5), Vec3::new(5.8, 0.5, 1.2));
    let respond = |order: u32| {
        simulate(&scene, &[source], &[listener], &exact_only(order))
            .unwrap()
            .remove(0)
    };
    let silent = respond(0);
    assert!(silent.paths.is_empty(), "{:?}", silent.paths);
    assert_eq!(ir_energy(&silent), 0.0);
    let direct = f64::from(source.distance(listener));
    for order in [1, 2] {
        let heard = respond(order);
        assert!(!heard.paths.is_empty(), "order {order}");
        for p in &heard.paths {
            assert!(p.surfaces.iter().all(|s| s.event == "diffraction"));
            assert!(p.distance_m > direct);
            let g: Vec<f32> = p.pressure_gain.iter().map(|g| g.abs()).collect();
            assert!(g[0] > g[7], "order {order}: {g:?}");
            assert!(f64::from(g[0]) < 1.0 / p.distance_m, "{g:?}");
        }
        assert!(ir_energy(&heard) > 0.0);
        if order == 2 {
            assert!(heard.paths.iter().any(|p| p.order == 2));
        }
    }
}
