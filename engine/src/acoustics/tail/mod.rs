//! Late reverberation by stochastic ray tracing: what follows the exact
//! specular paths in an impulse response.
//!
//! Rays leave the source in uniformly random directions, each carrying
//! `4π / rays` of the source's energy per band (so a listener 1 m away
//! would receive energy 1, the unit of an arrival's squared gain). At a
//! surface a ray loses the absorbed fraction; of what it keeps, the
//! material's scattering coefficient is the diffuse share. Two estimators
//! feed each listener's [`EnergyHistogram`]:
//!
//! - **diffuse rain**: every hit sends its diffuse share straight to every
//!   listener it can see, by Lambert's law (`E cos θ / (π d²)`), with one
//!   shadow ray per listener; this converges far faster than waiting for
//!   diffusely scattered rays to cross a listener;
//! - **receiver spheres**: a ray leg crossing the sphere around a listener
//!   adds `E ℓ / V` (chord length over sphere volume, the track-length
//!   estimator of the energy density), which is what catches specular
//!   energy, including that of rooms without any scattering. The sphere
//!   grows with the path's length like the ray tube a ray of the lattice
//!   stands for, so that every image source is caught about once whatever
//!   the ray count, up to half a mean free path; where it reaches past a
//!   surface only its part the listener sees counts, in chords and volume.
//!
//! The ray then goes on diffusely (Lambert), specularly, or through the
//! surface (its transmission), picked at random in proportion to the
//! energies and re-weighted per band so every band stays unbiased. It stops
//! 60 dB below its starting energy, past the tail's length, or when it
//! leaves the scene.
//!
//! **Nothing is counted twice**: the exact part holds the specular paths up
//! to `max_order` (carrying the specular share `(1 − α)(1 − s)` of each
//! reflection). So a sphere crossing counts only on a leg whose history is
//! not purely specular, or is longer than `max_order`; a leg that starts
//! with a diffuse reflection is not counted at the sphere either, since the
//! rain from that reflection already carried it.
//!
//! Each ray draws from its own random stream (PCG, seeded from the seed and
//! the ray's index), and rays are summed in a fixed order of fixed chunks,
//! so a given seed gives the same tail, to the bit, on any thread count: a
//! stream of a static source does not flicker.

mod region;
mod walk;

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::signal::{AirConditions, EnergyHistogram};
use super::AcousticScene;
use crate::deadline::Deadline;
use crate::scene::{Bands, BAND_COUNT};
use crate::{Error, Result};
use walk::{Receivers, Tally, Walk};

/// Width of a histogram bin, s.
pub const BIN_S: f64 = 1e-3;
/// The most rays one source may trace.
pub const MAX_RAYS: u32 = 1 << 20;
/// The longest tail, s.
pub const MAX_LENGTH_S: f64 = 30.0;

/// Rays are summed in this many chunks, whatever the thread count: fixed
/// chunks make the sum's rounding, and so the tail, reproducible.
const CHUNKS: usize = 8;

/// How the late reverberation is traced.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TailOptions {
    /// Rays traced from each source.
    pub rays: u32,
    /// The tail ends here, s, or where every ray is 60 dB down.
    pub max_length_s: f64,
    /// Seed of the rays and of the tail's fine structure.
    pub seed: u64,
    /// Radius of the sphere around each listener that detects rays, m,
    /// fixed; `None` sizes the smallest from the room's volume and the ray
    /// count and lets it grow with the path's length up to half a mean free
    /// path, counted only where the listener sees (see `walk::Receivers`).
    pub receiver_radius_m: Option<f64>,
}

impl Default for TailOptions {
    /// 8192 rays, up to 3 s, seed 0, the sphere sized to the room.
    fn default() -> Self {
        Self {
            rays: 8192,
            max_length_s: 3.0,
            seed: 0,
            receiver_radius_m: None,
        }
    }
}

impl TailOptions {
    /// Checks every field; the error names the one at fault.
    pub fn validated(self) -> Result<Self> {
        let fail = |field: &str, reason: String| {
            Err(Error::InvalidOption {
                field: format!("tail.{field}"),
                reason,
            })
        };
        if !(1..=MAX_RAYS).contains(&self.rays) {
            return fail("rays", format!("{} must lie in 1..={MAX_RAYS}", self.rays));
        }
        if !(self.max_length_s > 0.0 && self.max_length_s <= MAX_LENGTH_S) {
            return fail(
                "max_length_s",
                format!("{} must lie in (0, {MAX_LENGTH_S}]", self.max_length_s),
            );
        }
        if let Some(r) = self.receiver_radius_m {
            if !(r.is_finite() && r > 0.0) {
                return fail(
                    "receiver_radius_m",
                    format!("{r} must be a positive length"),
                );
            }
        }
        Ok(self)
    }
}

