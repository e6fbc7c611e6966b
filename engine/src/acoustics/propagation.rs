//! From a scene, a source and listeners to what each listener hears: the
//! validated specular paths with their per-band pressure gains, the
//! impulse response, and its ISO 3382-1 parameters.

use std::time::Instant;

use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};

use super::diffraction::{
    diffracted_paths_until, DiffractedPath, DiffractionSearch, MAX_DIFFRACTION_ORDER,
};
use super::path::ValidPath;
use super::signal::{
    self, AirConditions, Arrival, EnergyHistogram, ImpulseResponse, ImpulseResponseOptions,
    RoomParameters,
};
use super::tail::{trace_tail, Tail, TailInput, TailOptions, TailStats, TracedTail};
use super::{AcousticScene, BeamCache, CellAssignment, TraceOptions};
use crate::deadline::{Cancel, Deadline};
use crate::scene::{Bands, BAND_COUNT, OCTAVE_BANDS_HZ};
use crate::{Error, Result};

/// Closer than this, spherical spreading is held at its value here: a
/// point source has no meaning at zero distance, and a gain must stay finite.
pub const MIN_SPREADING_DISTANCE_M: f64 = 1e-3;

/// Highest order accepted: beyond it the count of frusta is astronomical
/// in any room.
pub const MAX_ORDER: u32 = 32;

/// Everything a simulation can be asked for; every field has a default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimulationOptions {
    pub max_order: u32,
    /// Sub-frusta per frustum side (`N`), 1..=64; `None` takes the cells'
    /// [`CellAssignment::default_sampling`] (2 conservative, 8 sampled).
    pub sampling: Option<u32>,
    /// Frusta per cube-face side leaving the source.
    pub primary_split: u32,
    /// Energy (relative to the source, per band) below which a frustum
    /// spawns no more frusta.
    pub energy_threshold: f32,
    /// How sub-frusta are handed to triangles: `conservative` (complete) or
    /// `sampled` (the dissertation's sample rays: bounded work).
    pub cells: CellAssignment,
    /// Octave band centres to compute, a subset of 63 Hz..8 kHz.
    pub bands_hz: Vec<f32>,
    /// Air absorption (ISO 9613-1); `None` turns it off.
    pub air: Option<AirConditions>,
    pub sample_rate: u32,
    pub channels: signal::Channels,
    pub listener_frame: signal::ListenerFrame,
    /// The late reverberation after the exact paths up to `max_order`:
    /// `"none"` for the exact paths alone.
    pub tail: Tail,
    /// Most edges a diffracted path bends around (UTD), 0 for none: 1
    /// hears sources around a corner or through a door in a thin wall;
    /// 2 also through a thick wall's doorway, at far more work in
    /// detailed scenes (every pair of edges the source and the listener
    /// see).
    pub diffraction_order: u32,
    /// How far a source may move from where its beams were traced before
    /// a stream traces them again, m: within it the kept beams are
    /// re-mirrored for the new position and every proposal validated
    /// exactly (no path is ever false), but a path that opens only after
    /// the move is missed until the next trace. The tail's walk is kept
    /// likewise, an eighth of its rays walked again from the new position
    /// per call. 0 traces and walks at every move. Only streams keep
    /// beams and walks; other calls always trace.
    pub source_reuse_m: f64,
}

/// The largest [`SimulationOptions::source_reuse_m`].
pub const MAX_SOURCE_REUSE_M: f64 = 10.0;

impl Default for SimulationOptions {
    /// The tracer's defaults, all bands, air at 20 °C and 50 % RH, 48 kHz mono.
    fn default() -> Self {
        let trace = TraceOptions::default();
        Self {
            max_order: trace.max_order,
            sampling: None,
            primary_split: trace.primary_split,
            energy_threshold: trace.energy_threshold,
            cells: trace.cells,
            bands_hz: OCTAVE_BANDS_HZ.to_vec(),
            air: Some(AirConditions::default()),
            sample_rate: 48_000,
            channels: signal::Channels::Mono,
            listener_frame: signal::ListenerFrame::default(),
            tail: Tail::default(),
            diffraction_order: 1,
            source_reuse_m: 0.25,
        }
    }
}

