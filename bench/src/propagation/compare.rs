//! Traced paths (or the peer's image sources) against a reference, one by
//! one.

use std::collections::HashMap;

use frusta_engine::acoustics::brute_force::ReferencePath;
use frusta_engine::acoustics::path::{Event, ValidPath};
use frusta_engine::acoustics::propagation::{arrival, SurfaceShare};
use frusta_engine::acoustics::signal::AirConditions;
use frusta_engine::acoustics::AcousticScene;
use frusta_engine::scene::{MaterialId, BAND_COUNT};
use glam::DVec3;

/// A traced path and a reference path are one path when their image
/// sources agree to this, relative to the length.
const SAME_IMAGE: f64 = 1e-6;
/// The peer's image sources are float32 (libroom): they match a reference
/// image within this many metres plus `PEER_RELATIVE` of the length.
const PEER_ABSOLUTE_M: f64 = 1e-4;
const PEER_RELATIVE: f64 = 1e-5;

/// What a comparison gives a row; the error fields are `None` where they
/// would be zero by construction (against the exhaustive solver).
pub struct Comparison {
    /// `"independent"` or `"exhaustive"`.
    pub reference: &'static str,
    pub exact: usize,
    pub recall: f64,
    pub false_paths: usize,
    pub max_time_error_s: Option<f64>,
    pub max_energy_error_db: Option<[f64; BAND_COUNT]>,
    pub total_energy_error_db: [f64; BAND_COUNT],
}

/// Energies over matched traced paths and over the reference, per band.
struct Energies {
    traced: [f64; BAND_COUNT],
    reference: [f64; BAND_COUNT],
}

impl Energies {
    fn db(&self) -> [f64; BAND_COUNT] {
        std::array::from_fn(|b| 10.0 * (self.traced[b] / self.reference[b]).log10())
    }
}

fn recall(matched: usize, exact: usize) -> f64 {
    if exact == 0 {
        1.0
    } else {
        matched as f64 / exact as f64
    }
}

fn speed() -> f64 {
    AirConditions::default().speed_of_sound()
}

/// The kinds and materials of a path's events, in order: what a traced
/// path and a reference path must share to be one path.
type Signature = Vec<(bool, MaterialId)>;

/// Against the independent reference: a traced path matches an unused
/// reference path of the same signature whose image source lies within
/// `SAME_IMAGE` of its length. Times and gains are compared on matched
/// paths (gains without air: the tracer's `arrival` against the closed
/// form).
pub fn against_independent(
    scene: &AcousticScene,
    listener: DVec3,
    traced: &[ValidPath],
    reference: &[ReferencePath],
) -> Comparison {
    let mut by_signature: HashMap<Signature, Vec<usize>> = HashMap::new();
    for (i, r) in reference.iter().enumerate() {
        let s = r
            .events
            .iter()
            .map(|e| (e.transmission, e.material))
            .collect();
        by_signature.entry(s).or_default().push(i);
    }
    let c = speed();
    let mut used = vec![false; reference.len()];
    let (mut matched, mut false_paths, mut dt) = (0, 0, 0.0f64);
    let mut de = [0.0f64; BAND_COUNT];
    let mut energy = Energies {
        traced: [0.0; BAND_COUNT],
        reference: [0.0; BAND_COUNT],
    };
    for p in traced {
        let s: Signature = p
            .vertices
            .iter()
            .map(|v| {
                let group = scene.surfaces().group(v.event.group());
                (v.event.is_transmission(), group.material)
            })
            .collect();
        let found = by_signature.get(&s).and_then(|candidates| {
            candidates.iter().copied().find(|&i| {
                !used[i]
                    && reference[i].image_source.distance(p.image_source)
                        <= SAME_IMAGE * reference[i].length
            })
        });
        let Some(i) = found else {
            false_paths += 1;
            continue;
        };
        used[i] = true;
        matched += 1;
        let r = &reference[i];
        dt = dt.max((p.length - r.length).abs() / c);
        let gains = arrival(scene, p, listener, c, None, SurfaceShare::Reflected).pressure_gain;
        for b in 0..BAND_COUNT {
            let (t, e) = (f64::from(gains[b]), r.pressure_gain[b]);
            de[b] = de[b].max((20.0 * (t / e).log10()).abs());
            energy.traced[b] += t * t;
        }
    }
    for r in reference {
        for (b, g) in r.pressure_gain.iter().enumerate() {
            energy.reference[b] += g * g;
        }
    }
    Comparison {
        reference: "independent",
        exact: reference.len(),
        recall: recall(matched, reference.len()),
        false_paths,
        max_time_error_s: Some(dt),
        max_energy_error_db: Some(de),
        total_energy_error_db: energy.db(),
    }
}

fn events(p: &ValidPath) -> Vec<Event> {
    p.vertices.iter().map(|v| v.event).collect()
}

/// Against the exhaustive solver: paths are identified by their event
/// sequence (plane group, reflection or transmission). Both sides are
/// validated and evaluated by the same engine code, so only recall, false
/// paths and the energy of the missed paths are informative.
pub fn against_exhaustive(
    scene: &AcousticScene,
    listener: DVec3,
    traced: &[ValidPath],
    reference: &[ValidPath],
) -> Comparison {
    let c = speed();
    let energy =
        |p: &ValidPath| arrival(scene, p, listener, c, None, SurfaceShare::Reflected).pressure_gain;
    let exact: HashMap<Vec<Event>, &ValidPath> = reference.iter().map(|p| (events(p), p)).collect();
    let mut e = Energies {
        traced: [0.0; BAND_COUNT],
        reference: [0.0; BAND_COUNT],
    };
    let (mut matched, mut false_paths) = (0, 0);
    for p in traced {
        if exact.contains_key(&events(p)) {
            matched += 1;
            for (b, g) in energy(p).iter().enumerate() {
                e.traced[b] += f64::from(*g).powi(2);
            }
        } else {
            false_paths += 1;
        }
    }
    for r in reference {
        for (b, g) in energy(r).iter().enumerate() {
            e.reference[b] += f64::from(*g).powi(2);
        }
    }
    Comparison {
        reference: "exhaustive",
        exact: exact.len(),
        recall: recall(matched, exact.len()),
        false_paths,
        max_time_error_s: None,
        max_energy_error_db: None,
        total_energy_error_db: e.db(),
    }
}

/// The peer's image sources against the independent reference's, one to
/// one by position: (matched, unmatched peer images). The peer's
/// unmatched images are false or duplicate paths.
pub fn peer_images(peer: &[DVec3], reference: &[ReferencePath]) -> (usize, usize) {
    let mut used = vec![false; reference.len()];
    let mut matched = 0;
    for p in peer {
        let found = (0..reference.len()).find(|&i| {
            let r = &reference[i];
            !used[i] && r.image_source.distance(*p) <= PEER_ABSOLUTE_M + PEER_RELATIVE * r.length
        });
        if let Some(i) = found {
            used[i] = true;
            matched += 1;
        }
    }
    (matched, peer.len() - matched)
}
