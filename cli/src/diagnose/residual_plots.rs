//! Where model and data disagreed: SVG plots of the discrepancy search.
//!
//! - `effect_K_<id>_jointJ.svg`: the residual of every pose projected on the named effect's
//!   direction (the joint-angle error `∂p/∂q_j · r / |∂p/∂q_j|²` that would explain it, or the
//!   tilt angle for axis-tilt), against the effect's variable (the joint reading, or the lever
//!   arm for compliance), before and after the effect was added, with the identified
//!   correction drawn over it.
//! - `per_pose_errors.svg`: every pose's held-out error before (geometry only) and after (the
//!   extended model), from the same cross-validation folds.

use crate::diagnose::candidates::{Candidate, CandidateKind};
use crate::diagnose::{distinct_figures, Diagnosis, Found};
use crate::VCAP;
use anyhow::anyhow;
use kinecal::model::param::Param;
use kinecal::{ForwardKinematics, Measurement, Robot};
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
        let p = dir.join(format!(
            "effect_{}_{}_joint{}.svg",
            k + 1,
            f.candidate.id(),
            f.candidate.joint + 1
        ));
        effect_residuals(&p, f, data)?;
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
            .build_cartesian_2d(0.0..(b.len().max(1) as f64 + 1.0), 0.0..ymax)
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

/// The x variable of a candidate's plot at one pose, and its axis title.
fn variable(c: &Candidate, q: f64, tau: f64) -> f64 {
    match c.kind {
        CandidateKind::Compliance => tau,
        _ => q.to_degrees(),
    }
}

/// Residuals projected on the effect's direction, before and after (mdeg), with the
/// identified correction.
pub fn effect_residuals<const N: usize>(
    path: &Path,
    f: &Found<N>,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<()> {
    let c = &f.candidate;
    let j = c.joint;
    let project = |robot: &Robot<f64, N, VCAP>| -> Vec<(f64, f64)> {
        let mut fk = ForwardKinematics::new();
        data.iter()
            .map(|m| {
                let r = m.point - fk.compute(robot, &m.q);
                let tau = fk.lever_arms()[j];
                let dir = match c.kind {
                    CandidateKind::Tilt => {
                        fk.column(robot, Param::Beta(j as u8)).unwrap_or_default()
                    }
                    _ => fk.reading_column(robot, j),
                };
                let n2 = dir.norm_squared();
                let e = if n2 > 0.0 { dir.dot(&r) / n2 } else { 0.0 };
                (variable(c, m.q[j], tau), e.to_degrees() * 1e3)
            })
            .collect()
    };
    let before = project(&f.before);
    let after = project(&f.after);
    let values = c.values(&f.after);
    let (xmin, xmax) = before
        .iter()
        .map(|p| p.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    let (xmin, xmax) = if xmax > xmin {
        (xmin, xmax)
    } else {
        (xmin - 1.0, xmin + 1.0)
    };
    let curve: Vec<(f64, f64)> = if c.kind == CandidateKind::Tilt {
        Vec::new()
    } else {
        (0..=400)
            .map(|k| {
                let x = xmin + (xmax - xmin) * k as f64 / 400.0;
                let dq = match c.kind {
                    CandidateKind::Compliance => c.correction(&values, 0.0, x),
                    _ => c.correction(&values, x.to_radians(), 0.0),
                };
                (x, dq.to_degrees() * 1e3)
            })
            .collect()
    };
    let ys = before.iter().chain(&after).chain(&curve).map(|p| p.1);
    let (ymin, ymax) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    let pad = ((ymax - ymin) * 0.05).max(1e-6);
    let x_desc = match c.kind {
        CandidateKind::Compliance => format!("lever arm τ{} (m)", j + 1),
        _ => format!("joint {} reading (°)", j + 1),
    };
    let y_desc = match c.kind {
        CandidateKind::Tilt => format!("residual along the tilt of axis {} (mdeg)", j + 1),
        _ => format!("joint {} angle error explaining the residual (mdeg)", j + 1),
    };
    // Drawn in memory, then written atomically (never a torn SVG).
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                {
                    let [before, after] = distinct_figures([f.before_rms_mm, f.validation_rms_mm]);
                    format!("{}: held-out RMS {before} → {after} mm", c.label())
                },
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(xmin..xmax, (ymin - pad)..(ymax + pad))
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(plot_err)?;
        chart
            .draw_series(
                before
                    .iter()
                    .map(|p| Circle::new(*p, 2, RED.mix(0.7).filled())),
            )
            .map_err(plot_err)?
            .label("before (model without the effect)")
            .legend(|(x, y)| Circle::new((x, y), 3, RED.filled()));
        chart
            .draw_series(
                after
                    .iter()
                    .map(|p| Circle::new(*p, 2, BLUE.mix(0.7).filled())),
            )
            .map_err(plot_err)?
            .label("after (with the effect)")
            .legend(|(x, y)| Circle::new((x, y), 3, BLUE.filled()));
        if !curve.is_empty() {
            chart
                .draw_series(LineSeries::new(curve, BLACK.stroke_width(2)))
                .map_err(plot_err)?
                .label("identified correction")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], BLACK.stroke_width(2))
                });
        }
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

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plot: {e}")
}
