//! `frusta-bench reverb`: frusta's hybrid impulse response (exact paths to
//! an order, then the stochastic tail) per scene and band, its ISO 3382
//! parameters beside the exact image-source answer (box rooms) and
//! Sabine's and Eyring's diffuse-field decay times, differences in
//! just-noticeable differences, and the time each part took.
//!
//! pyroomacoustics' hybrid runs beside it on box rooms (`reverb::pyroom`).
//! Box rooms run twice: with their materials (against Sabine and Eyring)
//! and with no scattering, the room the image sources answer exactly.
//! Air absorption is off everywhere, so the formulas and the image sources
//! answer the same question. Halls trace their exact part with sampled
//! cells (N = 8): conservative cells at order 3 take seconds to minutes
//! there (see the frustum-tracing issue).

mod plot;
mod pyroom;
mod theory;

use std::path::PathBuf;

use clap::Parser;
use frusta_engine::acoustics::signal::RoomParameters;
use frusta_engine::acoustics::{
    simulate, AcousticScene, CellAssignment, Response, SimulationOptions, Tail, TailOptions,
};
use frusta_engine::scene::{BAND_COUNT, OCTAVE_BANDS_HZ};
use serde::Serialize;

use crate::jnd::{self, jnd};
use crate::propagation::scenes;
use crate::provenance::{self, Provenance};
use crate::report::aligned;
use crate::stats::median;
use theory::BoxWalls;

#[derive(Parser)]
pub struct Args {
    /// Scenes to run (repeatable); default: shoebox, l-room, two-rooms,
    /// hall-10k, hall-200k.
    #[arg(long)]
    scene: Vec<String>,
    /// Exact (specular) order before the tail.
    #[arg(long, default_value_t = 3)]
    order: u32,
    /// Rays of the tail.
    #[arg(long, default_value_t = TailOptions::default().rays)]
    rays: u32,
    /// Length of the tail, s.
    #[arg(long, default_value_t = 2.0)]
    length: f64,
    /// Seed of the tail's rays.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Every scene also runs the tail with this many seeds (`seed`,
    /// `seed + 1`, ...; untimed) and reports each band's decay times'
    /// differences over them from the exact image sources (box rooms
    /// without scattering) or from their own mean (the others): the
    /// estimator's spread, which one seed cannot show.
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// Timed runs per scene; the median is reported.
    #[arg(long, default_value_t = 3)]
    rounds: usize,
    /// Skip the pyroomacoustics peer.
    #[arg(long)]
    no_peer: bool,
    #[arg(long)]
    json: bool,
    /// A PNG of the first box room without scattering: the impulse
    /// responses, and energy decay curves per band beside
    /// pyroomacoustics' and the exact image sources'.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Directory to write reverb.txt and reverb.json to.
    #[arg(long)]
    save: Option<PathBuf>,
}

#[derive(Serialize)]
struct Parameters {
    edt_s: Option<f64>,
    t20_s: Option<f64>,
    t30_s: Option<f64>,
    c80_db: Option<f64>,
    d50: Option<f64>,
}

impl From<&RoomParameters> for Parameters {
    fn from(p: &RoomParameters) -> Self {
        Self {
            edt_s: p.edt_s,
            t20_s: p.t20_s,
            t30_s: p.t30_s,
            c80_db: p.c80_db,
            d50: p.d50,
        }
    }
}

/// Differences in JNDs, frusta minus the reference.
#[derive(Serialize)]
struct Jnd {
    edt: Option<f64>,
    t20: Option<f64>,
    t30: Option<f64>,
    c80: Option<f64>,
    d50: Option<f64>,
}

#[derive(Serialize)]
struct Band {
    band_hz: f32,
    frusta: Parameters,
    /// The exact image-source answer (box rooms only).
    image_sources: Option<Parameters>,
    /// pyroomacoustics' hybrid (box rooms only).
    pyroomacoustics: Option<Parameters>,
    sabine_s: f64,
    eyring_s: f64,
    /// Against the image sources where there are some, else decay times
    /// against Eyring.
    jnd: Jnd,
}

