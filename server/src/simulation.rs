//! Impulse-response requests as the HTTP route and the stream both take
//! them: positions and options checked against the server's limits, then
//! one simulation under the scene's read lock, so every answer belongs to
//! exactly one revision of the scene.

use std::time::Instant;

use frusta_engine::acoustics::signal::impulse_response::MAX_DURATION_S;
use frusta_engine::acoustics::signal::Channels;
use frusta_engine::acoustics::{
    simulate_cached, simulate_until, BeamCache, Cancel, Response, SimulationOptions,
};
use frusta_engine::geometry::MAX_COORDINATE;
use glam::Vec3;
use serde_json::{Map, Value};

use frusta_api::impulse_responses::Point;

use crate::config::Limits;
use crate::error::ApiError;
use crate::lod_cache::LodCache;
use crate::registry::SceneEntry;

/// Sources, listeners and options; every option has a default.
#[derive(Clone, Debug, PartialEq)]
pub struct IrRequest {
    pub sources: Vec<Vec3>,
    pub listeners: Vec<Vec3>,
    /// The level-of-detail bound, m (0: exact geometry).
    pub lod_error_m: f32,
    pub options: SimulationOptions,
}

impl IrRequest {
    /// Reads `{"sources": [...], "listeners": [...], "lod_error_m": m,
    /// <options>...}`; the options are the engine's `SimulationOptions`
    /// fields, and an unknown field is an error that names it.
    pub fn from_json(value: Value, limits: &Limits) -> Result<Self, ApiError> {
        let Value::Object(mut fields) = value else {
            return Err(ApiError::Invalid("the body must be a JSON object".into()));
        };
        let sources = points(&mut fields, "sources")?;
        let listeners = points(&mut fields, "listeners")?;
        let lod_error_m = match fields.remove("lod_error_m") {
            Some(v) => serde_json::from_value(v)
                .map_err(|e| ApiError::Invalid(format!("lod_error_m: {e}")))?,
            None => 0.0,
        };
        let options: SimulationOptions = serde_json::from_value(Value::Object(fields))
            .map_err(|e| ApiError::Invalid(format!("options: {e}")))?;
        let request = Self {
            sources,
            listeners,
            lod_error_m,
            options,
        };
        request.check(limits)?;
        Ok(request)
    }

    /// The server's caps; the engine checks everything else.
    pub fn check(&self, limits: &Limits) -> Result<(), ApiError> {
        if !(self.lod_error_m.is_finite() && self.lod_error_m >= 0.0) {
            return Err(ApiError::Invalid(format!(
                "lod_error_m must be a finite distance of at least 0 m, not {}",
                self.lod_error_m
            )));
        }
        let pairs = self.sources.len() * self.listeners.len();
        if pairs > limits.max_pairs {
            return Err(ApiError::LimitExceeded(format!(
                "{} sources x {} listeners = {pairs} pairs; at most {} are allowed",
                self.sources.len(),
                self.listeners.len(),
                limits.max_pairs
            )));
        }
        if self.options.max_order > limits.max_order {
            return Err(ApiError::LimitExceeded(format!(
                "max_order {} exceeds this server's limit of {}",
                self.options.max_order, limits.max_order
            )));
        }
        if self.options.sampling() > limits.max_sampling {
            return Err(ApiError::LimitExceeded(format!(
                "sampling {} exceeds this server's limit of {}",
                self.options.sampling(),
                limits.max_sampling
            )));
        }
        if let Some(tail) = self.options.tail.options() {
            if tail.rays > limits.max_tail_rays {
                return Err(ApiError::LimitExceeded(format!(
                    "tail.rays {} exceeds this server's limit of {}",
                    tail.rays, limits.max_tail_rays
                )));
            }
        }
        // The engine's own checks before the memory bound, which is only
        // meaningful for options it takes (a tail of 1e30 s is refused as
        // such, not as a memory need).
        self.options
            .trace_options()
            .map_err(ApiError::from_engine)?;
        let channels: u64 = match self.options.channels {
            Channels::Mono => 1,
            Channels::Binaural => 2,
        };
        // The IR's length is known only after tracing; bound its memory by
        // the longest one the engine renders.
        let tail_bytes = self
            .options
            .tail
            .options()
            .map_or(0, |t| t.worst_memory_bytes(self.listeners.len()));
        let worst_mib = (pairs as f64
            * channels as f64
            * f64::from(self.options.sample_rate)
            * MAX_DURATION_S
            * 4.0
            + tail_bytes as f64)
            / (1024.0 * 1024.0);
        if worst_mib > limits.max_ir_mib as f64 {
            return Err(ApiError::LimitExceeded(format!(
                "{pairs} pairs x {channels} channels at {} Hz could need {worst_mib:.0} MiB of samples \
                 (impulse responses up to {MAX_DURATION_S} s, and the tail's histograms); this server \
                 allows {} MiB: ask for fewer pairs, a lower sample_rate, mono or a shorter tail",
                self.options.sample_rate, limits.max_ir_mib
            )));
        }
        Ok(())
    }
}

