//! The impulse-response answer as the service sends it (HTTP and stream
//! frames alike): its own types with schemas, borrowed from the engine's
//! `Response` at the edge, so the OpenAPI document shows every field and
//! an engine refactor cannot change the contract unnoticed (the tests
//! below compare served JSON with the schema).

use frusta_engine::acoustics::{Response, SoundPath};
use serde::Serialize;
use utoipa::ToSchema;

/// What one listener hears from one source.
#[derive(Serialize, ToSchema)]
pub struct PairResponse<'a> {
    /// Index into the request's `sources`.
    source: usize,
    /// Index into the request's `listeners`.
    listener: usize,
    /// The bands every per-band array follows, Hz.
    bands_hz: &'a [f32],
    speed_of_sound_m_s: f64,
    /// Validated specular paths, the direct sound (order 0) among them.
    paths: Vec<PathOut<'a>>,
    /// ISO 3382-1 parameters per band.
    parameters: Vec<BandParametersOut>,
    stats: StatsOut,
    /// The samples: a WAV body, or a stream's binary frame of interleaved
    /// little-endian f32 (`frames` x `channels`).
    sample_rate: u32,
    channels: usize,
    frames: usize,
}

/// One specular path from source to listener.
#[derive(Serialize, ToSchema)]
pub struct PathOut<'a> {
    /// Surfaces met: 0 for the direct sound.
    order: usize,
    distance_m: f64,
    delay_s: f64,
    /// The source mirrored in every surface of the path, `[x, y, z]`.
    image_source: [f64; 3],
    surfaces: Vec<SurfaceOut<'a>>,
    /// Linear pressure amplitude per band, relative to the source level at 1 m.
    pressure_gain: &'a [f32],
}

/// One surface a path meets.
#[derive(Serialize, ToSchema)]
pub struct SurfaceOut<'a> {
    object: &'a str,
    /// Triangle index in the object's mesh.
    triangle: u32,
    material: &'a str,
    /// `reflection` or `transmission`.
    event: &'a str,
    /// Where the path meets the surface, `[x, y, z]`.
    point: [f64; 3],
}

/// ISO 3382-1 parameters of one band; null where the decay is too short or
/// too shallow to measure.
#[derive(Serialize, ToSchema)]
pub struct BandParametersOut {
    band_hz: f32,
    /// Early decay time, s.
    edt_s: Option<f64>,
    /// Reverberation time from the -5 to -25 dB fit, s.
    t20_s: Option<f64>,
    /// Reverberation time from the -5 to -35 dB fit, s.
    t30_s: Option<f64>,
    /// Clarity for speech (50 ms), dB.
    c50_db: Option<f64>,
    /// Clarity for music (80 ms), dB.
    c80_db: Option<f64>,
    /// Definition: the fraction of the energy in the first 50 ms.
    d50: Option<f64>,
    /// Centre time, s.
    ts_s: Option<f64>,
}

/// What the simulation did.
#[derive(Serialize, ToSchema)]
pub struct StatsOut {
    /// Frusta traced for this source (shared by its listeners).
    frusta: u64,
    triangle_tests: u64,
    sample_rays: u64,
    /// Paths proposed before validation.
    proposals: u64,
    paths: usize,
    /// Whether the source's frusta came from a stream's cache.
    beams_reused: bool,
    trace_ms: f64,
    total_ms: f64,
    threads: usize,
}

impl<'a> PairResponse<'a> {
    pub fn new(response: &'a Response) -> Self {
        let ir = &response.impulse_response;
        let stats = &response.stats;
        Self {
            source: response.source,
            listener: response.listener,
            bands_hz: &response.bands_hz,
            speed_of_sound_m_s: response.speed_of_sound_m_s,
            paths: response.paths.iter().map(PathOut::new).collect(),
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
                trace_ms: stats.trace_ms,
                total_ms: stats.total_ms,
                threads: stats.threads,
            },
            sample_rate: ir.sample_rate,
            channels: ir.channels.len(),
            frames: ir.channels.first().map_or(0, Vec::len),
        }
    }
}

