//! `kinecal diagnose`: the discrepancy workflow (see [`crate::diagnose`]): fits the geometry,
//! finds where model and data disagree, names the missing effects, adds them and shows the
//! held-out gap shrink.

use super::inputs::InputArgs;
use crate::calibration::weights::{self, Weighting};
use crate::diagnose::linear::squared_errors;
use crate::diagnose::observations::{fit_all_observations, FullFit, Observations};
use crate::diagnose::search_weights::search_weights;
use crate::diagnose::{
    diagnose_with_progress, fit_geometry, observation_params, Config, Diagnosis, Progress,
};
use crate::formats::observations::{observe, pose_of, ObservationArgs, Observed};
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::output::numfmt::sig;
use crate::reports::diagnose::ObservationsReport;
use crate::reports::diagnose::{DiagnoseReport, HoldoutReport};
use crate::reports::identify::{ObservationSummary, PointResiduals};
use crate::with_joints;
use crate::VCAP;
use kinecal::model::param::ParamSet;
use kinecal::{Measurement, Robot};
use std::path::PathBuf;

/// Arguments of `kinecal diagnose` (docs/formats.md, docs/walkthrough.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file, measurements (and the `--validate` file's) units.
    #[command(flatten)]
    pub input: InputArgs,
    /// Seed of the cross-validation folds.
    #[arg(long, default_value_t = 0)]
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
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Family-wise false-alarm rate of each round.
    #[arg(long, default_value_t = 0.05)]
    pub alpha: f64,
    /// Highest joint-cyclic order in the catalogue.
    #[arg(long, default_value_t = 3)]
    pub max_order: u16,
    /// Most effects to add.
    #[arg(long, default_value_t = 12)]
    pub max_effects: usize,
    /// A geometric fit whose held-out RMS stays above this has not found the robot (units, a
    /// coupled joint, the tool, the base): nothing is diagnosed from it and the command exits 3.
    #[arg(long, default_value_t = crate::reports::diagnose::DEFAULT_STALL_RMS_MM)]
    pub stall_rms_mm: f64,
    /// Orientation and σ columns: how the search and the final fit to all observations weigh
    /// them.
    #[command(flatten)]
    pub obs: ObservationArgs,
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

/// Progress on stderr, one stage at a time: a spinner with the stage and the time spent (shown
/// only when stderr is a terminal, as PSO's and `study`'s bars).
struct Stages(indicatif::ProgressBar);