#[derive(Serialize)]
struct Run {
    scene: String,
    triangles: usize,
    cells: &'static str,
    exact_order: u32,
    rays: u32,
    tail_s: f64,
    volume_m3: f64,
    paths: usize,
    trace_ms: f64,
    tail_ms: f64,
    diffraction_ms: f64,
    total_ms: f64,
    threads: usize,
    /// pyroomacoustics' `compute_rir` (image sources, ray tracing,
    /// synthesis): the median of its runs between frusta's rounds, and its
    /// threads.
    pyroomacoustics_ms: Option<f64>,
    pyroomacoustics_threads: Option<usize>,
    pyroomacoustics_version: Option<String>,
    bands: Vec<Band>,
    /// Over `--seeds` seeds: against the exact image sources where there
    /// are some, else against the seeds' own mean (the estimator's noise).
    seed_spread: Option<Vec<SeedSpread>>,
    #[serde(skip)]
    curves: plot::Curves,
}

/// Differences in JND over several seeds from the exact image sources, or
/// where there are none from the mean of the seeds: per parameter (EDT,
/// T20, T30) the mean, least, greatest and standard deviation.
#[derive(Serialize)]
struct SeedSpread {
    band_hz: f32,
    seeds: u64,
    against_exact: bool,
    edt: [f64; 4],
    t20: [f64; 4],
    t30: [f64; 4],
}

/// Mean, least, greatest and standard deviation of `values` (not empty).
fn spread(values: &[f64]) -> [f64; 4] {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    [mean, lo, hi, sd]
}

#[derive(Serialize)]
struct Saved<'a> {
    provenance: Provenance,
    rounds: usize,
    runs: &'a [Run],
}

/// Band `band` of a response's echogram: its paths, then its tail.
fn echogram(r: &Response, band: usize) -> Vec<(f64, f64)> {
    let Some(i) = r
        .bands_hz
        .iter()
        .position(|&hz| hz == OCTAVE_BANDS_HZ[band])
    else {
        return Vec::new();
    };
    let mut out: Vec<(f64, f64)> = r
        .paths
        .iter()
        .map(|p| (p.delay_s, f64::from(p.pressure_gain[i]).powi(2)))
        .collect();
    if let Some(tail) = &r.late_energy {
        out.extend(tail.echogram(band));
    }
    out
}