impl<'a> PathOut<'a> {
    fn new(path: &'a SoundPath) -> Self {
        Self {
            order: path.order,
            distance_m: path.distance_m,
            delay_s: path.delay_s,
            image_source: path.image_source,
            surfaces: path
                .surfaces
                .iter()
                .map(|s| SurfaceOut {
                    object: &s.object,
                    triangle: s.triangle,
                    material: &s.material,
                    event: s.event,
                    point: s.point,
                })
                .collect(),
            pressure_gain: &path.pressure_gain,
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::routes::test_support::*;
    use serde_json::{json, Value};

    /// A shoebox answer with reflections and transmissions-free paths.
    async fn answer(server: &TestServer) -> Value {
        let body = json!({
            "sources": [{"position": [2, 3, 1.5]}], "listeners": [{"position": [7, 3, 1.2]}],
            "max_order": 2, "sample_rate": 8000
        });
        let uri = "/v1/scenes/shoebox/impulse-responses";
        let (status, _, body) = server.send(post_json(uri, &body.to_string())).await;
        assert_eq!(status, axum::http::StatusCode::OK, "{body}");
        body
    }

    #[tokio::test]
    async fn the_answer_is_the_engines_response_and_its_samples_shape() {
        // The engine's own serialisation, field for field: a field the
        // engine gains or renames fails here until the wire type says so.
        let server = TestServer::new();
        let served = answer(&server).await["responses"][0].clone();
        let entry = server.state.registry().get("shoebox").unwrap();
        let live = entry.read();
        let options = serde_json::from_value(json!({"max_order": 2, "sample_rate": 8000})).unwrap();
        let responses = frusta_engine::acoustics::simulate(
            &live.acoustic,
            &[glam::Vec3::new(2.0, 3.0, 1.5)],
            &[glam::Vec3::new(7.0, 3.0, 1.2)],
            &options,
        )
        .unwrap();
        // Through text, as the served answer came.
        let mut engine: Value =
            serde_json::from_str(&serde_json::to_string(&responses[0]).unwrap()).unwrap();
        let ir = &responses[0].impulse_response;
        engine["sample_rate"] = json!(ir.sample_rate);
        engine["channels"] = json!(ir.channels.len());
        engine["frames"] = json!(ir.channels[0].len());
        // Timings differ between the two runs; everything else may not.
        let mut served = served;
        for v in [&mut engine, &mut served] {
            v["stats"]["trace_ms"] = json!(0);
            v["stats"]["total_ms"] = json!(0);
            v["stats"]["threads"] = json!(0);
        }
        assert!(same(&served, &engine), "served {served}\nengine {engine}");
    }

    /// Equal in shape, keys, strings and integers; floats to 1e-9 relative
    /// (parallel sums may round the last bit differently between runs).
    fn same(a: &Value, b: &Value) -> bool {
        match (a, b) {
            (Value::Object(x), Value::Object(y)) => {
                x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same(v, w)))
            }
            (Value::Array(x), Value::Array(y)) => {
                x.len() == y.len() && x.iter().zip(y).all(|(v, w)| same(v, w))
            }
            (Value::Number(x), Value::Number(y)) if x.is_f64() || y.is_f64() => {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs())
            }
            (a, b) => a == b,
        }
    }

    /// The property names of component `name` in the OpenAPI document.
    fn properties(api: &Value, name: &str) -> Vec<String> {
        let mut names: Vec<String> = api["components"]["schemas"][name]["properties"]
            .as_object()
            .unwrap_or_else(|| panic!("no schema {name}"))
            .keys()
            .cloned()
            .collect();
        names.sort();
        names
    }

    fn keys(v: &Value) -> Vec<String> {
        let mut names: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
        names.sort();
        names
    }

    #[tokio::test]
    async fn openapi_shows_the_answer_field_by_field() {
        let server = TestServer::new();
        let (_, _, api) = server.send(get("/openapi.json")).await;
        let pair = &answer(&server).await["responses"][0];
        assert_eq!(properties(&api, "PairResponse"), keys(pair));
        assert_eq!(properties(&api, "PathOut"), keys(&pair["paths"][1]));
        assert_eq!(
            properties(&api, "SurfaceOut"),
            keys(&pair["paths"][1]["surfaces"][0])
        );
        assert_eq!(
            properties(&api, "BandParametersOut"),
            keys(&pair["parameters"][0])
        );
        assert_eq!(properties(&api, "StatsOut"), keys(&pair["stats"]));
        for field in ["sources", "listeners", "max_order", "bands_hz", "air"] {
            assert!(
                properties(&api, "ImpulseResponseRequest").contains(&field.to_owned()),
                "{field}"
            );
        }
    }
}
