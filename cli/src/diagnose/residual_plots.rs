//! Where model and data disagreed: SVG plots of the discrepancy search.
//!
//! - `effect_K_<id>_jointJ.svg`: the identified correction (degrees; a table's knots marked)
//!   against the effect's variable (the joint reading, or the lever arm for compliance), titled
//!   with the finding in words ([`crate::diagnose::explain`]), over the residual of every pose
//!   projected on the effect's direction (the joint-angle error `∂p/∂q_j · r / |∂p/∂q_j|²` that
//!   would explain it, or the tilt angle for axis-tilt): the fit with the effect plus its
//!   correction (the points the line should follow) and, fainter, the fit without it.
//! - `per_pose_errors.svg`: every pose's held-out error before (geometry only) and after (the
//!   extended model), from the same cross-validation folds.

use crate::diagnose::candidates::{fmt_deg, Candidate, CandidateKind};
use crate::diagnose::explain::{curve, explain, knots, per_pose, Explanation, PoseEffect};
use crate::diagnose::{distinct_figures, Diagnosis, Found};
use crate::output::numfmt::sig;
use crate::HostRobot;
use anyhow::anyhow;
use kinecal::Measurement;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Writes all plots of `d` into `dir` (created if needed); returns the files written.
pub fn write_all<const N: usize>(
    dir: &Path,
    d: &Diagnosis<N>,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| anyhow!("{}: cannot create: {e}", dir.display()))?;
    let mut out = Vec::new();
    let p = dir.join("per_pose_errors.svg");
    per_pose_errors(&p, &d.baseline_errors, &d.final_errors)?;
    out.push(p);
    for (k, f) in d.found.iter().enumerate() {
        // A joint-angle plot means nothing for what acts on no joint angle.
        if matches!(
            f.candidate.kind,
            CandidateKind::Thermal { .. } | CandidateKind::Drift { .. }
        ) {
            continue;
        }
        let p = dir.join(format!(
            "effect_{}_{}_joint{}.svg",
            k + 1,
            f.candidate.id(),
            f.candidate.joint + 1
        ));
        let e = explain(f, &d.model, data, d.noise_floor_mm);
        effect_residuals(&p, (f, &d.model), data, &e)?;
        out.push(p);
    }
    Ok(out)
}

/// Per-pose held-out errors (mm) before and after, from squared errors (mm²).
pub fn per_pose_errors(path: &Path, before_sq: &[f64], after_sq: &[f64]) -> anyhow::Result<()> {
    let b: Vec<(f64, f64)> = before_sq
        .iter()
        .enumerate()
        .map(|(i, e)| (i as f64 + 1.0, e.sqrt()))
        .collect();
    let a: Vec<(f64, f64)> = after_sq
        .iter()
        .enumerate()
        .map(|(i, e)| (i as f64 + 1.0, e.sqrt()))
        .collect();
    let ymax = b
        .iter()
        .chain(&a)
        .map(|p| p.1)
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.05;
    let rms = |v: &[f64]| (v.iter().sum::<f64>() / v.len().max(1) as f64).sqrt();
    // Drawn in memory, then written atomically (never a torn SVG).
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Held-out error of every pose (5-fold cross-validation)",
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(
                0.0..(b.len().max(1) as f64 + 1.0),
                // Room above the points for the legend (two entries).
                0.0..crate::output::plots::legend_headroom(0.0, ymax, 2, 500),
            )
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("pose (file order)")
            .y_desc("held-out 3-D error (mm)")
            .draw()
            .map_err(plot_err)?;
        let [rb, ra] = distinct_figures([rms(before_sq), rms(after_sq)]);
        chart
            .draw_series(b.iter().map(|p| Circle::new(*p, 2, RED.filled())))
            .map_err(plot_err)?
            .label(format!("geometry only: RMS {rb} mm"))
            .legend(|(x, y)| Circle::new((x, y), 3, RED.filled()));
        chart
            .draw_series(a.iter().map(|p| Circle::new(*p, 2, BLUE.filled())))
            .map_err(plot_err)?
            .label(format!("with the named effects: RMS {ra} mm"))
            .legend(|(x, y)| Circle::new((x, y), 3, BLUE.filled()));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    crate::output::plots::save_svg(path, &svg)?;
    Ok(())
}