fn points(fields: &mut Map<String, Value>, name: &str) -> Result<Vec<Vec3>, ApiError> {
    let value = fields.remove(name).ok_or_else(|| {
        ApiError::Invalid(format!(
            "`{name}` is missing: give at least one {{\"position\": [x, y, z]}}"
        ))
    })?;
    let list: Vec<Point> =
        serde_json::from_value(value).map_err(|e| ApiError::Invalid(format!("{name}: {e}")))?;
    positions(name, &list)
}

/// The points' positions, each checked finite.
pub fn positions(name: &str, list: &[Point]) -> Result<Vec<Vec3>, ApiError> {
    if list.is_empty() {
        return Err(ApiError::Invalid(format!("`{name}` is empty")));
    }
    list.iter()
        .enumerate()
        .map(|(i, p)| {
            let v = Vec3::from_array(p.position);
            if v.is_finite() && v.abs().max_element() <= MAX_COORDINATE {
                Ok(v)
            } else {
                Err(ApiError::Invalid(format!(
                    "{name}[{i}].position {:?} must be finite and within 1e15 m of the origin",
                    p.position
                )))
            }
        })
        .collect()
}

/// Cancels its simulation when dropped: held by a request's handler, so a
/// request that times out, or whose client goes away, frees its worker.
pub struct CancelOnDrop(pub Cancel);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.cancel();
    }
}

/// Simulates under the scene's read lock, stopping at `deadline` (the
/// compute limit of `limits` from when the request's work began) or on
/// `cancel`, on the scene simplified within the request's `lod_error_m`
/// where it has one (taken from `lods`, or moved or made there; making
/// it, a walk of the scene's trees, their planes' fit on first use and a
/// build of the result, is not interrupted, but its time counts: the
/// trace gets what is left). With a
/// `cache` (a stream), the frusta traced from unchanged sources are kept
/// for moving listeners; the engine drops them when the geometry,
/// materials or options change. Without one (a one-off request), listeners
/// are tested while tracing and nothing is kept. Blocking.
pub fn run(
    entry: &SceneEntry,
    request: &IrRequest,
    cache: Option<&mut BeamCache>,
    deadline: Instant,
    cancel: Option<&Cancel>,
    limits: &Limits,
    lods: &LodCache,
) -> Result<(u64, Vec<Response>), ApiError> {
    let live = entry.read();
    let simplified = match request.lod_error_m {
        0.0 => None,
        bound => lods.get(&entry.id, &live, bound)?,
    };
    let (scene, sources, listeners, options) = (
        simplified.as_deref().unwrap_or(&live.acoustic),
        &request.sources,
        &request.listeners,
        &request.options,
    );
    let responses = match cache {
        Some(cache) => simulate_cached(
            scene,
            sources,
            listeners,
            options,
            cache,
            Some(deadline),
            cancel,
        ),
        None => simulate_until(scene, sources, listeners, options, deadline, cancel),
    }
    .map_err(|e| ApiError::from_engine_within(e, limits))?;
    Ok((live.acoustic.revision(), responses))
}

/// Interleaved little-endian f32 frames, the binary form of an impulse
/// response on streams.
pub fn samples_le(response: &Response) -> Vec<u8> {
    let channels = &response.impulse_response.channels;
    let frames = channels.first().map_or(0, Vec::len);
    let mut out = Vec::with_capacity(frames * channels.len() * 4);
    for i in 0..frames {
        for c in channels {
            out.extend_from_slice(&c[i].to_le_bytes());
        }
    }
    out
}
