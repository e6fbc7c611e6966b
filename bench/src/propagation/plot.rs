//! `--plot`: recall against wall time, one series per scene.
//!
//! No text is drawn (plotters' font backends need system fonts or a font
//! download); the colours are listed on stderr and in `bench/README.md`.

use std::path::Path;

use plotters::prelude::*;

use super::Row;

/// Series colours, in `NAMES` order.
const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),  // shoebox: blue
    RGBColor(255, 127, 14),  // box-192: orange
    RGBColor(44, 160, 44),   // l-room: green
    RGBColor(214, 39, 40),   // two-rooms: red
    RGBColor(148, 103, 189), // hall-10k: purple
    RGBColor(140, 86, 75),   // hall-200k: brown
];
pub const COLOR_NAMES: [&str; 6] = ["blue", "orange", "green", "red", "purple", "brown"];

pub fn recall_vs_time(rows: &[Row], path: &Path) -> Result<(), String> {
    let pts: Vec<&Row> = rows
        .iter()
        .filter(|r| r.imp.starts_with("frusta") && r.recall.is_some() && r.time_ms > 0.0)
        .collect();
    let (lo, hi) = pts.iter().fold((f64::MAX, f64::MIN), |(lo, hi), r| {
        (lo.min(r.time_ms), hi.max(r.time_ms))
    });
    let (lo, hi) = if pts.is_empty() {
        (0.1, 10.0)
    } else {
        (lo / 1.5, hi * 1.5)
    };
    let e = |e: DrawingAreaErrorKind<_>| format!("plot: {e:?}");
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let area = root.margin(20, 20, 20, 20);
    let mut chart = ChartBuilder::on(&area)
        .build_cartesian_2d((lo..hi).log_scale(), 0.0f64..1.05)
        .map_err(e)?;
    // Frame and guide lines at recall 0.5, 0.9 and 1 (no labels).
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(lo, 0.0), (hi, 1.05)],
            BLACK,
        )))
        .map_err(e)?;
    for y in [0.5, 0.9, 1.0] {
        chart
            .draw_series(LineSeries::new([(lo, y), (hi, y)], RGBColor(200, 200, 200)))
            .map_err(e)?;
    }
    // Decade ticks on the time axis.
    let mut t = 10f64.powf(lo.log10().floor());
    while t < hi {
        if t > lo {
            chart
                .draw_series(LineSeries::new([(t, 0.0), (t, 0.03)], BLACK))
                .map_err(e)?;
        }
        t *= 10.0;
    }
    for (i, name) in super::NAMES.iter().enumerate() {
        let mut s: Vec<(f64, f64)> = pts
            .iter()
            .filter(|r| r.scene == *name)
            .map(|r| (r.time_ms, r.recall.unwrap_or(0.0)))
            .collect();
        if s.is_empty() {
            continue;
        }
        s.sort_by(|a, b| a.0.total_cmp(&b.0));
        let c = COLORS[i];
        chart
            .draw_series(s.iter().map(|&p| Circle::new(p, 4, c.filled())))
            .map_err(e)?;
        chart.draw_series(LineSeries::new(s, c)).map_err(e)?;
        eprintln!("plot: {name} = {}", COLOR_NAMES[i]);
    }
    root.present().map_err(e)?;
    Ok(())
}
