//! Impulse responses with levels of detail: the hall simplified at each
//! bound ([`AcousticScene::simplified`]: every highest node of error below the bound
//! one polygon), traced with its tail beside the same on exact geometry:
//! time, frusta, and the error in energy per band and in ISO 3382
//! parameters.
//!
//! The reference is exact geometry with the same cells where it finishes
//! within the time limit, else exact geometry with sampled cells
//! (conservative cells at order 4 in a detailed hall run for minutes:
//! that explosion is what levels of detail are for).

use std::time::{Duration, Instant};

use frusta_engine::acoustics::{
    simulate_until, AcousticScene, CellAssignment, Response, SimulationOptions, Tail,
};
use frusta_engine::scene::{Scene, OCTAVE_BANDS_HZ};
use glam::DVec3;

use super::{ms_since, peak_rss_mb, Run};
use crate::jnd::{self, jnd};
use crate::stats::median;

/// What the impulse-response rows run.
pub struct IrSetup {
    pub order: u32,
    pub sampling: u32,
    /// A run past this is stopped and reported as not finished.
    pub limit: Duration,
    pub rounds: usize,
}

/// One geometry (exact, or simplified at a bound) ready to trace.
struct Geometry {
    bound: f32,
    scene: AcousticScene,
    triangles: usize,
    polygons: usize,
    setup_ms: f64,
}

/// The rows of one hall: per cell assignment, exact geometry and every
/// bound, in interleaved rounds.
pub fn runs(
    name: &str,
    scene: &Scene,
    (source, listener): (DVec3, DVec3),
    bounds: &[f32],
    setup: &IrSetup,
) -> Result<Vec<Run>, String> {
    let start = Instant::now();
    let mut geometries = vec![Geometry {
        bound: 0.0,
        scene: AcousticScene::new(scene),
        triangles: scene.triangle_count(),
        polygons: 0,
        setup_ms: ms_since(start),
    }];
    for &bound in bounds {
        let start = Instant::now();
        let simplified = geometries[0].scene.simplified_from(scene, bound);
        let Some(simple) = simplified.map_err(|e| e.to_string())? else {
            eprintln!("{name} at {bound} m: nothing replaced, skipped");
            continue;
        };
        let triangles = simple.bvh().triangle_count();
        let polygons = simple.lod().map_or(0, |l| l.polygons);
        geometries.push(Geometry {
            bound,
            scene: simple,
            triangles,
            polygons,
            setup_ms: ms_since(start),
        });
        eprintln!("{name} at {bound} m: {triangles} triangles, {polygons} polygons");
    }
    let points = ([source.as_vec3()], [listener.as_vec3()]);
    let mut rows = Vec::new();
    let mut sampled_reference: Option<Response> = None;
    let mut noise: Option<(f64, Option<f64>)> = None;
    let trace =
        |g: &Geometry, options: &SimulationOptions| -> Result<Option<(f64, Response)>, String> {
            let start = Instant::now();
            match simulate_until(
                &g.scene,
                &points.0,
                &points.1,
                options,
                start + setup.limit,
                None,
            ) {
                Ok(mut r) => Ok(Some((ms_since(start), r.remove(0)))),
                Err(frusta_engine::Error::DeadlineExceeded { .. }) => Ok(None),
                Err(e) => Err(e.to_string()),
            }
        };
    for cells in [CellAssignment::Sampled, CellAssignment::Conservative] {
        let options = SimulationOptions {
            max_order: setup.order,
            sampling: Some(setup.sampling),
            cells,
            ..SimulationOptions::default()
        };
        // Per geometry: its times and its first response; None where the
        // first run did not finish. A later run that does not finish ends
        // that geometry's rounds.
        let mut results: Vec<Option<(Vec<f64>, Response)>> = Vec::new();
        for g in &geometries {
            results.push(trace(g, &options)?.map(|(ms, r)| (vec![ms], r)));
        }
        let mut running: Vec<bool> = results.iter().map(Option::is_some).collect();
        let sets = geometries.len();
        for round in 1..setup.rounds.max(1) {
            for k in (0..sets).map(|k| (k + round) % sets) {
                if !running[k] {
                    continue;
                }
                match (trace(&geometries[k], &options)?, &mut results[k]) {
                    (Some((ms, _)), Some((times, _))) => times.push(ms),
                    _ => running[k] = false,
                }
            }
        }
        let exact = results[0]
            .as_ref()
            .map(|(t, r)| (median(t.clone()), r.clone()));
        if cells == CellAssignment::Sampled {
            sampled_reference = exact.as_ref().map(|(_, r)| r.clone());
            // The tail's own noise: exact geometry again with the next
            // seed, what differences below it cannot be told from.
            if let Some(reference) = &sampled_reference {
                let mut reseeded = options.clone();
                if let Tail::Stochastic(t) = &mut reseeded.tail {
                    t.seed += 1;
                }
                if let Some((_, r)) = trace(&geometries[0], &reseeded)? {
                    noise = Some((
                        energy_error_db(&r, reference),
                        parameter_error_jnd(&r, reference),
                    ));
                }
            }
        }
        let reference = match &exact {
            Some((_, r)) => Some((r.clone(), cells)),
            None => sampled_reference
                .clone()
                .map(|r| (r, CellAssignment::Sampled)),
        };
        for (g, result) in geometries.iter().zip(&results).skip(1) {
            let mut row = Run::new(name, "ir", g.bound);
            row.cells = Some(cells);
            row.reference_cells = reference.as_ref().map(|(_, c)| *c);
            row.exact_ms = exact.as_ref().map(|(ms, _)| *ms);
            row.triangles = g.triangles;
            row.polygons = Some(g.polygons);
            row.setup_ms = Some(g.setup_ms);
            row.exact_setup_ms = Some(geometries[0].setup_ms);
            row.tail_noise_db = noise.map(|(db, _)| db);
            row.tail_noise_jnd = noise.and_then(|(_, jnd)| jnd);
            if let Some((times, response)) = result {
                row.ms = Some(median(times.clone()));
                row.frusta = Some(response.stats.frusta);
                row.paths = Some(response.paths.len());
                row.trace_ms = Some(response.stats.trace_ms);
                row.tail_ms = response.stats.tail.as_ref().map(|t| t.trace_ms);
                if let Some((reference, _)) = &reference {
                    row.energy_error_db_max = Some(energy_error_db(response, reference));
                    row.parameter_error_jnd_max = parameter_error_jnd(response, reference);
                }
            }
            rows.push(row);
        }
        if let Some((_, r)) = &exact {
            eprintln!("{name} exact, {cells:?}: {} frusta", r.stats.frusta);
        }
    }
    // Every run of this hall has ended: its geometries are all built.
    let peak = peak_rss_mb();
    for row in &mut rows {
        row.peak_rss_mb = peak;
    }
    Ok(rows)
}