impl SimulationOptions {
    /// Band indices of [`Self::bands_hz`], checked.
    fn band_indices(&self) -> Result<Vec<usize>> {
        if self.bands_hz.is_empty() {
            return Err(Error::InvalidOption {
                field: "bands_hz".into(),
                reason: "is empty; name at least one octave band".into(),
            });
        }
        let mut out = Vec::with_capacity(self.bands_hz.len());
        for &hz in &self.bands_hz {
            let b = OCTAVE_BANDS_HZ
                .iter()
                .position(|&c| c == hz)
                .ok_or_else(|| Error::InvalidOption {
                    field: "bands_hz".into(),
                    reason: format!("{hz} Hz is not one of the octave bands {OCTAVE_BANDS_HZ:?}"),
                })?;
            if out.contains(&b) {
                return Err(Error::InvalidOption {
                    field: "bands_hz".into(),
                    reason: format!("lists {hz} Hz twice"),
                });
            }
            out.push(b);
        }
        Ok(out)
    }

    /// The tail's options, checked; `None` for no tail.
    pub fn tail_options(&self) -> Result<Option<TailOptions>> {
        self.tail
            .options()
            .map(|o| o.clone().validated())
            .transpose()
    }

    /// The sampling `N` asked for, or the cells' default.
    pub fn sampling(&self) -> u32 {
        self.sampling
            .unwrap_or_else(|| self.cells.default_sampling())
    }

    /// Checks every option; the error names the one at fault.
    pub fn trace_options(&self) -> Result<TraceOptions> {
        if self.max_order > MAX_ORDER {
            return Err(Error::InvalidOption {
                field: "max_order".into(),
                reason: format!("{} exceeds {MAX_ORDER}", self.max_order),
            });
        }
        let sampling = self.sampling();
        if !(1..=64).contains(&sampling) {
            return Err(Error::InvalidOption {
                field: "sampling".into(),
                reason: format!("{sampling} must lie in 1..=64"),
            });
        }
        if !(1..=16).contains(&self.primary_split) {
            return Err(Error::InvalidOption {
                field: "primary_split".into(),
                reason: format!("{} must lie in 1..=16", self.primary_split),
            });
        }
        if !(self.energy_threshold >= 0.0 && self.energy_threshold < 1.0) {
            return Err(Error::InvalidOption {
                field: "energy_threshold".into(),
                reason: format!("{} must lie in [0, 1)", self.energy_threshold),
            });
        }
        if let Some(air) = self.air {
            air.validated()?;
        }
        if self.diffraction_order > MAX_DIFFRACTION_ORDER {
            return Err(Error::InvalidOption {
                field: "diffraction_order".into(),
                reason: format!("{} exceeds {MAX_DIFFRACTION_ORDER}", self.diffraction_order),
            });
        }
        if !(0.0..=MAX_SOURCE_REUSE_M).contains(&self.source_reuse_m) {
            return Err(Error::InvalidOption {
                field: "source_reuse_m".into(),
                reason: format!(
                    "{} must lie in [0, {MAX_SOURCE_REUSE_M}] m",
                    self.source_reuse_m
                ),
            });
        }
        self.tail_options()?;
        let mut active_bands = [false; BAND_COUNT];
        for b in self.band_indices()? {
            active_bands[b] = true;
        }
        Ok(TraceOptions {
            max_order: self.max_order,
            sampling,
            primary_split: self.primary_split,
            energy_threshold: self.energy_threshold,
            active_bands,
            cells: self.cells,
        })
    }
}