/// Runs `name` as it is, or with every material's scattering set to zero
/// (`specular`): the rooms the exact image sources answer.
fn run_scene(name: &'static str, specular: bool, args: &Args) -> Result<Run, String> {
    let mut bench = scenes::load(name, false)?;
    if specular {
        for m in &mut bench.scene.materials {
            m.scattering = [0.0; BAND_COUNT];
        }
    }
    let scene = AcousticScene::new(&bench.scene);
    let hall = name.starts_with("hall");
    let options = SimulationOptions {
        max_order: args.order,
        cells: if hall {
            CellAssignment::Sampled
        } else {
            CellAssignment::Conservative
        },
        air: None,
        sample_rate: 48_000,
        tail: Tail::Stochastic(TailOptions {
            rays: args.rays,
            max_length_s: args.length,
            seed: args.seed,
            ..Default::default()
        }),
        ..Default::default()
    };
    let (source, listener) = (bench.source.as_vec3(), bench.listener.as_vec3());
    let walls = BoxWalls::of(&bench.scene);
    let mut timings = Vec::new();
    let (mut peer, mut peer_ms, mut peer_failed) = (None, Vec::new(), args.no_peer);
    let mut last = None;
    for _ in 0..args.rounds.max(1) {
        let r = simulate(&scene, &[source], &[listener], &options)
            .map_err(|e| e.to_string())?
            .remove(0);
        let tail = r.stats.tail.as_ref().map_or(0.0, |t| t.trace_ms);
        timings.push((
            r.stats.trace_ms,
            tail,
            r.stats.diffraction_ms,
            r.stats.total_ms,
        ));
        // The peer runs between frusta's rounds, so both meet the same
        // machine, and its median is reported too.
        if let (Some(walls), false) = (&walls, peer_failed) {
            let job = pyroom::Job {
                walls,
                source: bench.source,
                listener: bench.listener,
                order: args.order,
                rays: args.rays,
                length_s: args.length,
                speed: r.speed_of_sound_m_s,
            };
            match pyroom::run(&job) {
                Ok(hybrid) => {
                    peer_ms.push(hybrid.ms);
                    peer = Some(hybrid);
                }
                Err(e) => {
                    eprintln!("warning: pyroomacoustics on {name}: {e}");
                    peer_failed = true;
                }
            }
        }
        last = Some(r);
    }
    let r = last.expect("one round at least");
    let speed = r.speed_of_sound_m_s;
    let volume = r.stats.tail.as_ref().map_or(0.0, |t| t.volume_m3);
    let (sabine, eyring) = theory::diffuse_field(&bench.scene, volume, speed);
    let exact = walls
        .as_ref()
        .filter(|_| specular)
        .map(|walls| walls.image_sources(bench.source, bench.listener, speed, args.length));
    let seed_spread = if args.seeds > 1 {
        Some(seed_spread(
            &scene,
            (source, listener),
            &options,
            exact.as_deref(),
            args,
        )?)
    } else {
        None
    };
    let peer = peer.map(|mut hybrid: pyroom::Hybrid| {
        hybrid.ms = median(peer_ms);
        hybrid
    });
    let bands = r
        .parameters
        .iter()
        .map(|b| {
            let band = OCTAVE_BANDS_HZ
                .iter()
                .position(|&hz| hz == b.band_hz)
                .unwrap_or(0);
            let p = &b.parameters;
            let reference = exact.as_ref().map(|e| &e[band].0);
            let decay = |f: Option<f64>, e: Option<f64>| match reference {
                Some(_) => jnd(f, e, true, jnd::DECAY),
                None => jnd(f, Some(eyring[band]), true, jnd::DECAY),
            };
            Band {
                band_hz: b.band_hz,
                frusta: p.into(),
                image_sources: reference.map(Parameters::from),
                pyroomacoustics: peer.as_ref().map(|p| (&p.parameters[band]).into()),
                sabine_s: sabine[band],
                eyring_s: eyring[band],
                jnd: Jnd {
                    edt: decay(p.edt_s, reference.and_then(|e| e.edt_s)),
                    t20: decay(p.t20_s, reference.and_then(|e| e.t20_s)),
                    t30: decay(p.t30_s, reference.and_then(|e| e.t30_s)),
                    c80: jnd(
                        p.c80_db,
                        reference.and_then(|e| e.c80_db),
                        false,
                        jnd::CLARITY_DB,
                    ),
                    d50: jnd(p.d50, reference.and_then(|e| e.d50), false, jnd::DEFINITION),
                },
            }
        })
        .collect();
    Ok(Run {
        scene: if specular {
            format!("{name} (no scattering)")
        } else {
            name.to_string()
        },
        triangles: bench.scene.triangle_count(),
        cells: if hall { "sampled" } else { "conservative" },
        exact_order: args.order,
        rays: args.rays,
        tail_s: args.length,
        volume_m3: volume,
        paths: r.paths.len(),
        trace_ms: median(timings.iter().map(|t| t.0).collect()),
        tail_ms: median(timings.iter().map(|t| t.1).collect()),
        diffraction_ms: median(timings.iter().map(|t| t.2).collect()),
        total_ms: median(timings.iter().map(|t| t.3).collect()),
        threads: r.stats.threads,
        pyroomacoustics_ms: peer.as_ref().map(|p| p.ms),
        pyroomacoustics_threads: peer.as_ref().map(|p| p.threads),
        pyroomacoustics_version: peer.as_ref().map(|p| p.version.clone()),
        bands,
        seed_spread,
        curves: plot::Curves {
            frusta_ir: r.impulse_response.channels[0].clone(),
            frusta: (0..BAND_COUNT).map(|b| echogram(&r, b)).collect(),
            peer_ir: peer.as_ref().map(|p| p.rir.clone()),
            peer: peer.map(|p| p.echograms),
            exact: exact.map(|e| e.into_iter().map(|(_, echogram)| echogram).collect()),
        },
    })
}

/// Per band, the exact image sources' parameters and echogram.
type ExactBands = [(RoomParameters, Vec<(f64, f64)>)];

