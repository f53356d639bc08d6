//! The report's figures, drawn with plotters into SVG text for inlining in the page: error
//! histograms, error against each joint angle, the workspace coloured by error, and the
//! corrections of the diagnose findings.
//!
//! Scatter plots draw at most [`MAX_POINTS`] poses (every k-th, in file order) so that the page
//! stays small; the captions say so.

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

/// Most poses a scatter plot draws.
pub const MAX_POINTS: usize = 700;

const BEFORE: RGBColor = RGBColor(200, 80, 40);
const AFTER: RGBColor = RGBColor(30, 90, 180);

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plot: {e}")
}

/// Indices of at most [`MAX_POINTS`] of `n` items, evenly spaced.
pub fn thin(n: usize) -> Vec<usize> {
    let step = n.div_ceil(MAX_POINTS).max(1);
    (0..n).step_by(step).collect()
}

/// The drawn SVG for inlining: no XML namespace attribute (HTML puts `<svg>` in its namespace,
/// and the page holds no URL at all).
fn inline(svg: String) -> String {
    svg.replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1)
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo.is_finite() {
        (lo, if hi > lo { hi } else { lo + 1.0 })
    } else {
        (0.0, 1.0)
    }
}

/// One panel of a figure: the chart on `area` with its caption, ranges, axis descriptions and
/// a plain mesh (no minor grid), labels with few digits.
type Panel<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn panel<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    caption: &str,
    (x, y): (std::ops::Range<f64>, std::ops::Range<f64>),
    (x_desc, y_desc): (&str, &str),
) -> anyhow::Result<Panel<'a, 'b>> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 14))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(50)
        .build_cartesian_2d(x, y)
        .map_err(err)?;
    chart
        .configure_mesh()
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 12))
        .light_line_style(TRANSPARENT)
        .x_labels(5)
        .y_labels(5)
        .x_label_formatter(&|x| short(*x))
        .y_label_formatter(&|y| short(*y))
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// Histograms of the position errors (mm) of named series, one panel each on its own scale
/// (errors before calibration are ten times those after).
pub fn histogram(title: &str, series: &[(String, &[f64])]) -> anyhow::Result<String> {
    histogram_of(title, series, ("position error (mm)", "poses"))
}

/// [`histogram`] with its axes named `labels` (x, y).
pub fn histogram_of(
    title: &str,
    series: &[(String, &[f64])],
    labels: (&str, &str),
) -> anyhow::Result<String> {
    let bins = 30usize;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 300)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 16)).map_err(err)?;
        let panels = root.split_evenly((1, series.len().max(1)));
        for (k, ((name, v), area)) in series.iter().zip(panels.iter()).enumerate() {
            let (_, hi) = range(v.iter().copied());
            let w = hi / bins as f64;
            let mut c = vec![0usize; bins];
            for x in v.iter().filter(|x| x.is_finite()) {
                c[((x / w) as usize).min(bins - 1)] += 1;
            }
            let top = c.iter().copied().max().unwrap_or(1).max(1) as f64;
            let colour = if k == 0 { BEFORE } else { AFTER };
            let mut chart = panel(area, name, (0.0..hi * 1.02, 0.0..top * 1.08), labels)?;
            chart
                .draw_series(c.iter().enumerate().map(|(b, &n)| {
                    Rectangle::new(
                        [(b as f64 * w, 0.0), ((b + 1) as f64 * w, n as f64)],
                        colour.mix(0.75).filled(),
                    )
                }))
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(inline(svg))
}

/// An axis label: few digits.
fn short(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 {
        "0".into()
    } else if a >= 100.0 {
        format!("{x:.0}")
    } else if a >= 1.0 {
        format!("{x:.1}")
    } else {
        crate::output::numfmt::sig(x, 2)
    }
}

