//! One run's results: the JSON line and the table row.

use frusta_engine::scene::BAND_COUNT;
use serde::{Deserialize, Serialize};

use super::compare::Comparison;

/// One run: ours at (order, N, cell mode), or the peer at an order. The
/// comparison fields start empty ([`Row::set`] fills them).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Row {
    pub scene: String,
    /// `frusta` (conservative cells), `frusta-sampled`, `pyroomacoustics`
    /// (one polygon wall per planar face) or `pyroomacoustics-triangles`
    /// (one wall per triangle).
    #[serde(rename = "impl")]
    pub imp: String,
    pub triangles: usize,
    /// Peer only: the walls it was given.
    pub walls: Option<usize>,
    pub order: u32,
    pub sampling: Option<u32>,
    pub frusta: Option<u64>,
    pub time_ms: f64,
    /// The independent reference's time on the same scene, source,
    /// listener and order (`None`: infeasible).
    pub reference_ms: Option<f64>,
    /// The exhaustive solver's time on the same case (`None`: infeasible).
    pub exhaustive_ms: Option<f64>,
    pub frusta_per_s_per_thread: Option<f64>,
    pub threads: usize,
    pub paths: usize,
    /// What `exact`, `recall`, `false_paths` and the errors are measured
    /// against: `"independent"` or `"exhaustive"`.
    pub reference: Option<String>,
    /// The reference's path count.
    pub exact: Option<usize>,
    pub recall: Option<f64>,
    pub false_paths: Option<usize>,
    pub max_time_error_s: Option<f64>,
    /// Per band (63 Hz .. 8 kHz), max |dB| over matched paths.
    pub max_energy_error_db: Option<[f64; BAND_COUNT]>,
    /// Per band, 10 log10(sum gain^2 traced / sum gain^2 reference).
    pub total_energy_error_db: Option<[f64; BAND_COUNT]>,
    /// Peer only: paths minus distinct image positions.
    pub duplicates: Option<usize>,
}

impl Row {
    pub fn set(&mut self, c: Comparison) {
        self.reference = Some(c.reference.to_string());
        self.exact = Some(c.exact);
        self.recall = Some(c.recall);
        self.false_paths = Some(c.false_paths);
        self.max_time_error_s = c.max_time_error_s;
        self.max_energy_error_db = c.max_energy_error_db;
        self.total_energy_error_db = Some(c.total_energy_error_db);
    }
}

fn opt<T>(v: Option<T>, f: impl Fn(T) -> String) -> String {
    v.map_or_else(|| "-".to_string(), f)
}

fn max_abs(v: &[f64; BAND_COUNT]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Times in ms to two decimals, the largest with none.
fn ms(x: f64) -> String {
    if x >= 1e4 {
        format!("{x:.0}")
    } else {
        format!("{x:.2}")
    }
}

/// The fixed-width table; energy columns give the largest band.
pub fn table(rows: &[Row], threads: usize) -> String {
    let header = [
        "scene",
        "impl",
        "tris",
        "walls",
        "order",
        "N",
        "frusta",
        "ms",
        "ref ms",
        "exh ms",
        "fr/s/thr",
        "thr",
        "paths",
        "vs",
        "exact",
        "recall",
        "false",
        "dt_max s",
        "dE_max dB",
        "dEtot dB",
        "dup",
    ];
    let mut cells = vec![header.map(String::from).to_vec()];
    for r in rows {
        cells.push(vec![
            r.scene.to_string(),
            r.imp.to_string(),
            r.triangles.to_string(),
            opt(r.walls, |w| w.to_string()),
            r.order.to_string(),
            opt(r.sampling, |n| n.to_string()),
            opt(r.frusta, |f| f.to_string()),
            ms(r.time_ms),
            opt(r.reference_ms, ms),
            opt(r.exhaustive_ms, ms),
            opt(r.frusta_per_s_per_thread, |f| format!("{f:.3e}")),
            r.threads.to_string(),
            r.paths.to_string(),
            opt(r.reference.as_deref(), |x| x[..3].to_string()),
            opt(r.exact, |e| e.to_string()),
            opt(r.recall, |x| format!("{x:.4}")),
            opt(r.false_paths, |x| x.to_string()),
            opt(r.max_time_error_s, |x| format!("{x:.1e}")),
            opt(r.max_energy_error_db.as_ref(), |x| {
                format!("{:.1e}", max_abs(x))
            }),
            opt(r.total_energy_error_db.as_ref(), |x| {
                format!("{:.1e}", max_abs(x))
            }),
            opt(r.duplicates, |x| x.to_string()),
        ]);
    }
    format!(
        "propagation: ms = wall time of the run (frusta: AcousticScene::find_paths on {threads} threads; \
         pyroomacoustics: Room.image_source_model, 1 thread); ref ms = the independent reference \
         (acoustics::brute_force, f64, {threads} threads) on the same case; exh ms = the exhaustive \
         solver (acoustics::reference, the tracer's validation, {threads} threads); vs = what exact, \
         recall, false and the errors are measured against (ind = independent, exh = exhaustive: \
         no time or gain errors, they are 0 by construction); energy errors: largest |dB| over the 8 bands\n{}",
        crate::report::aligned(&cells, 2)
    )
}
