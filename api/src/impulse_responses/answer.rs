//! The impulse-response answer as the service sends it (HTTP and stream
//! frames alike), converted from the engine's `Response` field by field:
//! the OpenAPI document shows every field, and an engine refactor cannot
//! change the contract unnoticed (a test below compares this with the
//! engine's own serialisation).

use frusta_engine::acoustics::{Response, SoundPath};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// The answer of the impulse-response route.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ImpulseResponses {
    pub scene: String,
    /// The scene revision every response belongs to.
    pub revision: u64,
    /// One per source-listener pair, sources outer.
    pub responses: Vec<PairResponse>,
}

/// What one listener hears from one source.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PairResponse {
    /// Index into the request's `sources`.
    pub source: usize,
    /// Index into the request's `listeners`.
    pub listener: usize,
    /// The bands every per-band array follows, Hz.
    pub bands_hz: Vec<f32>,
    pub speed_of_sound_m_s: f64,
    /// Validated paths, sorted by length: specular (the direct sound,
    /// order 0, among them) and diffracted around edges.
    pub paths: Vec<PathOut>,
    /// ISO 3382-1 parameters per band.
    pub parameters: Vec<BandParametersOut>,
    pub stats: StatsOut,
    /// The samples: a WAV body, or a stream's binary frame of interleaved
    /// little-endian f32 (`frames` x `channels`).
    pub sample_rate: u32,
    pub channels: usize,
    pub frames: usize,
}

/// One path from source to listener: specular, or diffracted around
/// edges.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PathOut {
    /// Surfaces and edges met: 0 for the direct sound.
    pub order: usize,
    pub distance_m: f64,
    pub delay_s: f64,
    /// The source mirrored in every surface of the path, `[x, y, z]`; for
    /// a diffracted path, the point it seems to come from (its length
    /// away along its last leg).
    pub image_source: [f64; 3],
    pub surfaces: Vec<SurfaceOut>,
    /// Linear pressure amplitude per band, relative to the source level at 1 m.
    pub pressure_gain: Vec<f32>,
}

/// One surface a path meets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SurfaceOut {
    pub object: String,
    /// Triangle index in the object's mesh.
    pub triangle: u32,
    pub material: String,
    /// `reflection`, `transmission` or `diffraction` (at an edge of the
    /// triangle's face).
    pub event: String,
    /// Where the path meets the surface, `[x, y, z]`.
    pub point: [f64; 3],
}

/// ISO 3382-1 parameters of one band; null where the decay is too short or
/// too shallow to measure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct BandParametersOut {
    pub band_hz: f32,
    /// Early decay time, s.
    pub edt_s: Option<f64>,
    /// Reverberation time from the -5 to -25 dB fit, s.
    pub t20_s: Option<f64>,
    /// Reverberation time from the -5 to -35 dB fit, s.
    pub t30_s: Option<f64>,
    /// Clarity for speech (50 ms), dB.
    pub c50_db: Option<f64>,
    /// Clarity for music (80 ms), dB.
    pub c80_db: Option<f64>,
    /// Definition: the fraction of the energy in the first 50 ms.
    pub d50: Option<f64>,
    /// Centre time, s.
    pub ts_s: Option<f64>,
}

/// What the simulation did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct StatsOut {
    /// Frusta traced for this source (shared by its listeners).
    pub frusta: u64,
    pub triangle_tests: u64,
    pub sample_rays: u64,
    /// Paths proposed before validation.
    pub proposals: u64,
    pub paths: usize,
    /// Whether the source's frusta came from a stream's cache.
    pub beams_reused: bool,
    /// How far from this source the reused frusta were traced, m: 0 when
    /// traced here; within the request's `source_reuse_m` they are
    /// re-mirrored for the moved source.
    #[serde(default)]
    pub beams_offset_m: f64,
    pub trace_ms: f64,
    /// Time to find the diffracted paths of the source's listeners (wall
    /// time, beside the tail's: the two overlap).
    pub diffraction_ms: f64,
    /// The late reverberation's rays and time; null without a tail.
    pub tail: Option<TailStatsOut>,
    pub total_ms: f64,
    pub threads: usize,
    /// The error bound of the simplified geometry this was computed on, m:
    /// the request's `lod_error_m`, or 0 for exact geometry (also where the
    /// bound replaced nothing). With a bound, paths name the original
    /// triangle each polygon stands for.
    #[serde(default)]
    pub lod_error_m: f32,
}

