//! `kinecal identify`: fits the model to measurements and reports residuals before and after.

use super::inputs::InputArgs;
use crate::application::identify::{
    identify, Inputs, Options, DEFAULT_SEED, DEFAULT_STALL_RMS_MM, DEFAULT_TOLERANCE_DEG,
    DEFAULT_TOLERANCE_MM,
};
use crate::calibration::method::Method;
use crate::calibration::selection::ParameterArgs;
use crate::calibration::EffectRequest;
use crate::formats::observations::ObservationArgs;
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::reports::identify::IdentifyReport;
use crate::reports::model_out::save;
use crate::with_joints;
use std::path::PathBuf;

/// Arguments of `kinecal identify` (docs/formats.md, docs/walkthrough.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file, measurements (and the `--validate` file's) units.
    #[command(flatten)]
    pub input: InputArgs,
    /// Identification method.
    #[arg(long, value_enum, default_value = "lm")]
    pub method: Method,
    /// Held-out poses: `--holdout` a fraction (< 1) or a count (≥ 1), `--split` which ones
    /// (last, random, every:K).
    #[command(flatten)]
    pub holdout: super::inputs::HoldoutArgs,
    /// Validate on a separate measurement file.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Add a joint correction to the model: KIND:JOINT[:ARG] (ARG: cyclic order, or table knot
    /// spacing in degrees, default 3.6). Repeatable.
    #[arg(long = "effect")]
    pub effects: Vec<EffectRequest>,
    /// Seed of the stochastic methods.
    #[arg(long, default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// Write the identified model (robot TOML; written atomically, never over an input).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Which parameters are estimated (`--fix`, `--free`, `--only`) and their prior.
    #[command(flatten)]
    pub parameters: ParameterArgs,
    /// Write each pose's residual (identification and held-out; per axis, with the pose index
    /// and its line in the file) to this CSV.
    #[arg(long)]
    pub residuals: Option<PathBuf>,
    /// A length parameter that moves further than this from its file value is reported as
    /// suspicious (a manufacturing tolerance; JSON `suspicious`).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE_MM)]
    pub tolerance_mm: f64,
    /// The same for angle parameters, degrees.
    #[arg(long, default_value_t = DEFAULT_TOLERANCE_DEG)]
    pub tolerance_deg: f64,
    /// A fit whose identification RMS stays above this has stalled far above any tracker's
    /// noise: reported as not converged (exit 3).
    #[arg(long, default_value_t = DEFAULT_STALL_RMS_MM)]
    pub stall_rms_mm: f64,
    /// Orientation and σ columns: how they are used.
    #[command(flatten)]
    pub obs: ObservationArgs,
}

impl Args {
    /// The options of the fit (everything but the files).
    pub fn options(&self) -> Options {
        Options {
            method: self.method,
            holdout: self.holdout,
            effects: self.effects.clone(),
            seed: self.seed,
            fix: self.parameters.fix.clone(),
            free: self.parameters.free.clone(),
            only: self.parameters.only.clone(),
            prior: self.parameters.prior.clone(),
            residuals: self.residuals.is_some(),
            tolerance_mm: self.tolerance_mm,
            tolerance_deg: self.tolerance_deg,
            stall_rms_mm: self.stall_rms_mm,
            obs: self.obs.clone(),
        }
    }
}

/// Refuses `--out` and `--residuals` over an input (tracker points and constraint files alike).
pub(super) fn refuse_outputs_over_inputs(args: &Args) -> anyhow::Result<()> {
    for out in [args.out.as_deref(), args.residuals.as_deref()] {
        crate::output::atomic::refuse_model_over_inputs(
            out,
            &args.input.robot,
            &args.input.data,
            args.validate.as_deref(),
        )?;
    }
    Ok(())
}

/// Runs the subcommand: fits the model (and writes it with `--out`); the report's
/// `converged` says whether the numbers are a calibration.
pub fn run(args: &Args) -> anyhow::Result<IdentifyReport> {
    refuse_outputs_over_inputs(args)?;
    let n = RobotFile::load(&args.input.robot)?.joint_count();
    with_joints!(n, N => run_with_joints::<N>(args))
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<IdentifyReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let load =
        |p: &std::path::Path| super::inputs::load_observed(p, input, (&file, &nominal), &args.obs);
    let observed = load(&input.data)?;
    super::inputs::any_rows(&observed.poses, &input.data)?;
    let validate = match &args.validate {
        Some(v) => Some((
            load(v).map_err(super::inputs::units_alike)?,
            v.display().to_string(),
        )),
        None => None,
    };
    let inputs = Inputs {
        file,
        nominal,
        observed,
        robot_origin: input.robot.display().to_string(),
        data_origin: input.data.display().to_string(),
        validate,
    };
    let mut done = identify(&args.options(), inputs)?;
    if let Some(path) = &args.residuals {
        crate::output::atomic::write_atomic(path, done.residuals.to_csv().as_bytes()).map_err(
            |e| crate::refused(format!("--residuals {}: cannot write: {e}", path.display())),
        )?;
    }
    let unfit = done.report.unfit();
    done.report.out = save(
        args.out.as_deref(),
        unfit.as_deref().map_or(Ok(&done.model), Err),
    )?;
    for w in done.report.warnings() {
        eprintln!("{w}");
    }
    Ok(done.report)
}