impl TailOptions {
    /// The most memory a trace of one source's tail can take for
    /// `listeners` listeners, bytes: every chunk's bins for the whole
    /// length, and each listener's region. Servers bound requests by it.
    /// Saturates at `u64::MAX` for lengths too long for any trace (a NaN
    /// or negative length counts as none), so that servers can bound a
    /// request before checking its options.
    pub fn worst_memory_bytes(&self, listeners: usize) -> u64 {
        let bins = ((self.max_length_s / BIN_S).ceil().max(0.0) as u64).saturating_add(1);
        let per_listener = bins
            .saturating_mul((BAND_COUNT * std::mem::size_of::<f64>() * CHUNKS) as u64)
            .saturating_add(region::BYTES);
        (listeners as u64).saturating_mul(per_listener)
    }
}

/// Whether responses get a late part: `"none"` (or `null`) for the exact
/// paths alone, or the [`TailOptions`] of the stochastic tail.
#[derive(Clone, Debug, PartialEq)]
pub enum Tail {
    None,
    Stochastic(TailOptions),
}

impl Default for Tail {
    fn default() -> Self {
        Self::Stochastic(TailOptions::default())
    }
}

impl Tail {
    pub fn options(&self) -> Option<&TailOptions> {
        match self {
            Self::None => None,
            Self::Stochastic(options) => Some(options),
        }
    }
}

impl Serialize for Tail {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            Self::None => serializer.serialize_str("none"),
            Self::Stochastic(options) => options.serialize(serializer),
        }
    }
}

impl<'de> Deserialize<'de> for Tail {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Tail;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"none\", null, or an object of tail options")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<Tail, E> {
                match v {
                    "none" => Ok(Tail::None),
                    other => Err(E::invalid_value(serde::de::Unexpected::Str(other), &self)),
                }
            }
            fn visit_unit<E: serde::de::Error>(self) -> std::result::Result<Tail, E> {
                Ok(Tail::None)
            }
            fn visit_none<E: serde::de::Error>(self) -> std::result::Result<Tail, E> {
                Ok(Tail::None)
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> std::result::Result<Tail, A::Error> {
                TailOptions::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(Tail::Stochastic)
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

/// What tracing a tail took.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TailStats {
    pub rays: u64,
    /// Surface hits, over all rays.
    pub reflections: u64,
    /// Shadow rays of the diffuse rain.
    pub shadow_rays: u64,
    pub receiver_radius_m: f64,
    /// The room volume the sphere and the reflection density were sized by.
    pub volume_m3: f64,
    /// Whether the rays' walk was a stream's kept one (only the listeners'
    /// shadow rays and sphere tests were done, and for a source that moved
    /// one chunk of the rays walked again from where it is now).
    pub walk_reused: bool,
    /// How far from this source the kept walk's rays started, m, at most
    /// (0 when all were walked from here).
    pub walk_offset_m: f64,
    pub trace_ms: f64,
}

/// The late energy at each listener from one source.
#[derive(Clone, Debug)]
pub struct TracedTail {
    /// Per listener, in the order given.
    pub histograms: Vec<EnergyHistogram>,
    pub stats: TailStats,
}

/// What a tail trace needs beyond the scene and the points.
pub(crate) struct TailInput<'a> {
    pub options: &'a TailOptions,
    /// Specular paths up to this order are the exact part's.
    pub exact_order: u32,
    pub active_bands: [bool; BAND_COUNT],
    pub speed_of_sound: f64,
    pub air: Option<&'a AirConditions>,
}

/// Traces the tail of `source` at every listener.
pub(crate) fn trace_tail(
    scene: &AcousticScene,
    source: DVec3,
    listeners: &[DVec3],
    input: &TailInput,
    deadline: &Deadline,
) -> Result<TracedTail> {
    let start = Instant::now();
    let room = Room::of(scene, input);
    let walk = Walk::new(scene, source, input, room.free_path);
    let receivers = Receivers::new(scene, listeners, input, &room, deadline)?;
    let chunks: Vec<Tally> = chunk_ranges(input.options.rays)
        .into_par_iter()
        .map(|rays| {
            let mut tally = Tally::new(listeners.len());
            // Events are rounded as a kept walk keeps them, so a stream's
            // replayed tail is this one, to the bit.
            tally.reflections = walk.rays(rays, deadline, &mut |e| {
                receivers.take(&walk::Recorded::from(&e), &mut tally)
            })?;
            Ok(tally)
        })
        .collect::<Result<_>>()?;
    Ok(summed(&chunks, &room, input, start))
}

