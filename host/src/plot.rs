//! Plots in the style of the paper's figures (SVG, no font dependency):
//! force amplitude on top, tip displacement below, against Omega/omega0, one
//! line per method; backbone and damping plots of the NMA.
use crate::results::MethodResult;
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;

const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 0, 0),
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

fn range(vals: impl Iterator<Item = f64>, pad: f64, zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if zero {
        lo = lo.min(0.0);
    }
    if hi <= lo {
        hi = lo + 1.0;
    }
    let d = (hi - lo) * pad;
    (if zero { lo } else { lo - d }, hi + d)
}

/// A time signal drawn in light grey under the envelopes (x = Omega/omega0).
pub struct Signal<'a> {
    pub eta: &'a [f64],
    pub force_n: &'a [f64],
    pub tip_m: &'a [f64],
}

/// Force (top) and tip displacement (bottom) against Omega/omega0.
pub fn sweep_plot(
    path: &Path,
    title: &str,
    omega0: f64,
    results: &[&MethodResult],
    signal: Option<Signal>,
) -> Result<()> {
    let root = SVGBackend::new(path, (900, 800)).into_drawing_area();
    root.fill(&WHITE)
        .map_err(|e| anyhow!("plot {}: {e}", path.display()))?;
    let (top, bottom) = root.split_vertically(400);
    let all_eta = results
        .iter()
        .flat_map(|r| r.envelope.omega_rad_s.iter().map(move |w| w / omega0));
    let (x0, x1) = range(all_eta, 0.0, false);
    for (panel, area) in [(0, &top), (1, &bottom)] {
        let get = |r: &MethodResult| -> Vec<f64> {
            if panel == 0 {
                r.envelope.force_amplitude_n.clone()
            } else {
                r.envelope.tip_amplitude_m.iter().map(|v| v * 1e3).collect()
            }
        };
        let mut ys: Vec<f64> = results.iter().flat_map(|r| get(r)).collect();
        if let Some(s) = &signal {
            if panel == 0 {
                ys.extend(s.force_n.iter().map(|v| v.abs()));
            } else {
                ys.extend(s.tip_m.iter().map(|v| v.abs() * 1e3));
            }
        }
        let (y0, y1) = range(ys.into_iter(), 0.05, true);
        let y0 = if signal.is_some() { -y1 } else { y0 };
        let ylabel = if panel == 0 {
            "force amplitude |F| [N]"
        } else {
            "tip displacement |q_tip| [mm]"
        };
        let mut chart = ChartBuilder::on(area)
            .caption(if panel == 0 { title } else { "" }, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| anyhow!("plot: {e}"))?;
        chart
            .configure_mesh()
            .x_desc("excitation frequency Omega/omega0 [-]")
            .y_desc(ylabel)
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(|e| anyhow!("plot: {e}"))?;
        if let Some(s) = &signal {
            let y: Vec<f64> = if panel == 0 {
                s.force_n.to_vec()
            } else {
                s.tip_m.iter().map(|v| v * 1e3).collect()
            };
            chart
                .draw_series(LineSeries::new(
                    s.eta.iter().zip(&y).map(|(&x, &y)| (x, y)),
                    RGBColor(200, 200, 200).stroke_width(1),
                ))
                .map_err(|e| anyhow!("plot: {e}"))?
                .label("reference (time signal)")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(200, 200, 200))
                });
        }
        for (i, r) in results.iter().enumerate() {
            let c = color(i);
            let y = get(r);
            let pts: Vec<(f64, f64, bool)> = r
                .envelope
                .omega_rad_s
                .iter()
                .zip(&y)
                .zip(stability(r))
                .filter(|((_, v), _)| v.is_finite())
                .map(|((&w, &v), stable)| (w / omega0, v, stable))
                .collect();
            // a steady-state branch: its unstable runs dashed (each run
            // shares its end points with the neighbouring ones)
            let mut start = 0;
            for k in 1..=pts.len() {
                if k < pts.len() && pts[k].2 == pts[start].2 {
                    continue;
                }
                let run: Vec<(f64, f64)> = pts[start..(k + 1).min(pts.len())]
                    .iter()
                    .map(|&(x, y, _)| (x, y))
                    .collect();
                if pts[start].2 {
                    chart
                        .draw_series(LineSeries::new(run, c.stroke_width(2)))
                        .map_err(|e| anyhow!("plot: {e}"))?;
                } else {
                    chart
                        .draw_series(DashedLineSeries::new(run, 6, 4, c.stroke_width(2)))
                        .map_err(|e| anyhow!("plot: {e}"))?;
                }
                start = k;
            }
            let label = if pts.iter().any(|p| !p.2) {
                format!("{} (unstable dashed)", r.name)
            } else {
                r.name.clone()
            };
            chart
                .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                .map_err(|e| anyhow!("plot: {e}"))?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        if panel == 0 {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(|e| anyhow!("plot: {e}"))?;
        }
    }
    root.present()
        .map_err(|e| anyhow!("plot {}: {e}", path.display()))?;
    Ok(())
}

