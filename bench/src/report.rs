//! Results: the aligned text table and the JSON object.

use serde::Serialize;

use crate::bvh_bench::check::RefitCheck;

#[derive(Clone, Debug, Serialize)]
pub struct MraysPerS {
    pub coherent_closest: f64,
    pub incoherent_closest: f64,
    pub coherent_any: f64,
    pub incoherent_any: f64,
}

/// One implementation's measurements in one round.
#[derive(Clone, Debug, Serialize)]
pub struct Round {
    pub build_ms: f64,
    pub refit_ms: Option<f64>,
    pub mrays_per_s: MraysPerS,
    /// `None` where the peer has no refit.
    pub refit_check: Option<RefitCheck>,
}

/// Ours over a peer's, median of the per-round ratios (times: below 1 ours
/// is faster; rates: above 1 ours is faster).
#[derive(Clone, Debug, Serialize)]
pub struct Ratios {
    pub build: f64,
    pub refit: Option<f64>,
    pub mrays_per_s: MraysPerS,
}

/// One implementation's numbers on one mesh: medians over rounds.
#[derive(Clone, Debug, Serialize)]
pub struct ImplResult {
    #[serde(rename = "impl")]
    pub name: &'static str,
    /// `false`: the build runs on one thread whatever `threads` says.
    pub parallel_build: bool,
    pub build_ms: f64,
    pub refit_ms: Option<f64>,
    /// Median of the per-round build / refit ratios.
    pub build_over_refit: Option<f64>,
    pub sah_cost: Option<f64>,
    pub mrays_per_s: MraysPerS,
    pub bytes_per_triangle: f64,
    pub mismatch_fraction: f64,
    /// Summed over rounds; `None` where the peer has no refit.
    pub refit_check: Option<RefitCheck>,
    /// `None` for ours.
    pub vs_frusta: Option<Ratios>,
    pub rounds: Vec<Round>,
}

/// All implementations on one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct MeshReport {
    pub mesh: String,
    pub triangles: usize,
    pub threads: usize,
    /// Rays per ray set (coherent and incoherent each hold this many).
    pub rays: usize,
    pub results: Vec<ImplResult>,
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.prec$}"))
}

fn rates(m: &MraysPerS, prec: usize) -> [String; 4] {
    [
        m.coherent_closest,
        m.incoherent_closest,
        m.coherent_any,
        m.incoherent_any,
    ]
    .map(|v| format!("{v:.prec$}"))
}

const RATES: [&str; 4] = ["coh closest", "inc closest", "coh any", "inc any"];

/// The plain-text tables for one mesh: medians, then ours over each peer.
pub fn table(r: &MeshReport, rounds: usize) -> String {
    let header = ["impl", "thr", "build ms", "refit ms", "build/refit", "SAH"]
        .into_iter()
        .chain(RATES)
        .chain(["B/tri", "mismatch", "refit wrong"]);
    let mut rows = vec![header.map(String::from).collect::<Vec<_>>()];
    for x in &r.results {
        let threads = if x.parallel_build { r.threads } else { 1 };
        let mut row = vec![
            x.name.to_string(),
            threads.to_string(),
            format!("{:.2}", x.build_ms),
            opt(x.refit_ms, 2),
            opt(x.build_over_refit, 1),
            opt(x.sah_cost, 1),
        ];
        row.extend(rates(&x.mrays_per_s, 2));
        row.push(format!("{:.1}", x.bytes_per_triangle));
        row.push(format!("{:.2e}", x.mismatch_fraction));
        row.push(
            x.refit_check
                .map_or("-".into(), |c| format!("{}/{}", c.wrong, c.checked)),
        );
        rows.push(row);
    }
    let header = ["frusta / peer", "build", "refit"].into_iter().chain(RATES);
    let mut ratios = vec![header.map(String::from).collect::<Vec<_>>()];
    for x in &r.results {
        let Some(v) = &x.vs_frusta else { continue };
        let mut row = vec![
            x.name.to_string(),
            format!("{:.2}", v.build),
            opt(v.refit, 2),
        ];
        row.extend(rates(&v.mrays_per_s, 2));
        ratios.push(row);
    }
    format!(
        "mesh {}: {} triangles, {} rays per set, {} threads, medians of {rounds} rounds (ray rates in Mrays/s)\n{}\n\
         ours over each peer, median of per-round ratios (times: < 1 ours faster; rates: > 1 ours faster)\n{}",
        r.mesh,
        r.triangles,
        r.rays,
        r.threads,
        aligned(&rows, 1),
        aligned(&ratios, 1)
    )
}

/// Rows (the first is the header) as fixed-width text: the first `left`
/// columns left-aligned, the rest right-aligned, a rule under the header.
pub fn aligned(rows: &[Vec<String>], left: usize) -> String {
    let columns = rows.first().map_or(0, Vec::len);
    let widths: Vec<usize> = (0..columns)
        .map(|c| rows.iter().map(|r| r[c].len()).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    for (i, row) in rows.iter().enumerate() {
        let cells: Vec<String> = row
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(c, (s, w))| {
                if c < left {
                    format!("{s:<w$}")
                } else {
                    format!("{s:>w$}")
                }
            })
            .collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
        if i == 0 {
            out.push_str(&"-".repeat(widths.iter().sum::<usize>() + 2 * (widths.len() - 1)));
            out.push('\n');
        }
    }
    out
}