/// The decay times' differences in JND over `args.seeds` seeds of the
/// tail, the other options as `options`, from `exact` (per band, as
/// `BoxWalls::image_sources` gives them) or without it from the mean of
/// the seeds.
fn seed_spread(
    scene: &AcousticScene,
    (source, listener): (glam::Vec3, glam::Vec3),
    options: &SimulationOptions,
    exact: Option<&ExactBands>,
    args: &Args,
) -> Result<Vec<SeedSpread>, String> {
    // Per band, per parameter (EDT, T20, T30), the value of each seed.
    let mut values = vec![[Vec::new(), Vec::new(), Vec::new()]; BAND_COUNT];
    for seed in args.seed..args.seed + args.seeds {
        let mut options = options.clone();
        if let Tail::Stochastic(tail) = &mut options.tail {
            tail.seed = seed;
        }
        let r = simulate(scene, &[source], &[listener], &options)
            .map_err(|e| e.to_string())?
            .remove(0);
        for b in &r.parameters {
            let Some(band) = OCTAVE_BANDS_HZ.iter().position(|&hz| hz == b.band_hz) else {
                continue;
            };
            let p = &b.parameters;
            for (k, v) in [p.edt_s, p.t20_s, p.t30_s].into_iter().enumerate() {
                values[band][k].extend(v);
            }
        }
    }
    let reference = |band: usize, k: usize, own: &[f64]| match exact {
        Some(exact) => {
            let e = &exact[band].0;
            [e.edt_s, e.t20_s, e.t30_s][k]
        }
        None => Some(own.iter().sum::<f64>() / own.len() as f64),
    };
    let diffs = |band: usize, k: usize, own: &[f64]| -> Vec<f64> {
        own.iter()
            .filter_map(|&v| jnd(Some(v), reference(band, k, own), true, jnd::DECAY))
            .collect()
    };
    Ok(values
        .iter()
        .enumerate()
        .filter(|(_, v)| v.iter().all(|v| !v.is_empty()))
        .filter_map(|(band, [edt, t20, t30])| {
            let [edt, t20, t30] = [(0, edt), (1, t20), (2, t30)].map(|(k, v)| diffs(band, k, v));
            (!edt.is_empty() && !t20.is_empty() && !t30.is_empty()).then(|| SeedSpread {
                band_hz: OCTAVE_BANDS_HZ[band],
                seeds: args.seeds,
                against_exact: exact.is_some(),
                edt: spread(&edt),
                t20: spread(&t20),
                t30: spread(&t30),
            })
        })
        .collect())
}

pub fn run(args: Args) -> Result<(), String> {
    let mut provenance = provenance::start(rayon::current_num_threads());
    let names: Vec<&'static str> = if args.scene.is_empty() {
        vec!["shoebox", "l-room", "two-rooms", "hall-10k", "hall-200k"]
    } else {
        args.scene
            .iter()
            .map(|s| {
                scenes::NAMES
                    .iter()
                    .copied()
                    .find(|n| n == s)
                    .ok_or_else(|| format!("unknown scene {s}; one of {:?}", scenes::NAMES))
            })
            .collect::<Result<_, _>>()?
    };
    let mut runs = Vec::new();
    for name in names {
        runs.push(run_scene(name, false, &args)?);
        if name == "shoebox" {
            runs.push(run_scene(name, true, &args)?);
        }
    }
    provenance.finish();
    if let Some(path) = &args.plot {
        let run = runs
            .iter()
            .find(|r| r.curves.exact.is_some())
            .ok_or("--plot needs a box room (e.g. --scene shoebox)")?;
        plot::decay(&run.scene, &run.curves, path)?;
    }
    let text = table(&runs, &provenance, &args);
    let saved = Saved {
        provenance,
        rounds: args.rounds,
        runs: &runs,
    };
    let printed = serde_json::json!({ "runs": &runs });
    provenance::emit(
        "reverb",
        &printed,
        &saved,
        &text,
        args.json,
        args.save.as_deref(),
    )
}