/// One surface a path meets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SurfaceEvent {
    pub object: String,
    /// Triangle index in the object's mesh.
    pub triangle: u32,
    pub material: String,
    /// `"reflection"` or `"transmission"`.
    pub event: &'static str,
    pub point: [f64; 3],
}

/// One validated specular path.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SoundPath {
    pub order: usize,
    pub distance_m: f64,
    pub delay_s: f64,
    pub image_source: [f64; 3],
    pub surfaces: Vec<SurfaceEvent>,
    /// Linear pressure amplitude per requested band, relative to the source
    /// level at 1 m.
    pub pressure_gain: Vec<f32>,
}

/// ISO 3382-1 parameters of one band.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BandParameters {
    pub band_hz: f32,
    #[serde(flatten)]
    pub parameters: RoomParameters,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimulationStats {
    /// Frusta traced for this response's source (shared by its listeners),
    /// by this call or, when the beams were reused, by the call that traced
    /// them.
    pub frusta: u64,
    pub triangle_tests: u64,
    pub sample_rays: u64,
    pub proposals: u64,
    pub paths: usize,
    /// Whether the source's beams came from the cache instead of a trace.
    pub beams_reused: bool,
    /// How far from this source the reused beams were traced, m (0 when
    /// traced here; see [`SimulationOptions::source_reuse_m`]).
    pub beams_offset_m: f64,
    /// Time to find the paths: tracing (unless reused), proposing and
    /// validating.
    pub trace_ms: f64,
    /// Time to find the diffracted paths of every listener of the source
    /// (wall time, beside the tail's: the two overlap).
    pub diffraction_ms: f64,
    /// The late reverberation's rays and time (shared by the source's
    /// listeners), when there is a tail.
    pub tail: Option<TailStats>,
    pub total_ms: f64,
    pub threads: usize,
    /// The level-of-detail bound of the geometry this was computed on, m
    /// (0: exact; see [`AcousticScene::simplified`]).
    pub lod_error_m: f32,
}

/// What one listener hears from one source.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Response {
    pub source: usize,
    pub listener: usize,
    pub bands_hz: Vec<f32>,
    pub speed_of_sound_m_s: f64,
    pub paths: Vec<SoundPath>,
    pub parameters: Vec<BandParameters>,
    pub stats: SimulationStats,
    #[serde(skip)]
    pub impulse_response: ImpulseResponse,
    /// The tail's energy per band and 1 ms bin, when there is a tail: the
    /// late part of the response's echogram (the arrivals of `paths` are
    /// the early part).
    #[serde(skip)]
    pub late_energy: Option<EnergyHistogram>,
}

/// Simulates every source-listener pair: one frustum trace per source
/// serves all its listeners.
pub fn simulate(
    scene: &AcousticScene,
    sources: &[Vec3],
    listeners: &[Vec3],
    options: &SimulationOptions,
) -> Result<Vec<Response>> {
    simulate_with(scene, sources, listeners, options, None, Deadline::none())
}

/// [`simulate`] that stops with [`Error::DeadlineExceeded`] past
/// `deadline`, or with [`Error::Cancelled`] once `cancel` is cancelled,
/// returning nothing partial.
pub fn simulate_until(
    scene: &AcousticScene,
    sources: &[Vec3],
    listeners: &[Vec3],
    options: &SimulationOptions,
    deadline: Instant,
    cancel: Option<&Cancel>,
) -> Result<Vec<Response>> {
    let stop = Deadline::new(Some(deadline), Instant::now()).or_cancel(cancel);
    simulate_with(scene, sources, listeners, options, None, stop)
}

