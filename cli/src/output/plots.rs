//! Small SVG charts (plotters): convergence curves and per-pose errors, like the paper's figures.

use plotters::prelude::*;
use std::path::Path;

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plot: {e}")
}

/// Writes a drawn SVG to `path` atomically ([`crate::output::atomic::write_atomic`]).
pub fn save_svg(path: &Path, svg: &str) -> anyhow::Result<()> {
    crate::output::atomic::write_atomic(path, svg.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))
}

const COLOURS: [RGBColor; 6] = [
    RED,
    BLUE,
    RGBColor(0, 140, 0),
    MAGENTA,
    RGBColor(230, 140, 0),
    BLACK,
];

/// The top of a y range `lo..hi` raised so that a legend of `rows` entries in the upper right
/// corner of a chart `height` pixels high lies above every point (plotters draws the legend
/// over the curves otherwise).
pub fn legend_headroom(lo: f64, hi: f64, rows: usize, height: u32) -> f64 {
    // The plotting area is the chart less the caption, margins and x labels (about 110 px);
    // a legend row is about 20 px, its box 16 px more.
    let plot = (f64::from(height) - 110.0).max(100.0);
    let legend = (rows as f64 * 20.0 + 16.0).min(plot * 0.6);
    let f = legend / plot;
    hi + (hi - lo) * f / (1.0 - f)
}

/// Lines `(x, y)` per named series; `log_y` plots log10 of y (for fitness that falls by decades).
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    log_y: bool,
) -> anyhow::Result<()> {
    // Drawn in memory, then written atomically (never a torn SVG).
    let svg = line_chart_svg(title, x_label, y_label, series, log_y, (900, 500))
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    crate::output::plots::save_svg(path, &svg)?;
    Ok(())
}

/// [`line_chart`] as SVG text of `size` pixels (for inlining in a page).
pub fn line_chart_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    log_y: bool,
    size: (u32, u32),
) -> anyhow::Result<String> {
    let tf = |y: f64| if log_y { y.max(1e-300).log10() } else { y };
    let pts: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.1.iter().map(|&(x, y)| (x, tf(y))))
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    anyhow::ensure!(!pts.is_empty(), "plot {title}: no data");
    let (x0, x1) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    let (y0, y1) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    let pad = ((y1 - y0) * 0.05).max(1e-9);
    // A range wider than a float holds (±1e308) would leave the axis without ticks to find.
    anyhow::ensure!(
        (x1 - x0).is_finite() && (y0 - pad).is_finite() && (y1 + pad).is_finite(),
        "plot {title}: the values span more than a number can hold"
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                x0..x1.max(x0 + 1.0),
                (y0 - pad)..legend_headroom(y0 - pad, y1 + pad, series.len(), size.1),
            )
            .map_err(plot_err)?;
        let y_desc = if log_y {
            format!("log10 {y_label}")
        } else {
            y_label.to_string()
        };
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_desc)
            .draw()
            .map_err(plot_err)?;
        for (k, (name, s)) in series.iter().enumerate() {
            let c = COLOURS[k % COLOURS.len()];
            chart
                .draw_series(LineSeries::new(
                    s.iter().map(|&(x, y)| (x, tf(y))),
                    c.stroke_width(2),
                ))
                .map_err(plot_err)?
                .label(name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// Per-pose position errors (mm) of several models on the same poses, as points.
pub fn pose_errors(path: &Path, title: &str, series: &[(String, Vec<f64>)]) -> anyhow::Result<()> {
    let ymax = series
        .iter()
        .flat_map(|s| s.1.iter().copied())
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.05;
    let n = series.iter().map(|s| s.1.len()).max().unwrap_or(1) as f64;
    // Drawn in memory, then written atomically (never a torn SVG).
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                0.0..n + 1.0,
                0.0..legend_headroom(0.0, ymax, series.len(), 500),
            )
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("pose")
            .y_desc("position error (mm)")
            .draw()
            .map_err(plot_err)?;
        for (k, (name, e)) in series.iter().enumerate() {
            let c = COLOURS[k % COLOURS.len()];
            chart
                .draw_series(
                    LineSeries::new(
                        e.iter().enumerate().map(|(i, v)| (i as f64 + 1.0, *v)),
                        c.stroke_width(1),
                    )
                    .point_size(3),
                )
                .map_err(plot_err)?
                .label(name.as_str())
                .legend(move |(x, y)| Circle::new((x + 10, y), 3, c.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    crate::output::plots::save_svg(path, &svg)?;
    Ok(())
}
