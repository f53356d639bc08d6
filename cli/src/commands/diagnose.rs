//! `kinecal diagnose`: reads the files, runs the discrepancy workflow on them
//! ([`crate::diagnose::workflow`]) and writes the model and the plots.

use super::inputs::InputArgs;
use super::Spinner;
use crate::diagnose::workflow::{self, check_plots_dir, Inputs, Options};
use crate::formats::observations::ObservationArgs;
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::reports::diagnose::DiagnoseReport;
use crate::{with_joints, Tell};
use std::path::PathBuf;

/// Arguments of `kinecal diagnose` (docs/formats.md, docs/walkthrough.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file, measurements (and the `--validate` file's) units.
    #[command(flatten)]
    pub input: InputArgs,
    /// Seed of the cross-validation folds.
    #[arg(long, default_value_t = workflow::DEFAULT_SEED)]
    pub seed: u64,
    /// Write the extended model (robot TOML with its effects).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write SVG plots (residuals against each named effect, per-pose errors) into this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Also keep poses out of the whole search and report the errors on them: `--holdout` a
    /// fraction (< 1) or a count (≥ 1), `--split` which ones (last, random, every:K).
    #[command(flatten)]
    pub holdout: super::inputs::HoldoutArgs,
    /// Also report the errors on a separate measurement file.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Cross-validation folds.
    #[arg(long, default_value_t = workflow::DEFAULT_FOLDS)]
    pub folds: usize,
    /// Family-wise false-alarm rate of each round.
    #[arg(long, default_value_t = workflow::DEFAULT_ALPHA)]
    pub alpha: f64,
    /// Highest joint-cyclic order in the catalogue.
    #[arg(long, default_value_t = workflow::DEFAULT_MAX_ORDER)]
    pub max_order: u16,
    /// Most effects to add.
    #[arg(long, default_value_t = workflow::DEFAULT_MAX_EFFECTS)]
    pub max_effects: usize,
    /// A geometric fit whose held-out RMS stays above this has not found the robot (units, a
    /// coupled joint, the tool, the base) unless the effects found leave a tenth of it or a
    /// fifth of this: otherwise nothing is diagnosed from it and the command exits 3.
    #[arg(long, default_value_t = crate::reports::diagnose::DEFAULT_STALL_RMS_MM)]
    pub stall_rms_mm: f64,
    /// Orientation and σ columns: how the search and the final fit to all observations weigh
    /// them.
    #[command(flatten)]
    pub obs: ObservationArgs,
}

impl Args {
    /// The workflow's options these arguments give (but the files).
    pub fn options(&self) -> Options {
        Options {
            seed: self.seed,
            holdout: self.holdout,
            folds: self.folds,
            alpha: self.alpha,
            max_order: self.max_order,
            max_effects: self.max_effects,
            stall_rms_mm: self.stall_rms_mm,
            obs: self.obs.clone(),
        }
    }
}

/// Runs the subcommand: the diagnosis (and the extended model and plots when asked for);
/// the report's `converged` is false when the geometric model does not fit the data.
pub fn run(args: &Args) -> anyhow::Result<DiagnoseReport> {
    crate::output::atomic::refuse_model_over_inputs(
        args.out.as_deref(),
        &args.input.robot,
        &args.input.data,
        args.validate.as_deref(),
    )?;
    let n = RobotFile::load(&args.input.robot)?.joint_count();
    with_joints!(n, N => run_with_joints::<N>(args))
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<DiagnoseReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    // The search (its linear screening, cross-validation and paired test) reads every
    // observation, weighted as identify weighs them at the geometric fit
    // (crate::diagnose::search_weights); the named effects are then fitted to all observations
    // as identify fits them (crate::diagnose::observations).
    let load =
        |p: &std::path::Path| super::inputs::load_observed(p, input, (&file, &nominal), &args.obs);
    check_plots_dir(args.plots.as_deref())?;
    let observed = load(&input.data)?;
    super::inputs::any_rows(&observed.poses, &input.data)?;
    let mut validate = None;
    if let Some(path) = &args.validate {
        let v = load(path).map_err(super::inputs::units_alike)?;
        super::inputs::any_rows(&v.poses, path)?;
        validate = Some((v, path.display().to_string()));
    }
    let inputs = Inputs {
        file,
        nominal,
        observed,
        data_origin: input.data.display().to_string(),
        validate,
    };
    let mut stages = Spinner::new("diagnose");
    let w = workflow::run(inputs, &args.options(), &mut stages)?;
    let mut report = DiagnoseReport::of_workflow(&w, args.stall_rms_mm);
    if let Some(e) = report.error_line(args.stall_rms_mm) {
        eprintln!("error: {e}");
    }
    let unfit = if w.acceptance.as_ref().is_some_and(|a| a.extrapolated) {
        Some("the model is not determined across the joint ranges")
    } else if w.held_out_worse() {
        Some("the model predicts the held-out poses worse than the nominal robot")
    } else if report.unexplained.is_some() {
        Some("an effect the data need was refused (implausible, or not told from another cause)")
    } else {
        (!report.converged).then_some("the geometric model is no calibration of these data")
    };
    report.out =
        crate::reports::model_out::save(args.out.as_deref(), unfit.map_or(Ok(&w.model), Err))?;
    if let Some(dir) = &args.plots {
        stages.stage("writing the plots");
        let files = crate::diagnose::residual_plots::write_all(dir, &w.diagnosis, &w.search)?;
        report.plots = Some(files.iter().map(|p| p.display().to_string()).collect());
    }
    Ok(report)
}