/// The energy of each requested band: the paths', then the tail's (whose
/// histogram holds every octave band).
fn band_energy(r: &Response) -> Vec<f64> {
    r.bands_hz
        .iter()
        .enumerate()
        .map(|(i, hz)| {
            let paths: f64 = r
                .paths
                .iter()
                .map(|p| f64::from(p.pressure_gain[i]).powi(2))
                .sum();
            let octave = OCTAVE_BANDS_HZ.iter().position(|c| c == hz);
            let late = r
                .late_energy
                .as_ref()
                .zip(octave)
                .map_or(0.0, |(l, b)| l.energy(b));
            paths + late
        })
        .collect()
}

/// The largest difference in any band's energy, dB.
fn energy_error_db(r: &Response, reference: &Response) -> f64 {
    let (a, b) = (band_energy(r), band_energy(reference));
    a.iter()
        .zip(&b)
        .map(|(a, b)| (10.0 * (a / b).log10()).abs())
        .fold(0.0, f64::max)
}

/// The largest difference in EDT, T30, C80 or D50 in any band, in
/// just-noticeable differences (infinite where one response has a
/// parameter the other lacks); `None` where none can be compared.
fn parameter_error_jnd(r: &Response, reference: &Response) -> Option<f64> {
    let mut worst: Option<f64> = None;
    for (p, q) in r.parameters.iter().zip(&reference.parameters) {
        let (p, q) = (&p.parameters, &q.parameters);
        let one_sided = [
            (p.edt_s, q.edt_s),
            (p.t30_s, q.t30_s),
            (p.c80_db, q.c80_db),
            (p.d50, q.d50),
        ]
        .iter()
        .any(|(a, b)| a.is_some() != b.is_some());
        for d in [
            jnd(p.edt_s, q.edt_s, true, jnd::DECAY),
            jnd(p.t30_s, q.t30_s, true, jnd::DECAY),
            jnd(p.c80_db, q.c80_db, false, jnd::CLARITY_DB),
            jnd(p.d50, q.d50, false, jnd::DEFINITION),
            one_sided.then_some(f64::INFINITY),
        ]
        .into_iter()
        .flatten()
        {
            worst = Some(worst.map_or(d.abs(), |w| w.max(d.abs())));
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use frusta_engine::acoustics::simulate;
    use frusta_engine::scene::generate::BoxRoom;
    use frusta_engine::scene::Material;
    use glam::Vec3;

    /// A response against itself differs by nothing; with every pressure
    /// doubled (paths and tail alike) every band is 20 log10 2 dB louder.
    #[test]
    fn errors_of_a_response_against_itself_and_twice_as_loud() {
        let room = BoxRoom::new(Vec3::ZERO, Vec3::new(6.0, 4.0, 3.0))
            .generate()
            .unwrap();
        let scene =
            Scene::single_object("box", room, Material::uniform("w", 0.2).unwrap()).unwrap();
        let options = SimulationOptions {
            max_order: 2,
            tail: Tail::Stochastic(frusta_engine::acoustics::TailOptions {
                rays: 512,
                ..Default::default()
            }),
            ..SimulationOptions::default()
        };
        let r = simulate(
            &AcousticScene::new(&scene),
            &[Vec3::new(1.0, 1.0, 1.5)],
            &[Vec3::new(4.5, 3.0, 1.2)],
            &options,
        )
        .unwrap()
        .remove(0);
        assert_eq!(energy_error_db(&r, &r), 0.0);
        assert_eq!(parameter_error_jnd(&r, &r), Some(0.0));
        let mut louder = r.clone();
        for p in &mut louder.paths {
            p.pressure_gain.iter_mut().for_each(|g| *g *= 2.0);
        }
        for bin in &mut louder.late_energy.as_mut().unwrap().bins {
            bin.iter_mut().for_each(|e| *e *= 4.0);
        }
        let db = energy_error_db(&louder, &r);
        assert!((db - 20.0 * 2f64.log10()).abs() < 1e-5, "{db}");
    }
}