/// [`simulate`], reusing the beams `cache` holds for a source when the
/// source (to the bit), the trace options, the materials and the scene's
/// [`state`](AcousticScene::state) are unchanged: moving listeners
/// then cost no trace. The cache keeps the sources of this call only.
///
/// Past `deadline` the call stops with [`Error::DeadlineExceeded`], and
/// once `cancel` is cancelled with [`Error::Cancelled`]; either way it
/// returns nothing partial.
pub fn simulate_cached(
    scene: &AcousticScene,
    sources: &[Vec3],
    listeners: &[Vec3],
    options: &SimulationOptions,
    cache: &mut BeamCache,
    deadline: Option<Instant>,
    cancel: Option<&Cancel>,
) -> Result<Vec<Response>> {
    let start = Instant::now();
    let stop = Deadline::new(deadline, start).or_cancel(cancel);
    simulate_with(scene, sources, listeners, options, Some(cache), stop)
}

/// Without a cache, tracing tests the listeners as it goes and keeps no
/// frusta: memory stays flat however many frusta the trace visits.
fn simulate_with(
    scene: &AcousticScene,
    sources: &[Vec3],
    listeners: &[Vec3],
    options: &SimulationOptions,
    mut cache: Option<&mut BeamCache>,
    deadline: Deadline,
) -> Result<Vec<Response>> {
    let start = Instant::now();
    let trace_options = options.trace_options()?;
    let tail_options = options.tail_options()?;
    let bands = options.band_indices()?;
    let ir_options = ImpulseResponseOptions {
        sample_rate: options.sample_rate,
        channels: options.channels,
        bands: bands.clone(),
        listener: options.listener_frame,
    }
    .validated()?;
    let speed = options.air.unwrap_or_default().speed_of_sound();
    let listener_points: Vec<DVec3> = listeners
        .iter()
        .enumerate()
        .map(|(i, &p)| scene.check_point(&format!("listener {i}"), p))
        .collect::<Result<_>>()?;
    let source_points: Vec<DVec3> = sources
        .iter()
        .enumerate()
        .map(|(i, &p)| scene.check_point(&format!("source {i}"), p))
        .collect::<Result<_>>()?;
    if let Some(cache) = cache.as_deref_mut() {
        cache.retain(
            scene,
            &trace_options,
            &source_points,
            options.source_reuse_m,
        );
    }
    let mut out = Vec::with_capacity(sources.len() * listeners.len());
    for (s, &source) in source_points.iter().enumerate() {
        let trace_start = Instant::now();
        let (found, beams_offset) = match cache.as_deref_mut() {
            Some(cache) => cache.find_paths(
                scene,
                source,
                &listener_points,
                &trace_options,
                options.source_reuse_m,
                &deadline,
            )?,
            None => (
                scene.find_paths_until(source, &listener_points, &trace_options, &deadline)?,
                None,
            ),
        };
        let trace_ms = trace_start.elapsed().as_secs_f64() * 1e3;
        // The diffracted paths beside the tail: one listener's first-order
        // search is one thread's work, which the tail's rays leave room for.
        let search = DiffractionSearch {
            order: options.diffraction_order,
            speed_of_sound: speed,
            active_bands: trace_options.active_bands,
        };
        let (tail, diffraction) = rayon::join(
            || -> Result<Option<TracedTail>> {
                let Some(tail) = &tail_options else {
                    return Ok(None);
                };
                let input = TailInput {
                    options: tail,
                    exact_order: trace_options.max_order,
                    active_bands: trace_options.active_bands,
                    speed_of_sound: speed,
                    air: options.air.as_ref(),
                };
                Ok(Some(match cache.as_deref_mut() {
                    Some(cache) => cache.tail(
                        scene,
                        source,
                        &listener_points,
                        &input,
                        options.source_reuse_m,
                        &deadline,
                    )?,
                    None => trace_tail(scene, source, &listener_points, &input, &deadline)?,
                }))
            },
            || -> Result<(Vec<Vec<DiffractedPath>>, f64)> {
                use rayon::prelude::*;
                let diffraction_start = Instant::now();
                let diffracted = listener_points
                    .par_iter()
                    .map(|&l| {
                        diffracted_paths_until(scene.edge_scene(), source, l, &search, &deadline)
                    })
                    .collect::<Result<_>>()?;
                Ok((diffracted, diffraction_start.elapsed().as_secs_f64() * 1e3))
            },
        );
        let tail = tail?;
        let (diffracted, diffraction_ms) = diffraction?;
        let surface_share = if tail.is_some() {
            SurfaceShare::Specular
        } else {
            SurfaceShare::Reflected
        };
        for (l, paths) in found.paths.iter().enumerate() {
            deadline.check()?;
            let air = options.air.as_ref();
            let listener = listener_points[l];
            let mut arrivals: Vec<Arrival> = paths
                .iter()
                .map(|p| arrival(scene, p, listener, speed, air, surface_share))
                .collect();
            arrivals.extend(
                diffracted[l]
                    .iter()
                    .map(|p| diffracted_arrival(p, listener, speed, air)),
            );
            let histogram: Option<&EnergyHistogram> = tail.as_ref().map(|t| &t.histograms[l]);
            let impulse_response = signal::synthesize_with_tail(&arrivals, histogram, &ir_options)?;
            let parameters = signal::per_band_with_tail(&arrivals, histogram, &bands)?
                .into_iter()
                .map(|(band_hz, parameters)| BandParameters {
                    band_hz,
                    parameters,
                })
                .collect();
            let mut sound_paths: Vec<SoundPath> = paths
                .iter()
                .zip(&arrivals)
                .map(|(p, a)| sound_path(scene, p, a, &bands, speed))
                .collect();
            sound_paths.extend(
                diffracted[l]
                    .iter()
                    .zip(&arrivals[paths.len()..])
                    .map(|(p, a)| diffracted_sound_path(scene, p, listener, a, &bands, speed)),
            );
            sound_paths.sort_by(|a, b| a.distance_m.total_cmp(&b.distance_m));
            out.push(Response {
                source: s,
                listener: l,
                bands_hz: bands.iter().map(|&b| OCTAVE_BANDS_HZ[b]).collect(),
                speed_of_sound_m_s: speed,
                stats: SimulationStats {
                    frusta: found.stats.frusta,
                    triangle_tests: found.stats.triangle_tests,
                    sample_rays: found.stats.sample_rays,
                    proposals: found.stats.proposals,
                    paths: sound_paths.len(),
                    beams_reused: beams_offset.is_some(),
                    beams_offset_m: beams_offset.unwrap_or(0.0),
                    trace_ms,
                    diffraction_ms,
                    tail: tail.as_ref().map(|t| t.stats.clone()),
                    total_ms: start.elapsed().as_secs_f64() * 1e3,
                    threads: rayon::current_num_threads(),
                    lod_error_m: scene.lod_error_m(),
                },
                paths: sound_paths,
                parameters,
                impulse_response,
                late_energy: histogram.cloned(),
            });
        }
    }
    Ok(out)
}

