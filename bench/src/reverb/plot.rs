//! `reverb --plot`: a room's impulse responses (frusta's hybrid and
//! pyroomacoustics') and their energy decay curves per band beside the
//! exact image sources'. Text is drawn with the DejaVu font compiled into
//! the binary, as in the propagation plot.

use std::path::Path;

use frusta_engine::scene::{BAND_COUNT, OCTAVE_BANDS_HZ};
use plotters::prelude::*;
use plotters::style::FontStyle;

const FONT: &str = "sans-serif";
/// Impulse responses are drawn at 48 kHz.
const RATE: f64 = 48_000.0;
/// Bands drawn, by index into [`OCTAVE_BANDS_HZ`].
const BANDS: [usize; 4] = [1, 3, 5, 7];
const COLORS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
];

/// What the plot draws of one run; echograms are (time s, energy).
#[derive(Default)]
pub struct Curves {
    pub frusta_ir: Vec<f32>,
    /// Per band of [`OCTAVE_BANDS_HZ`].
    pub frusta: Vec<Vec<(f64, f64)>>,
    pub peer_ir: Option<Vec<f32>>,
    pub peer: Option<Vec<Vec<(f64, f64)>>>,
    pub exact: Option<Vec<Vec<(f64, f64)>>>,
}

/// The Schroeder curve of an echogram in dB, on a 5 ms grid from 0 to
/// `until_s`, down to −80 dB.
fn decay_curve(echogram: &[(f64, f64)], until_s: f64) -> Vec<(f64, f64)> {
    let step = 5e-3;
    let n = (until_s / step) as usize + 1;
    let mut bins = vec![0.0; n];
    for &(t, e) in echogram {
        if let Some(b) = bins.get_mut((t / step) as usize) {
            *b += e;
        }
    }
    let total: f64 = bins.iter().sum();
    let mut remaining = total;
    let mut out = Vec::with_capacity(n);
    for (k, e) in bins.iter().enumerate() {
        if total > 0.0 && remaining > 1e-8 * total {
            out.push((k as f64 * step, 10.0 * (remaining / total).log10()));
        }
        remaining -= e;
    }
    out
}

pub fn decay(scene: &str, curves: &Curves, path: &Path) -> Result<(), String> {
    plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "plot: the bundled font does not parse".to_string())?;
    let e = |e: DrawingAreaErrorKind<_>| format!("plot: {e:?}");
    let root = BitMapBackend::new(path, (1200, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let (top, bottom) = root.split_vertically(360);
    let until = curves.frusta_ir.len() as f64 / RATE;
    let peak = curves
        .frusta_ir
        .iter()
        .chain(curves.peer_ir.iter().flatten())
        .fold(0.0f32, |m, v| m.max(v.abs()));
    let peak = f64::from(peak.max(1e-9));
    let mut ir = ChartBuilder::on(&top)
        .caption(
            format!("{scene}: impulse responses (pyroomacoustics shifted down)"),
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..until, -2.2 * peak..1.1 * peak)
        .map_err(e)?;
    ir.configure_mesh()
        .x_desc("time, s")
        .y_desc("pressure")
        .label_style((FONT, 14))
        .draw()
        .map_err(e)?;
    let wave = |signal: &[f32], offset: f64| -> Vec<(f64, f64)> {
        signal
            .iter()
            .enumerate()
            .map(|(i, &v)| (i as f64 / RATE, f64::from(v) + offset))
            .collect()
    };
    ir.draw_series(LineSeries::new(wave(&curves.frusta_ir, 0.0), COLORS[0]))
        .map_err(e)?
        .label("frusta (exact paths + tail)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], COLORS[0]));
    if let Some(peer) = &curves.peer_ir {
        ir.draw_series(LineSeries::new(wave(peer, -1.2 * peak), COLORS[2]))
            .map_err(e)?
            .label("pyroomacoustics hybrid")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], COLORS[2]));
    }
    ir.configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 14))
        .draw()
        .map_err(e)?;
    let mut edc = ChartBuilder::on(&bottom)
        .caption(
            "Energy decay per band: frusta solid, pyroomacoustics dashed, exact image sources dotted",
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..until, -80.0..0.0)
        .map_err(e)?;
    edc.configure_mesh()
        .x_desc("time, s")
        .y_desc("level, dB")
        .label_style((FONT, 14))
        .draw()
        .map_err(e)?;
    for (&band, &color) in BANDS.iter().zip(&COLORS) {
        if band >= BAND_COUNT {
            continue;
        }
        let frusta = decay_curve(&curves.frusta[band], until);
        edc.draw_series(LineSeries::new(frusta, color.stroke_width(2)))
            .map_err(e)?
            .label(format!("{} Hz", OCTAVE_BANDS_HZ[band]))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color));
        if let Some(peer) = &curves.peer {
            let curve = decay_curve(&peer[band], until);
            edc.draw_series(DashedLineSeries::new(curve, 8, 6, color.into()))
                .map_err(e)?;
        }
        if let Some(exact) = &curves.exact {
            let curve = decay_curve(&exact[band], until);
            edc.draw_series(DashedLineSeries::new(curve, 2, 4, color.into()))
                .map_err(e)?;
        }
    }
    edc.configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font((FONT, 14))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
}
