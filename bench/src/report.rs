//! Results: the aligned text table and the JSON object.

use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct MraysPerS {
    pub coherent_closest: f64,
    pub incoherent_closest: f64,
    pub coherent_any: f64,
    pub incoherent_any: f64,
}

/// One implementation's numbers on one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct ImplResult {
    #[serde(rename = "impl")]
    pub name: &'static str,
    pub build_ms: f64,
    pub refit_ms: Option<f64>,
    pub sah_cost: Option<f64>,
    pub mrays_per_s: MraysPerS,
    pub bytes_per_triangle: f64,
    pub mismatch_fraction: f64,
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

/// The plain-text table for one mesh.
pub fn table(r: &MeshReport) -> String {
    let header = [
        "impl",
        "build ms",
        "refit ms",
        "SAH",
        "coh closest",
        "inc closest",
        "coh any",
        "inc any",
        "B/tri",
        "mismatch",
    ];
    let mut rows = vec![header.map(String::from).to_vec()];
    for x in &r.results {
        let m = &x.mrays_per_s;
        rows.push(vec![
            x.name.to_string(),
            format!("{:.2}", x.build_ms),
            opt(x.refit_ms, 2),
            opt(x.sah_cost, 1),
            format!("{:.2}", m.coherent_closest),
            format!("{:.2}", m.incoherent_closest),
            format!("{:.2}", m.coherent_any),
            format!("{:.2}", m.incoherent_any),
            format!("{:.1}", x.bytes_per_triangle),
            format!("{:.2e}", x.mismatch_fraction),
        ]);
    }
    format!(
        "mesh {}: {} triangles, {} rays per set, {} threads (ray rates in Mrays/s)\n{}",
        r.mesh,
        r.triangles,
        r.rays,
        r.threads,
        aligned(&rows, 1)
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