/// Which share of a reflection a specular path carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceShare {
    /// All the reflected energy, `1 − α`: the paths are the whole answer.
    Reflected,
    /// Its specular part, `(1 − α)(1 − s)`: the scattered rest is the
    /// tail's.
    Specular,
}

/// The path's arrival: surface factors (pressure: the square root of the
/// reflection's `share` per reflection, `sqrt(tau)` per transmission),
/// spherical spreading and air absorption, from the direction of its last
/// leg.
pub fn arrival(
    scene: &AcousticScene,
    p: &ValidPath,
    listener: DVec3,
    speed: f64,
    air: Option<&AirConditions>,
    share: SurfaceShare,
) -> Arrival {
    let mut gain: Bands = [1.0; BAND_COUNT];
    for v in &p.vertices {
        let group = scene.surfaces().group(v.event.group());
        if let Some(m) = scene.materials().get(group.material as usize) {
            for (b, g) in gain.iter_mut().enumerate() {
                *g *= if v.event.is_transmission() {
                    m.transmission[b].sqrt()
                } else if share == SurfaceShare::Specular {
                    ((1.0 - m.absorption[b]) * (1.0 - m.scattering[b])).sqrt()
                } else {
                    (1.0 - m.absorption[b]).sqrt()
                };
            }
        }
    }
    let spreading = 1.0 / p.length.max(MIN_SPREADING_DISTANCE_M);
    let air = air
        .map(|a| a.pressure_factors(p.length))
        .unwrap_or([1.0; BAND_COUNT]);
    for (g, a) in gain.iter_mut().zip(air) {
        *g = (f64::from(*g) * spreading * f64::from(a)) as f32;
    }
    let from = p.vertices.last().map_or(p.image_source, |v| v.point);
    Arrival {
        delay_s: p.length / speed,
        direction: (from - listener).normalize_or_zero().as_vec3(),
        pressure_gain: gain,
    }
}