/// The walk of one source's rays, kept to hand to any listeners later
/// ([`TailRecord::replay`]): the walk is most of a tail's work, and it
/// does not depend on the listeners. A chunk may be walked again from a
/// source that moved ([`TailRecord::rewalk`]), so a moving source's tail
/// is renewed a chunk at a time.
#[derive(Clone, Debug)]
pub struct TailRecord {
    /// The events of each chunk of rays, in walk order.
    chunks: Vec<Vec<walk::Recorded>>,
    /// Per chunk, where its rays started and the surface hits they made.
    sources: Vec<DVec3>,
    hits: Vec<u64>,
    rays: u32,
}

impl TailRecord {
    /// Events held.
    pub fn events(&self) -> usize {
        self.chunks.iter().map(Vec::len).sum()
    }

    /// Where each chunk's rays started.
    pub(crate) fn sources(&self) -> &[DVec3] {
        &self.sources
    }

    /// Walks chunk `chunk` again from `source`, in place of its events;
    /// `false`, the record unchanged, when they would pass `max_events`
    /// over [`CHUNKS`]. The chunk's rays are the ones a record made at
    /// `source` has there, so once every chunk is walked from one source
    /// the record is the one [`record_tail`] makes there, to the bit.
    pub(crate) fn rewalk(
        &mut self,
        chunk: usize,
        scene: &AcousticScene,
        source: DVec3,
        input: &TailInput,
        max_events: usize,
        deadline: &Deadline,
    ) -> Result<bool> {
        let room = Room::of(scene, input);
        let walk = Walk::new(scene, source, input, room.free_path);
        let rays = chunk_ranges(input.options.rays)[chunk].clone();
        // Two halves on two threads, joined in ray order.
        let mid = rays.start + rays.len() / 2;
        let per_chunk = max_events / CHUNKS;
        let (first, second) = rayon::join(
            || walk_events(&walk, rays.start..mid, per_chunk, deadline),
            || walk_events(&walk, mid..rays.end, per_chunk, deadline),
        );
        let (Some((mut events, a)), Some((more, b))) = (first?, second?) else {
            return Ok(false);
        };
        // Within the chunk's share, as a record made here would be, and
        // with the other chunks within `max_events` too (they were capped
        // when the room was different).
        let others = self.events() - self.chunks[chunk].len();
        if events.len() + more.len() > per_chunk || others + events.len() + more.len() > max_events
        {
            return Ok(false);
        }
        events.extend(more);
        self.chunks[chunk] = events;
        self.sources[chunk] = source;
        self.hits[chunk] = a + b;
        Ok(true)
    }
}

/// The events of rays `rays`, and their surface hits; `None` past
/// `max_events`.
fn walk_events(
    walk: &Walk,
    rays: std::ops::Range<usize>,
    max_events: usize,
    deadline: &Deadline,
) -> Result<Option<(Vec<walk::Recorded>, u64)>> {
    let mut events = Vec::new();
    let mut full = false;
    let hits = walk.rays(rays, deadline, &mut |e| {
        if events.len() < max_events {
            events.push(walk::Recorded::from(&e));
        } else {
            full = true;
        }
    })?;
    Ok((!full).then_some((events, hits)))
}

/// Walks the rays of `source` and keeps their events, unless they number
/// more than `max_events` (then `None`: the caller traces each time).
pub(crate) fn record_tail(
    scene: &AcousticScene,
    source: DVec3,
    input: &TailInput,
    max_events: usize,
    deadline: &Deadline,
) -> Result<Option<TailRecord>> {
    let room = Room::of(scene, input);
    let walk = Walk::new(scene, source, input, room.free_path);
    let per_chunk = max_events / CHUNKS;
    let chunks: Vec<Option<(Vec<walk::Recorded>, u64)>> = chunk_ranges(input.options.rays)
        .into_par_iter()
        .map(|rays| walk_events(&walk, rays, per_chunk, deadline))
        .collect::<Result<_>>()?;
    let Some(chunks) = chunks.into_iter().collect::<Option<Vec<_>>>() else {
        return Ok(None);
    };
    let (chunks, hits) = chunks.into_iter().unzip();
    Ok(Some(TailRecord {
        chunks,
        sources: vec![source; CHUNKS],
        hits,
        rays: input.options.rays,
    }))
}