/// What tracing the late reverberation of this source took (shared by its
/// listeners).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TailStatsOut {
    pub rays: u64,
    /// Surface hits over all rays.
    pub reflections: u64,
    /// Shadow rays sent from diffuse reflections to the listeners.
    pub shadow_rays: u64,
    /// Radius of the sphere around each listener that counted rays, m: the
    /// smallest, unless the request fixed it (it grows with the path's
    /// length up to half a mean free path, counted where the listener sees).
    pub receiver_radius_m: f64,
    /// The room volume the sphere and the tail's echo density were sized by, m³.
    pub volume_m3: f64,
    /// Whether the rays' walk came from a stream's cache (the source and
    /// the scene unchanged): only the listeners' shadow rays and sphere
    /// tests were done.
    pub walk_reused: bool,
    /// How far from this source the kept walk's rays started, m, at most:
    /// a moving source's walk is renewed an eighth of its rays per update
    /// within `source_reuse_m` (0 when every ray started here).
    #[serde(default)]
    pub walk_offset_m: f64,
    pub trace_ms: f64,
}

impl From<&Response> for PairResponse {
    fn from(response: &Response) -> Self {
        let ir = &response.impulse_response;
        let stats = &response.stats;
        Self {
            source: response.source,
            listener: response.listener,
            bands_hz: response.bands_hz.clone(),
            speed_of_sound_m_s: response.speed_of_sound_m_s,
            paths: response.paths.iter().map(PathOut::from).collect(),
            parameters: response
                .parameters
                .iter()
                .map(|b| {
                    let p = &b.parameters;
                    BandParametersOut {
                        band_hz: b.band_hz,
                        edt_s: p.edt_s,
                        t20_s: p.t20_s,
                        t30_s: p.t30_s,
                        c50_db: p.c50_db,
                        c80_db: p.c80_db,
                        d50: p.d50,
                        ts_s: p.ts_s,
                    }
                })
                .collect(),
            stats: StatsOut {
                frusta: stats.frusta,
                triangle_tests: stats.triangle_tests,
                sample_rays: stats.sample_rays,
                proposals: stats.proposals,
                paths: stats.paths,
                beams_reused: stats.beams_reused,
                beams_offset_m: stats.beams_offset_m,
                trace_ms: stats.trace_ms,
                diffraction_ms: stats.diffraction_ms,
                tail: stats.tail.as_ref().map(|t| TailStatsOut {
                    rays: t.rays,
                    reflections: t.reflections,
                    shadow_rays: t.shadow_rays,
                    receiver_radius_m: t.receiver_radius_m,
                    volume_m3: t.volume_m3,
                    walk_reused: t.walk_reused,
                    walk_offset_m: t.walk_offset_m,
                    trace_ms: t.trace_ms,
                }),
                total_ms: stats.total_ms,
                threads: stats.threads,
                lod_error_m: stats.lod_error_m,
            },
            sample_rate: ir.sample_rate,
            channels: ir.channels.len(),
            frames: ir.channels.first().map_or(0, Vec::len),
        }
    }
}

impl From<&SoundPath> for PathOut {
    fn from(path: &SoundPath) -> Self {
        Self {
            order: path.order,
            distance_m: path.distance_m,
            delay_s: path.delay_s,
            image_source: path.image_source,
            surfaces: path
                .surfaces
                .iter()
                .map(|s| SurfaceOut {
                    object: s.object.clone(),
                    triangle: s.triangle,
                    material: s.material.clone(),
                    event: s.event.to_owned(),
                    point: s.point,
                })
                .collect(),
            pressure_gain: path.pressure_gain.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frusta_engine::acoustics::{simulate, AcousticScene};
    use frusta_engine::scene::generate::BoxRoom;
    use frusta_engine::scene::{Material, Scene};
    use glam::Vec3;
    use serde_json::json;

    #[test]
    fn the_answer_is_the_engines_response_and_its_samples_shape() {
        // The engine's own serialisation, field for field: a field the
        // engine gains or renames fails here until the wire type says so.
        let room = BoxRoom::new(Vec3::ZERO, Vec3::new(10.0, 6.0, 3.0))
            .generate()
            .expect("room");
        let walls = Material::uniform("walls", 0.1).expect("material");
        let scene = Scene::single_object("box", room, walls).expect("scene");
        let options =
            serde_json::from_value(json!({"max_order": 2, "sample_rate": 8000})).expect("options");
        let source = Vec3::new(2.0, 3.0, 1.5);
        let listener = Vec3::new(7.0, 3.0, 1.2);
        let responses = simulate(
            &AcousticScene::new(&scene),
            &[source],
            &[listener],
            &options,
        )
        .expect("simulate");
        let response = &responses[0];
        let mut engine = serde_json::to_value(response).expect("engine JSON");
        let ir = &response.impulse_response;
        engine["sample_rate"] = json!(ir.sample_rate);
        engine["channels"] = json!(ir.channels.len());
        engine["frames"] = json!(ir.channels[0].len());
        let wire = serde_json::to_value(PairResponse::from(response)).expect("wire JSON");
        assert!(response.paths.iter().any(|p| !p.surfaces.is_empty()));
        assert_eq!(wire, engine);
        let back: PairResponse = serde_json::from_value(wire).expect("read back");
        assert_eq!(back, PairResponse::from(response));
    }
}
