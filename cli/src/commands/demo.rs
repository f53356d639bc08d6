//! `kinecal demo`: the BPNN-PSO paper's simulation end to end on built-in data
//! ([`crate::application::demo`]): the comparison, its figures and the calibration report of
//! the paper's method.

use crate::application::demo::{demo, Options};
use crate::output::plots;
use crate::reports::demo::DemoReport;
use crate::Stderr;
use std::path::PathBuf;

/// Arguments of `kinecal demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Seed of the errors, the poses, the noise and the swarms.
    #[arg(long, default_value_t = 2018)]
    pub seed: u64,
    /// Where the SVG figures go.
    #[arg(long, default_value = "out/demo")]
    pub out_dir: PathBuf,
    /// Iteration limit of the swarms.
    #[arg(long, default_value_t = 1000)]
    pub max_iterations: u32,
    /// Drift of alpha/theta (degrees, uniform ±) between the factory and the follow-up
    /// identification. BPNN-PSO's head start shrinks as the drift grows (README).
    #[arg(long, default_value_t = 0.002)]
    pub drift_deg: f64,
    /// Drift of a/d (mm, uniform ±) between the two identifications.
    #[arg(long, default_value_t = 0.01)]
    pub drift_mm: f64,
}

/// Runs the simulation: writes the figures and returns the comparison.
pub fn run(args: &Args) -> anyhow::Result<DemoReport> {
    let options = Options {
        seed: args.seed,
        max_iterations: args.max_iterations,
        drift_deg: args.drift_deg,
        drift_mm: args.drift_mm,
    };
    let d = demo(&options, &mut Stderr)?;
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.out_dir.display()))?;
    let fit_svg = args.out_dir.join("fitness.svg");
    plots::line_chart(
        &fit_svg,
        "Best fitness per iteration (follow-up identification)",
        "iteration",
        "fitness Σ|e|² (mm²)",
        &d.curves,
        true,
    )?;
    let err_svg = args.out_dir.join("pose_errors.svg");
    plots::pose_errors(
        &err_svg,
        "Position error on the 50 validation poses",
        &d.errors,
    )?;

    // The calibration report of the paper's method (BPNN-PSO) on these poses.
    let page = args.out_dir.join("report.html");
    let built = crate::report_html::build(crate::report_html::Inputs {
        robot_name: "ER20-C10 stand-in (kinecal demo)".into(),
        model_name: "identified by BPNN-PSO (follow-up identification)".into(),
        sources: crate::report_html::Sources {
            files: vec![(
                "data".into(),
                format!(
                    "kinecal demo --seed {}: {} identification and {} validation poses, \
                     {} mm tracker noise",
                    args.seed,
                    d.ident.len(),
                    d.valid.len(),
                    d.sigma
                ),
            )],
            units: "millimetres and degrees".into(),
            told: Vec::new(),
        },
        nominal: &d.nominal,
        base_fitted: false,
        tool_unknown: false,
        model: &d.model,
        start: &d.nominal,
        all_params: crate::calibration::model_params(&d.model, &[]),
        estimated: d.estimated.clone(),
        // The demo's model comes from BPNN-PSO, which has no prior.
        prior: vec![None; d.estimated.len()],
        ident: d.ident.clone(),
        valid: d.valid.clone(),
        pose_of: (0..d.ident.len()).collect(),
        ident_poses: d.ident.len(),
        valid_poses: d.valid.len(),
        names: Vec::new(),
        six_d: false,
        sigma: false,
        weighting: crate::calibration::weights::Weighting {
            balance: false,
            orientation_cv: false,
            params: d.estimated.len(),
        },
        limits_deg: vec![None; 6],
        stall_rms_mm: 5.0,
        outliers: None,
        diagnose: None,
        validation: None,
    })?;
    crate::output::atomic::write_atomic(&page, built.html.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", page.display()))?;
    eprintln!("wrote the calibration report {}", page.display());

    let mut report = d.report;
    report.figures = vec![fit_svg.display().to_string(), err_svg.display().to_string()];
    Ok(report)
}