impl TailRecord {
    /// The tail of the recorded source at `listeners`: what
    /// [`trace_tail`] gives, to the bit, for the cost of the shadow rays
    /// and sphere tests alone.
    pub(crate) fn replay(
        &self,
        scene: &AcousticScene,
        listeners: &[DVec3],
        input: &TailInput,
        deadline: &Deadline,
    ) -> Result<TracedTail> {
        let start = Instant::now();
        let room = Room::of(scene, input);
        let receivers = Receivers::new(scene, listeners, input, &room, deadline)?;
        let chunks: Vec<Tally> = self
            .chunks
            .par_iter()
            .map(|events| {
                deadline.check()?;
                let mut tally = Tally::new(listeners.len());
                for e in events {
                    receivers.take(e, &mut tally);
                }
                Ok(tally)
            })
            .collect::<Result<_>>()?;
        let mut traced = summed(&chunks, &room, input, start);
        traced.stats.rays = u64::from(self.rays);
        traced.stats.reflections = self.hits.iter().sum();
        Ok(traced)
    }
}

/// What a tail's estimators are sized by.
struct Room {
    volume: f64,
    /// Whether the surfaces enclose the volume (else it is the scene's
    /// box, and the free path means little).
    closed: bool,
    free_path: f64,
    radius: f64,
}

impl Room {
    /// The largest a listener's sphere may grow: half a mean free path,
    /// so it stays small beside the room.
    fn sphere_reach(&self) -> f64 {
        0.5 * self.free_path
    }

    fn of(scene: &AcousticScene, input: &TailInput) -> Self {
        let (volume, closed) = room_volume(scene);
        let free_path = mean_free_path(scene, volume);
        let radius = input.options.receiver_radius_m.unwrap_or_else(|| {
            receiver_radius(
                scene,
                volume,
                free_path,
                input.options.rays,
                input.speed_of_sound,
            )
        });
        Self {
            volume,
            closed,
            free_path,
            radius,
        }
    }
}

/// The rays of each of the [`CHUNKS`] chunks.
fn chunk_ranges(rays: u32) -> Vec<std::ops::Range<usize>> {
    let rays = rays as usize;
    let per_chunk = rays.div_ceil(CHUNKS);
    (0..CHUNKS)
        .map(|c| c * per_chunk..((c + 1) * per_chunk).min(rays))
        .collect()
}

/// The chunks' tallies summed in chunk order, as histograms.
fn summed(chunks: &[Tally], room: &Room, input: &TailInput, start: Instant) -> TracedTail {
    let listeners = chunks.first().map_or(0, |c| c.energy.len());
    let mut total = Tally::new(listeners);
    for chunk in chunks {
        total.add(chunk);
    }
    let histograms = total
        .energy
        .iter()
        .map(|bins| histogram(bins, room.volume, input, input.options.seed))
        .collect();
    TracedTail {
        histograms,
        stats: TailStats {
            rays: u64::from(input.options.rays),
            reflections: total.reflections,
            shadow_rays: total.shadow_rays,
            receiver_radius_m: room.radius,
            volume_m3: room.volume,
            walk_reused: false,
            walk_offset_m: 0.0,
            trace_ms: start.elapsed().as_secs_f64() * 1e3,
        },
    }
}

/// A listener's summed bins with air absorption applied by each bin's
/// travel distance (air depends on nothing else, so it is applied once
/// here rather than per ray).
fn histogram(
    bins: &[[f64; BAND_COUNT]],
    volume: f64,
    input: &TailInput,
    seed: u64,
) -> EnergyHistogram {
    let bins = bins
        .iter()
        .enumerate()
        .map(|(k, energy)| {
            let air = input.air.map_or([1.0; BAND_COUNT], |a| {
                a.pressure_factors((k as f64 + 0.5) * BIN_S * input.speed_of_sound)
            });
            let mut out: Bands = [0.0; BAND_COUNT];
            for ((o, &e), a) in out.iter_mut().zip(energy).zip(air) {
                *o = (e * f64::from(a).powi(2)) as f32;
            }
            out
        })
        .collect();
    EnergyHistogram {
        bin_s: BIN_S,
        bins,
        volume_m3: volume,
        speed_of_sound: input.speed_of_sound,
        seed,
    }
}