fn table(runs: &[Run], provenance: &Provenance, args: &Args) -> String {
    let mut out = provenance.header();
    out += &format!(
        "\nhybrid IR: exact order {} then a {} s tail of {} rays, 8 bands, 48 kHz mono, no air; \
         times are medians of {} runs; JND = (frusta - reference) in just-noticeable differences \
         (5 % decay times, 1 dB C80, 0.05 D50) against the exact image sources (boxes) or, \
         for decay times, Eyring\n",
        args.order, args.length, args.rays, args.rounds
    );
    let f = |v: Option<f64>, digits: usize| v.map_or("-".into(), |v| format!("{v:.digits$}"));
    for run in runs {
        out += &format!(
            "\n{}: {} triangles, {} cells, {:.0} m³, {} paths; exact part {:.1} ms, tail {:.1} ms, \
             diffraction {:.1} ms, total {:.1} ms ({} threads)\n",
            run.scene,
            run.triangles,
            run.cells,
            run.volume_m3,
            run.paths,
            run.trace_ms,
            run.tail_ms,
            run.diffraction_ms,
            run.total_ms,
            run.threads
        );
        if let (Some(ms), Some(threads), Some(version)) = (
            run.pyroomacoustics_ms,
            run.pyroomacoustics_threads,
            &run.pyroomacoustics_version,
        ) {
            out += &format!(
                "pyroomacoustics {version} hybrid (same order, rays and length; its ray-tracing \
                 defaults): {ms:.1} ms ({threads} thread; median of runs between frusta's)\n"
            );
        }
        let mut rows = vec![[
            "band Hz",
            "EDT s",
            "T20 s",
            "T30 s",
            "C80 dB",
            "D50",
            "exact EDT",
            "exact T20",
            "exact T30",
            "exact C80",
            "exact D50",
            "pra EDT",
            "pra T20",
            "pra T30",
            "pra C80",
            "pra D50",
            "Eyring s",
            "Sabine s",
            "JND EDT",
            "JND T20",
            "JND T30",
            "JND C80",
            "JND D50",
        ]
        .map(String::from)
        .to_vec()];
        for b in &run.bands {
            let e = b.image_sources.as_ref();
            let pra = b.pyroomacoustics.as_ref();
            rows.push(vec![
                format!("{}", b.band_hz),
                f(b.frusta.edt_s, 2),
                f(b.frusta.t20_s, 2),
                f(b.frusta.t30_s, 2),
                f(b.frusta.c80_db, 2),
                f(b.frusta.d50, 3),
                f(e.and_then(|e| e.edt_s), 2),
                f(e.and_then(|e| e.t20_s), 2),
                f(e.and_then(|e| e.t30_s), 2),
                f(e.and_then(|e| e.c80_db), 2),
                f(e.and_then(|e| e.d50), 3),
                f(pra.and_then(|e| e.edt_s), 2),
                f(pra.and_then(|e| e.t20_s), 2),
                f(pra.and_then(|e| e.t30_s), 2),
                f(pra.and_then(|e| e.c80_db), 2),
                f(pra.and_then(|e| e.d50), 3),
                format!("{:.2}", b.eyring_s),
                format!("{:.2}", b.sabine_s),
                f(b.jnd.edt, 1),
                f(b.jnd.t20, 1),
                f(b.jnd.t30, 1),
                f(b.jnd.c80, 1),
                f(b.jnd.d50, 1),
            ]);
        }
        out += &aligned(&rows, 0);
        if let Some(spread) = &run.seed_spread {
            let seeds = spread.first().map_or(0, |s| s.seeds);
            let against = if spread.first().is_some_and(|s| s.against_exact) {
                "exact"
            } else {
                "the seeds' mean"
            };
            out += &format!(
                "over {seeds} seeds ({}..{}, untimed): frusta - {against} in JND, mean [least, greatest] sd\n",
                args.seed,
                args.seed + seeds - 1
            );
            let mut rows = vec![["band Hz", "EDT", "T20", "T30"].map(String::from).to_vec()];
            let cell =
                |s: &[f64; 4]| format!("{:+.1} [{:+.1}, {:+.1}] {:.1}", s[0], s[1], s[2], s[3]);
            for s in spread {
                rows.push(vec![
                    format!("{}", s.band_hz),
                    cell(&s.edt),
                    cell(&s.t20),
                    cell(&s.t30),
                ]);
            }
            out += &aligned(&rows, 0);
        }
    }
    out
}