/// Position error (mm) after calibration against each joint angle (degrees), one panel per
/// joint: `q_deg[i]` are pose i's readings.
pub fn error_vs_joints(q_deg: &[Vec<f64>], after: &[f64]) -> anyhow::Result<String> {
    let joints = q_deg.first().map_or(0, Vec::len);
    anyhow::ensure!(joints > 0, "plot: no poses");
    let cols = 3usize;
    let rows = joints.div_ceil(cols);
    let idx = thin(q_deg.len());
    let (_, ymax) = range(idx.iter().map(|&i| after[i]));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 230 * rows as u32)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        for (j, area) in root
            .split_evenly((rows, cols))
            .iter()
            .enumerate()
            .take(joints)
        {
            let (lo, hi) = range(idx.iter().map(|&i| q_deg[i][j]));
            let mut chart = panel(
                area,
                "",
                (lo..hi, 0.0..ymax * 1.05),
                (&format!("q{} (°)", j + 1), "error after (mm)"),
            )?;
            chart
                .draw_series(
                    idx.iter().map(|&i| {
                        Circle::new((q_deg[i][j], after[i]), 1.6, AFTER.mix(0.6).filled())
                    }),
                )
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(inline(svg))
}

/// A view of the workspace: title, axis descriptions and the projection of a point.
type View = (
    &'static str,
    &'static str,
    &'static str,
    fn(&[f64; 3]) -> (f64, f64),
);

/// Where the error is large: the measured points in the robot's base frame from above (x, y)
/// and from the side (radius from the first axis, z), coloured by the error (mm) from dark
/// (small) to yellow (large).
pub fn workspace(points: &[[f64; 3]], errors: &[f64]) -> anyhow::Result<String> {
    let idx = thin(points.len());
    let (emin, emax) = range(idx.iter().map(|&i| errors[i]));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 430)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (plots, bar) = root.split_horizontally(780);
        let panels = plots.split_evenly((1, 2));
        let views: [View; 2] = [
            ("from above", "x (mm)", "y (mm)", |p| (p[0], p[1])),
            ("from the side", "radius from axis 1 (mm)", "z (mm)", |p| {
                (p[0].hypot(p[1]), p[2])
            }),
        ];
        for (area, (title, xl, yl, f)) in panels.iter().zip(views) {
            let xy: Vec<(f64, f64)> = idx.iter().map(|&i| f(&points[i])).collect();
            let (x0, x1) = range(xy.iter().map(|p| p.0));
            let (y0, y1) = range(xy.iter().map(|p| p.1));
            let pad = 0.05 * (x1 - x0).max(y1 - y0);
            let mut chart = panel(
                area,
                title,
                ((x0 - pad)..(x1 + pad), (y0 - pad)..(y1 + pad)),
                (xl, yl),
            )?;
            // Largest errors drawn last (on top).
            let mut order: Vec<usize> = (0..xy.len()).collect();
            order.sort_by(|a, b| errors[idx[*a]].total_cmp(&errors[idx[*b]]));
            chart
                .draw_series(order.iter().map(|&k| {
                    let c = ViridisRGB::get_color_normalized(errors[idx[k]], emin, emax);
                    Circle::new(xy[k], 2.5, c.filled())
                }))
                .map_err(err)?;
        }
        // The colour scale.
        let mut scale = ChartBuilder::on(&bar)
            .caption("error (mm)", ("sans-serif", 13))
            .margin_top(12)
            .margin_bottom(40)
            .margin_right(50)
            .y_label_area_size(44)
            .build_cartesian_2d(0.0..1.0, emin..emax)
            .map_err(err)?;
        scale
            .configure_mesh()
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 12))
            .disable_x_mesh()
            .disable_y_mesh()
            .disable_x_axis()
            .y_labels(6)
            .y_label_formatter(&|y| short(*y))
            .draw()
            .map_err(err)?;
        let steps = 60;
        scale
            .draw_series((0..steps).map(|k| {
                let a = emin + (emax - emin) * k as f64 / steps as f64;
                let b = emin + (emax - emin) * (k + 1) as f64 / steps as f64;
                Rectangle::new(
                    [(0.0, a), (1.0, b)],
                    ViridisRGB::get_color_normalized(a, emin, emax).filled(),
                )
            }))
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(inline(svg))
}

/// Lines `(x, y)` per named series (the diagnose findings' corrections and held-out RMS),
/// drawn by [`crate::output::plots::line_chart_svg`].
pub fn lines(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> anyhow::Result<String> {
    crate::output::plots::line_chart_svg(title, x_label, y_label, series, false, (640, 320))
        .map(inline)
}