fn sound_path(
    scene: &AcousticScene,
    p: &ValidPath,
    a: &Arrival,
    bands: &[usize],
    speed: f64,
) -> SoundPath {
    let surfaces = p
        .vertices
        .iter()
        .map(|v| {
            let event = if v.event.is_transmission() {
                "transmission"
            } else {
                "reflection"
            };
            surface_event(
                scene,
                (v.object, v.triangle),
                v.event.group(),
                event,
                v.point,
            )
        })
        .collect();
    SoundPath {
        order: p.order(),
        distance_m: p.length,
        delay_s: p.length / speed,
        image_source: p.image_source.to_array(),
        surfaces,
        pressure_gain: bands.iter().map(|&b| a.pressure_gain[b]).collect(),
    }
}

/// What a path meets at one point: `(object, mesh-order triangle)` of
/// plane group `group`, named as answers name them (on a simplified scene,
/// the original triangle).
fn surface_event(
    scene: &AcousticScene,
    (object, triangle): (u32, u32),
    group: u32,
    event: &'static str,
    point: DVec3,
) -> SurfaceEvent {
    let material = scene.surfaces().group(group).material as usize;
    SurfaceEvent {
        object: scene
            .object_names()
            .get(object as usize)
            .cloned()
            .unwrap_or_default(),
        triangle: scene.original_triangle(object, triangle),
        material: scene
            .materials()
            .get(material)
            .map(|m| m.name.clone())
            .unwrap_or_default(),
        event,
        point: point.to_array(),
    }
}

/// A diffracted path's arrival: its UTD gains with air absorption over
/// its length, from the direction of its last edge point.
fn diffracted_arrival(
    p: &DiffractedPath,
    listener: DVec3,
    speed: f64,
    air: Option<&AirConditions>,
) -> Arrival {
    let air = air
        .map(|a| a.pressure_factors(p.length))
        .unwrap_or([1.0; BAND_COUNT]);
    let mut gain = p.gain;
    for (g, a) in gain.iter_mut().zip(air) {
        *g *= a;
    }
    let from = p.points.last().map_or(listener, |e| e.point);
    Arrival {
        delay_s: p.length / speed,
        direction: (from - listener).normalize_or_zero().as_vec3(),
        pressure_gain: gain,
    }
}