impl Stages {
    fn start() -> Self {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template("diagnose {spinner} {msg} {elapsed}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        Self(bar)
    }
    fn stage(&self, what: &str) {
        self.0.set_message(what.to_string());
    }
}

impl Drop for Stages {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<DiagnoseReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    // The search (its linear screening, cross-validation and paired test) reads every
    // observation, weighted as identify weighs them at the geometric fit
    // (crate::diagnose::search_weights); the named effects are then fitted to all observations
    // as identify fits them (crate::diagnose::observations).
    let load = |p: &std::path::Path| -> anyhow::Result<Observed<N>> {
        let ds = crate::formats::loading::load_measurements(
            p,
            &input.units,
            &nominal,
            file.base_known(),
        )?;
        observe(&ds, &file, &args.obs, &p.display().to_string())
    };
    if let Some(dir) = args.plots.as_deref().filter(|d| d.exists() && !d.is_dir()) {
        crate::refuse!(
            "--plots {}: names a file, not a directory: give a directory for the SVG plots",
            dir.display()
        );
    }
    let observed = load(&input.data)?;
    super::inputs::any_rows(&observed.poses, &input.data)?;
    let validate = match &args.validate {
        Some(path) => {
            let v = load(path)?;
            super::inputs::any_rows(&v.poses, path)?;
            Some(v)
        }
        None => None,
    };
    let kind = observed.kind();
    let (search_poses, held_poses) =
        super::inputs::split_sets(observed, validate, (&args.holdout, args.seed))?;
    let observed = kind;
    let full = observed.six_d || observed.sigma || observed.names.len() > 1;
    let (nominal, search, held) = search_observations(
        &nominal,
        &file,
        &observed,
        &args.obs,
        (&search_poses, &held_poses),
    )?;
    if full {
        eprintln!(
            "note: {}: the search for missing effects reads every observation ({}), weighted \
             as identify weighs them at the geometric fit (σ and error floors; figures per \
             observation, the points' in mm); what it names is then fitted to all observations \
             as identify fits them, and that model is the one reported under `observations` \
             and written by --out",
            input.data.display(),
            [
                Some("positions"),
                observed.six_d.then_some("orientations"),
                observed.sigma.then_some("the stated σ"),
                (observed.names.len() > 1).then_some("every reflector"),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(", ")
        );
    }
    crate::check_count("--folds", args.folds, 2, search.len().max(2))?;
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        crate::refuse!("--alpha {}: must be between 0 and 1", args.alpha);
    }
    crate::check_count(
        "--max-order",
        usize::from(args.max_order),
        1,
        usize::from(crate::MAX_CYCLIC_ORDER),
    )?;
    crate::check_count("--max-effects", args.max_effects, 0, 64)?;
    crate::check_positive("--stall-rms-mm", args.stall_rms_mm, 1e6)?;
    let mut cfg = Config {
        folds: args.folds,
        alpha: args.alpha,
        max_effects: args.max_effects,
        seed: args.seed,
        ..Config::default()
    };
    cfg.catalogue.max_cyclic_order = args.max_order;
    let stages = Stages::start();
    let (poses, folds) = (search.len(), cfg.folds);
    let mut d = diagnose_with_progress(
        &nominal,
        file.base_known(),
        &file.tilt_joints(),
        &search,
        &cfg,
        &mut |p| {
            stages.stage(&match p {
                Progress::Geometry => format!("fitting the geometry ({poses} poses)"),
                Progress::Baseline => format!("held-out errors of the geometry ({folds} folds)"),
                Progress::Screen { round, candidates } => {
                    format!("round {round}: screening {candidates} candidates")
                }
                Progress::Refit { round, families } => {
                    format!("round {round}: refitting the best {families} in {folds} folds")
                }
            })
        },
    )?;
    let holdout = if held.is_empty() {
        None
    } else {
        stages.stage(&format!("errors on the {} held-out poses", held.len()));
        // The starting model: the nominal robot placed as identify places it.
        let mut start = nominal.clone();
        super::inputs::place_nominal(&mut start, &file, &search, false)?;
        Some(holdout_report(&mut d, &start, &held))
    };
    let mut report =
        DiagnoseReport::with_stall_limit(&d, args.stall_rms_mm).with_explanations(&d, &search);
    if let Some(h) = &holdout {
        let rms = |sq: Vec<f64>| (sq.iter().sum::<f64>() / sq.len().max(1) as f64).sqrt();
        report.acceptance = crate::calibration::acceptance::judge(
            (
                Some(h.start_rms_mm),
                Some(h.final_rms_mm),
                rms(squared_errors(&d.model, &search)),
            ),
            &search,
            &held,
            Vec::new(),
        );
        report.held_out_worse = report.acceptance.as_ref().map(|a| a.held_out_worse);
        if let Some(m) = report.acceptance.as_ref().and_then(|a| a.message.as_ref()) {
            let worse = report.held_out_worse == Some(true);
            eprintln!("{}: {m}", if worse { "error" } else { "warning" });
        }
    }
    report.holdout = holdout;
    report.poses = search.len();
    let full_fit = if full && report.converged {
        stages.stage("fitting the model to all observations");
        let fitted = all_observations(
            &d,
            &file,
            &observed,
            &args.obs,
            &cfg,
            (&search_poses, &held_poses),
        )?;
        report.observations = Some(fitted.1);
        Some(fitted.0)
    } else {
        None
    };
    if !report.converged {
        // A geometric model that cannot reach the data is not "missing an effect": the data
        // or the model are wrong, and a noise floor of metres is no finding (exit 3).
        eprintln!(
            "error: the geometric model does not fit the data (held-out RMS {} mm, above \
             --stall-rms-mm {}): check the units (--length-unit, --angle-unit), coupled joints \
             ([[couplings]], see `kinecal check`), the tool and the base; nothing is diagnosed \
             (exit 3)",
            sig(d.baseline_validation_rms_mm, 4),
            sig(args.stall_rms_mm, 3)
        );
    }
    if let Some(out) = args
        .out
        .as_ref()
        .filter(|_| report.held_out_worse == Some(true))
    {
        eprintln!(
            "note: {} not written: the model predicts the held-out poses worse than the \
             nominal robot",
            out.display()
        );
    } else if let Some(out) = &args.out {
        let model = full_fit.as_ref().map_or(&d.model, |f| &f.model);
        let mut f = RobotFile::from_robot(
            &format!("{} (diagnosed)", file.name),
            model,
            true,
            &d.free_tilt,
        )
        .with_tool_names(&observed.names);
        if f.tool.rpy_deg.is_none() {
            f.tool.rpy_deg = file.tool.rpy_deg;
        }
        f.save(out)?;
        report.out = Some(out.display().to_string());
    }
    if let Some(dir) = &args.plots {
        stages.stage("writing the plots");
        let files = crate::diagnose::residual_plots::write_all(dir, &d, &search)?;
        report.plots = Some(files.iter().map(|p| p.display().to_string()).collect());
    }
    Ok(report)
}

/// The observations the search reads (every one of the searched poses and of the held-out
/// ones), weighted as [`crate::diagnose::search_weights`] says, and the nominal robot it starts
/// from: with 6-D data and no `[tool] rpy_deg`, the measured frame's axes started from the data
/// (at a geometric fit of the positions), as identify starts them.
#[allow(clippy::type_complexity)]
fn search_observations<const N: usize>(
    nominal: &Robot<f64, N, VCAP>,
    file: &RobotFile,
    observed: &Observed<N>,
    obs: &ObservationArgs,
    poses: (&Observed<N>, &Observed<N>),
) -> anyhow::Result<(
    Robot<f64, N, VCAP>,
    Vec<Measurement<f64, N>>,
    Vec<Measurement<f64, N>>,
)> {
    let (mut search, mut held) = (poses.0.all(), poses.1.all());
    let mut start = nominal.clone();
    if !(observed.six_d || observed.sigma || observed.names.len() > 1) || search.is_empty() {
        return Ok((start, search, held));
    }
    let (base_known, tilt) = (file.base_known(), file.tilt_joints());
    if observed.six_d && file.tool.rpy_deg.is_none() {
        let positions: Vec<Measurement<f64, N>> = search
            .iter()
            .map(|m| Measurement {
                orientation: None,
                ..*m
            })
            .collect();
        let (geo, _) = fit_geometry(&start, base_known, &tilt, &positions)?;
        if let Some(axes) = crate::compute::registration::fit_tool_axes(&geo, &search) {
            start
                .set_tool_axes(axes)
                .map_err(|e| anyhow::anyhow!("estimated tool orientation is invalid: {e:?}"))?;
        }
    }
    let stated = weights::stated(&search, observed.sigma);
    let params = ParamSet::<64>::full(N, !base_known)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .len()
        + observation_params(&start, &search).len();
    let pose_of = pose_of(&poses.0.poses);
    let how = Weighting::of(
        observed.six_d,
        observed.sigma,
        obs,
        poses.0.poses.len(),
        params,
    );
    let w = search_weights(&mut search, &pose_of, &stated, how, |d| {
        Ok(fit_geometry(&start, base_known, &tilt, d)?.0)
    })?;
    let stated_held = weights::stated(&held, observed.sigma);
    w.apply(&mut held, &stated_held);
    Ok((start, search, held))
}

/// The geometry and `d`'s extended model fitted to all observations of the searched poses
/// (`poses.0`), with their errors there and on the held-out poses (`poses.1`).
fn all_observations<const N: usize>(
    d: &Diagnosis<N>,
    file: &RobotFile,
    observed: &Observed<N>,
    obs: &ObservationArgs,
    cfg: &Config,
    poses: (&Observed<N>, &Observed<N>),
) -> anyhow::Result<(FullFit<N>, ObservationsReport)> {
    let pose_of = pose_of(&poses.0.poses);
    let (data, held) = (poses.0.all(), poses.1.all());
    let w = Observations {
        six_d: observed.six_d,
        sigma: observed.sigma,
        obs,
    };
    let tool_axes_unknown = observed.six_d && file.tool.rpy_deg.is_none();
    let fitted = fit_all_observations(
        d,
        &data,
        &pose_of,
        w,
        file.base_known(),
        tool_axes_unknown,
        cfg,
    )?;
    let (before, after) = fitted.residuals(&held);
    let report = ObservationsReport {
        summary: ObservationSummary::new(
            observed,
            data.len(),
            obs.deg_weight_mm,
            &fitted.weighting,
        ),
        before,
        after,
        per_point: PointResiduals::per_point(
            &observed.names,
            (&fitted.geometric, &fitted.model),
            (&fitted.weighted, &held),
        ),
        unidentifiable: fitted.unidentifiable.clone(),
        chi2_per_dof: fitted.chi2_per_dof,
    };
    Ok((fitted, report))
}

/// The errors of the nominal robot `start` (placed as identify places it), of the starting
/// model as the search fitted it (the same fit as the final model when nothing is added) and
/// of the final model on the `held` poses; lowers `d`'s noise floor
/// to the final model's RMS there when it is above it.
fn holdout_report<const N: usize>(
    d: &mut Diagnosis<N>,
    start: &kinecal::Robot<f64, N, { crate::VCAP }>,
    held: &[kinecal::Measurement<f64, N>],
) -> HoldoutReport {
    let rms = |sq: Vec<f64>| (sq.iter().sum::<f64>() / sq.len() as f64).sqrt();
    let start_rms_mm = rms(squared_errors(start, held));
    let geometric_rms_mm = rms(squared_errors(&d.baseline_model, held));
    let final_rms_mm = rms(squared_errors(&d.model, held));
    let noise_floor_capped = d.cap_noise_floor(final_rms_mm);
    HoldoutReport {
        poses: held.len(),
        start_rms_mm,
        geometric_rms_mm,
        final_rms_mm,
        noise_floor_capped,
    }
}
