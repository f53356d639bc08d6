//! The figure of `kinecal study` (like Jost et al. 2017's Figure 8): the KPI design's
//! improvement of the predicted TCP variance per manipulator, against each other design.

use plotters::prelude::*;
use std::path::Path;

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plot: {e}")
}

const COLOURS: [RGBColor; 4] = [
    RGBColor(200, 30, 30),
    RGBColor(30, 60, 200),
    RGBColor(240, 150, 150),
    RGBColor(140, 160, 240),
];

/// One series per comparison: improvement in percent (`1 − KPI/other`) per manipulator, in
/// manipulator order; filled markers for the first two series, hollow for the rest.
pub fn improvements(path: &Path, title: &str, series: &[(String, Vec<f64>)]) -> anyhow::Result<()> {
    let n = series.iter().map(|s| s.1.len()).max().unwrap_or(0);
    anyhow::ensure!(n > 0, "plot {}: no data", path.display());
    let vals = series
        .iter()
        .flat_map(|s| s.1.iter().copied())
        .filter(|v| v.is_finite());
    let (lo, hi) = vals.fold((0.0f64, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    // Drawn in memory, then written atomically (never a torn SVG).
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(14)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(
                0.0..(n as f64 + 1.0),
                (lo - 5.0).min(0.0)
                    ..crate::output::plots::legend_headroom(
                        (lo - 5.0).min(0.0),
                        (hi + 10.0).min(100.0),
                        series.len(),
                        520,
                    ),
            )
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc(
                "manipulator (upper arm 650…1100 mm, forearm 600…1000 mm; forearm varies fastest)",
            )
            .y_desc("TCP variance improvement of the KPI design (%)")
            .draw()
            .map_err(plot_err)?;
        for (k, (name, v)) in series.iter().enumerate() {
            let c = COLOURS[k % COLOURS.len()];
            let filled = k < 2;
            let style = if filled {
                c.filled()
            } else {
                c.stroke_width(1)
            };
            chart
                .draw_series(
                    v.iter()
                        .enumerate()
                        .filter(|(_, y)| y.is_finite())
                        .map(move |(i, y)| Circle::new((i as f64 + 1.0, *y), 3, style)),
                )
                .map_err(plot_err)?
                .label(name.as_str())
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, style));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    crate::output::plots::save_svg(path, &svg)?;
    Ok(())
}

/// The figure of the study's arms `results`: the KPI design's improvement over the random and
/// the D/O1 designs, with and without collision avoidance, written to `path`.
pub fn kpi_improvements(path: &Path, results: &[super::study::ArmResult]) -> anyhow::Result<()> {
    let series: Vec<(String, Vec<f64>)> = vec![
        (
            "vs random, with collision avoidance".into(),
            results
                .iter()
                .map(|r| 100.0 * (1.0 - r.settings[0].kpi / r.settings[0].random))
                .collect(),
        ),
        (
            "vs D/O1, with collision avoidance".into(),
            results
                .iter()
                .map(|r| 100.0 * (1.0 - r.settings[0].kpi / r.settings[0].d))
                .collect(),
        ),
        (
            "vs random, without".into(),
            results
                .iter()
                .map(|r| 100.0 * (1.0 - r.settings[1].kpi / r.settings[1].random))
                .collect(),
        ),
        (
            "vs D/O1, without".into(),
            results
                .iter()
                .map(|r| 100.0 * (1.0 - r.settings[1].kpi / r.settings[1].d))
                .collect(),
        ),
    ];
    improvements(
        path,
        &format!(
            "KPI design: TCP variance improvement, {} arms",
            results.len()
        ),
        &series,
    )?;
    Ok(())
}