/// A diffracted path as answers show it: one `"diffraction"` event per
/// edge (the triangle and material of the edge's first face), and, in
/// place of an image source, the apparent source: the point the sound
/// seems to come from, its length away along the last leg.
fn diffracted_sound_path(
    scene: &AcousticScene,
    p: &DiffractedPath,
    listener: DVec3,
    a: &Arrival,
    bands: &[usize],
    speed: f64,
) -> SoundPath {
    let surfaces = p
        .points
        .iter()
        .map(|e| {
            surface_event(
                scene,
                (e.object, e.triangle),
                e.group,
                "diffraction",
                e.point,
            )
        })
        .collect();
    let toward = a.direction.as_dvec3();
    SoundPath {
        order: p.points.len(),
        distance_m: p.length,
        delay_s: p.length / speed,
        image_source: (listener + toward * p.length).to_array(),
        surfaces,
        pressure_gain: bands.iter().map(|&b| a.pressure_gain[b]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_fields_at_every_level_are_errors_naming_them() {
        for (json, field) in [
            (r#"{"max_ordr": 3}"#, "max_ordr"),
            (r#"{"air": {"humidity_percent": 200}}"#, "humidity_percent"),
            (
                r#"{"listener_frame": {"forward": [1, 0, 0], "up": [0, 0, 1], "left": [0, 1, 0]}}"#,
                "left",
            ),
        ] {
            let e = serde_json::from_str::<SimulationOptions>(json).unwrap_err();
            assert!(e.to_string().contains(field), "{e}");
        }
    }

    #[test]
    fn sampling_left_out_or_null_is_the_cells_default() {
        let cells = |json: &str| -> TraceOptions {
            let options: SimulationOptions = serde_json::from_str(json).unwrap();
            options.trace_options().unwrap()
        };
        assert_eq!(cells("{}").sampling, 2);
        assert_eq!(cells(r#"{"sampling": null}"#).sampling, 2);
        assert_eq!(cells(r#"{"cells": "sampled"}"#).sampling, 8);
        assert_eq!(
            cells(r#"{"cells": "sampled", "sampling": null}"#).sampling,
            8
        );
        assert_eq!(cells(r#"{"cells": "sampled", "sampling": 3}"#).sampling, 3);
        assert_eq!(cells(r#"{"sampling": 5}"#).sampling, 5);
    }

    #[test]
    fn every_out_of_range_option_is_an_error_naming_it() {
        let bad = [
            (
                "max_order",
                SimulationOptions {
                    max_order: MAX_ORDER + 1,
                    ..Default::default()
                },
            ),
            (
                "sampling",
                SimulationOptions {
                    sampling: Some(0),
                    ..Default::default()
                },
            ),
            (
                "sampling",
                SimulationOptions {
                    sampling: Some(65),
                    ..Default::default()
                },
            ),
            (
                "primary_split",
                SimulationOptions {
                    primary_split: 0,
                    ..Default::default()
                },
            ),
            (
                "energy_threshold",
                SimulationOptions {
                    energy_threshold: f32::NAN,
                    ..Default::default()
                },
            ),
            (
                "energy_threshold",
                SimulationOptions {
                    energy_threshold: 1.0,
                    ..Default::default()
                },
            ),
            (
                "bands_hz",
                SimulationOptions {
                    bands_hz: vec![],
                    ..Default::default()
                },
            ),
            (
                "diffraction_order",
                SimulationOptions {
                    diffraction_order: MAX_DIFFRACTION_ORDER + 1,
                    ..Default::default()
                },
            ),
            (
                "source_reuse_m",
                SimulationOptions {
                    source_reuse_m: -0.1,
                    ..Default::default()
                },
            ),
            (
                "source_reuse_m",
                SimulationOptions {
                    source_reuse_m: f64::NAN,
                    ..Default::default()
                },
            ),
            (
                "source_reuse_m",
                SimulationOptions {
                    source_reuse_m: MAX_SOURCE_REUSE_M * 2.0,
                    ..Default::default()
                },
            ),
            (
                "1234",
                SimulationOptions {
                    bands_hz: vec![1234.0],
                    ..Default::default()
                },
            ),
            (
                "twice",
                SimulationOptions {
                    bands_hz: vec![500.0, 500.0],
                    ..Default::default()
                },
            ),
        ];
        for (word, options) in bad {
            let e = options.trace_options().unwrap_err().to_string();
            assert!(e.contains(word), "{e} should name {word}");
        }
        let t = SimulationOptions {
            bands_hz: vec![500.0, 1000.0],
            ..Default::default()
        }
        .trace_options()
        .unwrap();
        assert_eq!(
            t.active_bands,
            [false, false, false, true, true, false, false, false]
        );
    }
}