/// The x variable of a candidate's plot at one pose: the joint reading (degrees), or the
/// lever arm (m) for compliance.
fn variable(c: &Candidate, p: &PoseEffect) -> f64 {
    match c.kind {
        CandidateKind::Compliance => p.tau,
        _ => p.q.to_degrees(),
    }
}

/// Values `lo..hi` holding the middle 98 % of `ys` (all of them when there are few), so that
/// the few poses where the joint barely moves the tool (huge projected errors) do not flatten
/// the plot.
fn robust_span(ys: &[f64]) -> (f64, f64) {
    let mut v: Vec<f64> = ys.iter().copied().filter(|y| y.is_finite()).collect();
    if v.is_empty() {
        return (f64::INFINITY, f64::NEG_INFINITY);
    }
    v.sort_by(f64::total_cmp);
    let cut = if v.len() >= 50 { v.len() / 100 } else { 0 };
    (v[cut], v[v.len() - 1 - cut])
}

/// The identified correction (line; a table's knots marked) against the effect's variable
/// (the joint reading in degrees, or the lever arm for compliance; axis-tilt: the tilt, flat),
/// in degrees, with the data's residuals projected on the joint behind it: every pose's
/// residual of the fit with the effect plus the correction there (what the correction should
/// follow), and, fainter, the residual of the fit without it. Titled with the explanation's
/// first clause.
pub fn effect_residuals<const N: usize>(
    path: &Path,
    (f, model): (&Found<N>, &HostRobot<N>),
    data: &[Measurement<f64, N>],
    e: &Explanation,
) -> anyhow::Result<()> {
    let c = &f.candidate;
    let j = c.joint;
    let values = c.values(model);
    let before: Vec<(f64, f64)> = per_pose(c, &f.before, data)
        .iter()
        .map(|p| (variable(c, p), p.residual.to_degrees()))
        .collect();
    let after_poses = per_pose(c, model, data);
    let partial: Vec<(f64, f64)> = after_poses
        .iter()
        .map(|p| (variable(c, p), (p.residual + p.dq).to_degrees()))
        .collect();
    let (xmin, xmax) = partial
        .iter()
        .map(|p| p.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    let (xmin, xmax) = if xmax > xmin {
        (xmin, xmax)
    } else if xmin.is_finite() {
        (xmin - 1.0, xmin + 1.0)
    } else {
        (-1.0, 1.0)
    };
    let v0 = values.first().copied().unwrap_or(0.0);
    let curve: Vec<(f64, f64)> = match c.kind {
        CandidateKind::Compliance => (0..=400)
            .map(|k| {
                let x = xmin + (xmax - xmin) * k as f64 / 400.0;
                (x, c.correction(&values, 0.0, x).to_degrees())
            })
            .collect(),
        CandidateKind::Tilt => vec![(xmin, v0.to_degrees()), (xmax, v0.to_degrees())],
        _ => curve(c, &values, xmin.to_radians(), xmax.to_radians())
            .into_iter()
            .map(|(q, dq)| (q.to_degrees(), dq.to_degrees()))
            .collect(),
    };
    let knot_marks: Vec<(f64, f64)> = knots(c, &values, xmin.to_radians(), xmax.to_radians())
        .into_iter()
        .map(|(q, v)| (q.to_degrees(), v.to_degrees()))
        .collect();
    let points: Vec<f64> = before.iter().chain(&partial).map(|p| p.1).collect();
    let (plo, phi) = robust_span(&points);
    let (ymin, ymax) = curve
        .iter()
        .map(|p| p.1)
        .fold((plo, phi), |(a, b), y| (a.min(y), b.max(y)));
    let (ymin, ymax) = if ymax > ymin {
        (ymin, ymax)
    } else if ymin.is_finite() {
        (ymin - 1e-3, ymin + 1e-3)
    } else {
        (-1e-3, 1e-3)
    };
    let pad = (ymax - ymin) * 0.05;
    let (ylo, yhi) = (ymin - pad, ymax + pad);
    let inside = |p: &&(f64, f64)| p.1 >= ylo && p.1 <= yhi;
    // "(12 beyond the axis)" for the points of a series left out.
    let clipped = |series: &[(f64, f64)]| -> String {
        match series.iter().filter(|p| !inside(p)).count() {
            0 => String::new(),
            k => format!(" ({k} beyond the axis)"),
        }
    };
    let x_desc = match c.kind {
        CandidateKind::Compliance => format!("lever arm τ{} (m)", j + 1),
        _ => format!("joint {} reading (°)", j + 1),
    };
    let y_desc = match c.kind {
        CandidateKind::Tilt => format!("tilt of axis {} (°)", j + 1),
        _ => format!("joint {} angle error (°)", j + 1),
    };
    let (ptp, tool) = (
        e.peak_to_peak_deg
            .map_or_else(String::new, |d| fmt_deg(d.to_radians())),
        distinct_figures([e.tool_rms_mm, e.tool_max_mm]),
    );
    // Drawn in memory, then written atomically (never a torn SVG).
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 620)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let (top, chart_area) = root.split_vertically(56);
        top.titled(&e.short, ("sans-serif", 17)).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&chart_area)
            .caption(
                {
                    let [before, after] = distinct_figures([f.before_rms_mm, f.validation_rms_mm]);
                    format!(
                        "{}: {ptp} peak to peak, {} mm RMS ({} mm max) at the tool; held-out RMS {before} → {after} mm",
                        c.label(),
                        tool[0],
                        tool[1]
                    )
                },
                ("sans-serif", 14),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(
                xmin..xmax,
                // Room above the points for the legend (up to four entries).
                ylo..crate::output::plots::legend_headroom(ylo, yhi, 4, 620 - 56),
            )
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            // A tick at zero computed as 1e-18 prints as 0.
            .y_label_formatter(&|y| {
                sig(
                    if y.abs() < 1e-9 * (yhi - ylo) {
                        0.0
                    } else {
                        *y
                    },
                    3,
                )
            })
            .draw()
            .map_err(plot_err)?;
        chart
            .draw_series(
                before
                    .iter()
                    .filter(inside)
                    .map(|p| Circle::new(*p, 2, RED.mix(0.35).filled())),
            )
            .map_err(plot_err)?
            .label(format!(
                "residuals of the fit without the effect, as joint-angle error{}",
                clipped(&before)
            ))
            .legend(|(x, y)| Circle::new((x, y), 3, RED.mix(0.35).filled()));
        chart
            .draw_series(
                partial
                    .iter()
                    .filter(inside)
                    .map(|p| Circle::new(*p, 2, BLUE.mix(0.6).filled())),
            )
            .map_err(plot_err)?
            .label(format!(
                "residuals of the fit with the effect plus its correction{}",
                clipped(&partial)
            ))
            .legend(|(x, y)| Circle::new((x, y), 3, BLUE.mix(0.6).filled()));
        chart
            .draw_series(LineSeries::new(curve, BLACK.stroke_width(2)))
            .map_err(plot_err)?
            .label("identified correction")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.stroke_width(2)));
        if !knot_marks.is_empty() {
            chart
                .draw_series(
                    knot_marks
                        .iter()
                        .filter(inside)
                        .map(|p| Cross::new(*p, 5, BLACK.stroke_width(2))),
                )
                .map_err(plot_err)?
                .label("table knots")
                .legend(|(x, y)| Cross::new((x, y), 4, BLACK.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.7))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    crate::output::plots::save_svg(path, &svg)?;
    Ok(())
}

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plot: {e}")
}
