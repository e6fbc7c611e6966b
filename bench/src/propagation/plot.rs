//! `--plot`: recall against wall time, one series per scene and cell mode,
//! with axis labels and a legend. Text is drawn with DejaVu Sans compiled
//! into the binary (the `dejavu` crate, through plotters' `ab_glyph`), so
//! no system font is looked up and nothing is downloaded at run time.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::FontStyle;

use super::Row;

/// The font family the chart's text asks for.
const FONT: &str = "sans-serif";

/// Series colours, in `NAMES` order.
const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),  // shoebox: blue
    RGBColor(255, 127, 14),  // box-192: orange
    RGBColor(44, 160, 44),   // l-room: green
    RGBColor(214, 39, 40),   // two-rooms: red
    RGBColor(148, 103, 189), // hall-10k: purple
    RGBColor(140, 86, 75),   // hall-200k: brown
];

/// Tick labels of the log time axis: plain decimals.
fn time_label(ms: &f64) -> String {
    if *ms >= 1.0 {
        format!("{ms:.0}")
    } else {
        format!("{ms}")
    }
}

pub fn recall_vs_time(rows: &[Row], path: &Path) -> Result<(), String> {
    plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "plot: the bundled font does not parse".to_string())?;
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
        (
            10f64.powf(lo.log10().floor()),
            10f64.powf(hi.log10().ceil()),
        )
    };
    let lowest = pts.iter().filter_map(|r| r.recall).fold(1.0f64, f64::min);
    let bottom = ((lowest - 0.05) * 10.0).floor() / 10.0;
    let e = |e: DrawingAreaErrorKind<_>| format!("plot: {e:?}");
    let root = BitMapBackend::new(path, (1200, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Frustum tracing: recall against wall time (each point one order and N)",
            (FONT, 24),
        )
        .margin(16)
        // Room for the last time label, centred on the right edge.
        .margin_right(48)
        .x_label_area_size(56)
        .y_label_area_size(72)
        .build_cartesian_2d((lo..hi).log_scale(), bottom.max(0.0)..1.02f64)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("wall time of AcousticScene::find_paths, ms (log scale)")
        .y_desc("recall (vs independent reference, else exhaustive solver)")
        .x_label_formatter(&time_label)
        .y_label_formatter(&|y| format!("{y:.2}"))
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    for (i, name) in super::NAMES.iter().enumerate() {
        let c = COLORS[i];
        for (mode, label) in [("frusta", "conservative"), ("frusta-sampled", "sampled")] {
            let s: Vec<(f64, f64)> = pts
                .iter()
                .filter(|r| r.scene == *name && r.imp == mode)
                .map(|r| (r.time_ms, r.recall.unwrap_or(0.0)))
                .collect();
            if s.is_empty() {
                continue;
            }
            if mode == "frusta" {
                chart
                    .draw_series(s.iter().map(|&p| Circle::new(p, 5, c.filled())))
                    .map_err(e)?
                    .label(format!("{name}, {label}"))
                    .legend(move |(x, y)| Circle::new((x + 10, y), 5, c.filled()));
            } else {
                let stroke = c.stroke_width(2);
                chart
                    .draw_series(s.iter().map(|&p| TriangleMarker::new(p, 7, stroke)))
                    .map_err(e)?
                    .label(format!("{name}, {label}"))
                    .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 7, stroke));
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 16))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}