/// The volume sound fills: what the surfaces enclose when they are closed,
/// bounded by the scene's box (an open scene's signed sum means nothing);
/// and whether they are.
fn room_volume(scene: &AcousticScene) -> (f64, bool) {
    let size = scene.bvh().bounds().extent().as_dvec3();
    let boxed = (size.x * size.y * size.z).max(size.max_element().powi(3) * 1e-6);
    let (_, enclosed) = scene.surfaces().area_and_volume();
    if enclosed > 1e-6 * boxed {
        (enclosed.min(boxed), true)
    } else {
        (boxed, false)
    }
}

/// Crossings of a listener's sphere expected per histogram bin: enough that
/// the decay curve is smooth well before it is integrated.
const CROSSINGS_PER_BIN: f64 = 2.0;

/// The mean free path of a diffuse field, `4V/S`, m (the scene's size for
/// a scene without area).
fn mean_free_path(scene: &AcousticScene, volume: f64) -> f64 {
    let (area, _) = scene.surfaces().area_and_volume();
    if area > 0.0 {
        4.0 * volume / area
    } else {
        scene.surfaces().scale()
    }
}

/// The sphere radius at which `rays` rays spread through `volume` cross it
/// [`CROSSINGS_PER_BIN`] times per bin (`N c π r² Δt / V`), at most a
/// quarter of the mean free path so it stays small beside the room.
fn receiver_radius(
    scene: &AcousticScene,
    volume: f64,
    free_path: f64,
    rays: u32,
    speed: f64,
) -> f64 {
    let wanted = (CROSSINGS_PER_BIN * volume
        / (f64::from(rays) * speed * std::f64::consts::PI * BIN_S))
        .sqrt();
    wanted
        .min(0.25 * free_path)
        .max(1e-6 * scene.surfaces().scale())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A length or listener count no trace accepts bounds memory at the
    /// most, never overflows (found by the server's bad-input property
    /// test: a debug build panicked on it).
    #[test]
    fn worst_memory_saturates() {
        let options = |max_length_s| TailOptions {
            max_length_s,
            ..TailOptions::default()
        };
        assert_eq!(options(1e30).worst_memory_bytes(1), u64::MAX);
        assert_eq!(options(f64::INFINITY).worst_memory_bytes(2), u64::MAX);
        assert_eq!(options(3.0).worst_memory_bytes(usize::MAX), u64::MAX);
        let one = options(3.0).worst_memory_bytes(1);
        assert!(one > 0 && one < 1 << 30);
        assert_eq!(options(3.0).worst_memory_bytes(3), 3 * one);
    }
    #[test]
    fn tail_reads_none_null_and_objects_and_names_bad_fields() {
        let parse = |json: &str| serde_json::from_str::<Tail>(json);
        assert_eq!(parse(r#""none""#).unwrap(), Tail::None);
        assert_eq!(parse("null").unwrap(), Tail::None);
        assert_eq!(parse("{}").unwrap(), Tail::default());
        let Tail::Stochastic(o) = parse(r#"{"rays": 100, "seed": 3}"#).unwrap() else {
            panic!("an object is a stochastic tail");
        };
        assert_eq!((o.rays, o.seed, o.max_length_s), (100, 3, 3.0));
        assert!(parse(r#""some""#).unwrap_err().to_string().contains("none"));
        assert!(parse(r#"{"ray": 1}"#)
            .unwrap_err()
            .to_string()
            .contains("ray"));
        for tail in [Tail::None, Tail::default()] {
            assert_eq!(parse(&serde_json::to_string(&tail).unwrap()).unwrap(), tail);
        }
    }

    #[test]
    fn out_of_range_tail_options_name_their_field() {
        let base = TailOptions::default();
        for (field, options) in [
            (
                "rays",
                TailOptions {
                    rays: 0,
                    ..base.clone()
                },
            ),
            (
                "rays",
                TailOptions {
                    rays: MAX_RAYS + 1,
                    ..base.clone()
                },
            ),
            (
                "max_length_s",
                TailOptions {
                    max_length_s: 0.0,
                    ..base.clone()
                },
            ),
            (
                "max_length_s",
                TailOptions {
                    max_length_s: f64::NAN,
                    ..base.clone()
                },
            ),
            (
                "max_length_s",
                TailOptions {
                    max_length_s: 31.0,
                    ..base.clone()
                },
            ),
            (
                "receiver_radius_m",
                TailOptions {
                    receiver_radius_m: Some(-1.0),
                    ..base.clone()
                },
            ),
            (
                "receiver_radius_m",
                TailOptions {
                    receiver_radius_m: Some(f64::INFINITY),
                    ..base.clone()
                },
            ),
        ] {
            let e = options.validated().unwrap_err().to_string();
            assert!(e.contains(field), "{e} should name {field}");
        }
    }
}
