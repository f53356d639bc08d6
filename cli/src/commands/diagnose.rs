//! `kinecal diagnose`: the discrepancy workflow (see [`crate::diagnose`]): fits the geometry,
//! finds where model and data disagree, names the missing effects, adds them and shows the
//! held-out gap shrink.

use super::inputs::InputArgs;
use crate::calibration::split_holdout;
use crate::diagnose::linear::squared_errors;
use crate::diagnose::{diagnose_with_progress, Config, Diagnosis, Progress};
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::output::numfmt::sig;
use crate::reports::diagnose::{DiagnoseReport, HoldoutReport};
use crate::with_joints;
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
    /// Also keep the last poses out of the whole search and report the errors on them: a
    /// fraction (< 1) or a count (≥ 1).
    #[arg(long, conflicts_with = "validate")]
    pub holdout: Option<f64>,
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
    // The discrepancy analysis (its linear screening and cross-validation) reads one position
    // residual per pose, unweighted: orientation and σ columns are read and left aside (said
    // on stderr); several reflectors are refused.
    let unit_model = &nominal;
    let load = |p: &std::path::Path| -> anyhow::Result<Vec<kinecal::Measurement<f64, N>>> {
        let ds = crate::formats::units::load_measurements(
            p,
            &input.units,
            unit_model,
            file.base_known(),
        )?;
        let o = crate::formats::observations::observe(
            &ds,
            &file,
            &crate::formats::observations::ObservationArgs {
                positions_only: true,
                ignore_sigma: true,
                ..Default::default()
            },
            &p.display().to_string(),
        )?;
        let extra = ["rx_deg", "sx_mm"]
            .iter()
            .any(|c| ds.extra_names.iter().any(|n| n == c));
        if extra {
            eprintln!(
                "note: {}: diagnose uses the positions, unweighted; the orientation and σ \
                 columns are used by identify",
                p.display()
            );
        }
        if o.names.len() > 1 {
            crate::refuse!(
                "{}: diagnose reads one measured point per pose; give a robot file with one \
                 [tool] (the reflector whose columns are x, y, z) or use identify",
                p.display()
            );
        }
        Ok(o.all())
    };
    if let Some(dir) = args.plots.as_deref().filter(|d| d.exists() && !d.is_dir()) {
        crate::refuse!(
            "--plots {}: names a file, not a directory: give a directory for the SVG plots",
            dir.display()
        );
    }
    let all = super::inputs::some_rows(load(&input.data)?, &input.data)?;
    let (search, held) = match (&args.validate, args.holdout) {
        (Some(v), _) => (all, super::inputs::some_rows(load(v)?, v)?),
        (None, Some(h)) => {
            if !(h.is_finite() && h > 0.0) {
                crate::refuse!(
                    "--holdout {h}: give a fraction (0 < F < 1) or a count of poses (≥ 1)"
                );
            }
            split_holdout(&all, h)?
        }
        (None, None) => (all, Vec::new()),
    };
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
        Some(holdout_report(&mut d, &held))
    };
    let mut report =
        DiagnoseReport::with_stall_limit(&d, args.stall_rms_mm).with_explanations(&d, &search);
    report.holdout = holdout;
    report.poses = search.len();
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
    if let Some(out) = &args.out {
        let mut f = RobotFile::from_robot(
            &format!("{} (diagnosed)", file.name),
            &d.model,
            true,
            &d.free_tilt,
        );
        f.tool.rpy_deg = file.tool.rpy_deg;
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

/// The errors of the starting model as the search fitted it (the same fit as the final model
/// when nothing is added) and of the final model on the `held` poses; lowers `d`'s noise floor
/// to the final model's RMS there when it is above it.
fn holdout_report<const N: usize>(
    d: &mut Diagnosis<N>,
    held: &[kinecal::Measurement<f64, N>],
) -> HoldoutReport {
    let rms = |sq: Vec<f64>| (sq.iter().sum::<f64>() / sq.len() as f64).sqrt();
    let geometric_rms_mm = rms(squared_errors(&d.baseline_model, held));
    let final_rms_mm = rms(squared_errors(&d.model, held));
    let noise_floor_capped = d.cap_noise_floor(final_rms_mm);
    HoldoutReport {
        poses: held.len(),
        geometric_rms_mm,
        final_rms_mm,
        noise_floor_capped,
    }
}

/// The JSON report of a diagnosis, as before the typed reports: use
/// [`DiagnoseReport::of`]`(d)` (and [`DiagnoseReport::to_value`] for the JSON) instead.
pub fn report<const N: usize>(d: &Diagnosis<N>) -> serde_json::Value {
    DiagnoseReport::of(d).to_value()
}