/// Per envelope point whether it is drawn solid: the `stable` column of a
/// steady-state method (`hb`: 0 where Hill's method finds it unstable), all
/// true otherwise.
fn stability(r: &MethodResult) -> Vec<bool> {
    match r.extra_columns.iter().find(|(n, _)| n == "stable") {
        Some((_, v)) => v.iter().map(|&s| s != 0.0).collect(),
        None => vec![true; r.envelope.omega_rad_s.len()],
    }
}

/// One curve of an x-y plot.
pub struct Curve<'a> {
    pub label: String,
    pub x: &'a [f64],
    pub y: &'a [f64],
}

/// How [`xy_plot`] draws its curves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    /// Lines, x on a log10 axis.
    LinesLogX,
    /// Dots (steady-state branches: stable / unstable), y axis from zero.
    Dots,
}

/// A single-panel x-y plot (backbone, damping, steady-state branches).
pub fn xy_plot(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    curves: &[Curve],
    style: Style,
) -> Result<()> {
    let root = SVGBackend::new(path, (900, 500)).into_drawing_area();
    root.fill(&WHITE)
        .map_err(|e| anyhow!("plot {}: {e}", path.display()))?;
    let log_x = style == Style::LinesLogX;
    let tx = |v: f64| if log_x { v.log10() } else { v };
    let (x0, x1) = range(
        curves.iter().flat_map(|c| c.x.iter().map(|&v| tx(v))),
        0.02,
        false,
    );
    let (y0, y1) = range(
        curves.iter().flat_map(|c| c.y.iter().cloned()),
        0.05,
        style == Style::Dots,
    );
    let xdesc = if log_x {
        format!("log10 {xlabel}")
    } else {
        xlabel.to_string()
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| anyhow!("plot: {e}"))?;
    chart
        .configure_mesh()
        .x_desc(xdesc)
        .y_desc(ylabel)
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    for (i, c) in curves.iter().enumerate() {
        let col = color(i);
        let pts: Vec<(f64, f64)> =
            c.x.iter()
                .zip(c.y)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .map(|(&x, &y)| (tx(x), y))
                .collect();
        if style == Style::Dots {
            chart
                .draw_series(pts.into_iter().map(|p| Circle::new(p, 2, col.filled())))
                .map_err(|e| anyhow!("plot: {e}"))?
                .label(c.label.clone())
                .legend(move |(x, y)| Circle::new((x + 10, y), 3, col.filled()));
        } else {
            chart
                .draw_series(LineSeries::new(pts, col.stroke_width(2)))
                .map_err(|e| anyhow!("plot: {e}"))?
                .label(c.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                });
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    root.present()
        .map_err(|e| anyhow!("plot {}: {e}", path.display()))?;
    Ok(())
}
