//! `kinecal report`: the calibration report, one self-contained HTML page
//! ([`crate::report_html`]), from the robot file, the model `identify --out` wrote, the
//! identification data and optionally held-out data and a diagnose JSON.

use super::inputs::InputArgs;
use crate::application::report::{report, Inputs, Options};
use crate::calibration::replay;
use crate::calibration::selection::ParameterArgs;
use crate::formats::observations::ObservationArgs;
use crate::formats::robot_file::load_robot;
use crate::report_html::summary::ReportSummary;
use crate::report_html::{findings, Sources};
use crate::with_joints;
use std::path::PathBuf;

/// Arguments of `kinecal report` (docs/formats.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file (the nominal model), identification data and their units.
    #[command(flatten)]
    pub input: InputArgs,
    /// The identified model (`identify --robot R --data D --out M`).
    #[arg(long)]
    pub model: PathBuf,
    /// Held-out measurements: figures on poses the model never saw.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Hold out poses of the data as `identify --holdout --split --seed` did.
    #[command(flatten)]
    pub holdout: super::inputs::HoldoutArgs,
    /// The seed of `--split random` (as given to `identify`).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The JSON of `kinecal diagnose --json` on these data: its findings and their plots.
    #[arg(long)]
    pub diagnose: Option<PathBuf>,
    /// The JSON of `kinecal validate --json` on another session: the model against the
    /// nominal robot there, both registered the same way (`--validate` is for held-out poses of
    /// this session: nothing is registered).
    #[arg(long)]
    pub validate_json: Option<PathBuf>,
    /// The page to write (HTML; written atomically, never over an input).
    #[arg(long)]
    pub out: PathBuf,
    /// The parameters `identify` was told to hold, add or estimate alone (`--fix`, `--free`,
    /// `--only`) and its `--prior` (the robot file's `[prior]` is read as identify reads it).
    #[command(flatten)]
    pub parameters: ParameterArgs,
    /// A model that misses the identification poses by more than this RMS (mm) is not a
    /// calibration of these data (exit 3).
    #[arg(long, default_value_t = 5.0)]
    pub stall_rms_mm: f64,
    /// Orientation and σ columns: how they are used (as given to `identify`).
    #[command(flatten)]
    pub obs: ObservationArgs,
}

/// Runs the subcommand: writes the page and returns its summary.
pub fn run(args: &Args) -> anyhow::Result<ReportSummary> {
    let input = &args.input;
    let mut inputs = vec![
        ("robot", input.robot.as_path()),
        ("data", input.data.as_path()),
        ("model", args.model.as_path()),
    ];
    inputs.extend(args.validate.as_deref().map(|v| ("validation", v)));
    inputs.extend(args.diagnose.as_deref().map(|d| ("diagnose", d)));
    inputs.extend(args.validate_json.as_deref().map(|v| ("validate JSON", v)));
    crate::output::atomic::refuse_overwriting_inputs("--out", &args.out, &inputs)?;
    crate::check_positive("--stall-rms-mm", args.stall_rms_mm, 1e6)?;
    let n = replay::joint_count(&input.robot, &args.model)?;
    let mut summary = with_joints!(n, N => run_with_joints::<N>(args))?;
    summary.out = Some(args.out.display().to_string());
    Ok(summary)
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ReportSummary> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let (model_file, model) = load_robot::<N>(&args.model)?;
    replay::same_robot(&nominal, &model, (&input.robot, &args.model))?;
    let (validate, holdout) = (args.validate.as_deref(), (&args.holdout, args.seed));
    // What reading the files tells goes to stderr and onto the page.
    let (split, told) = crate::captured(|| {
        super::inputs::load_split(
            input,
            (&file, &nominal),
            (&model, &args.model),
            &args.obs,
            validate,
            holdout,
        )
    });
    for line in &told {
        crate::Tell::line(&mut crate::Stderr, line);
    }
    let split = split?;
    let t = |p: &std::path::Path| p.display().to_string();
    let diagnose = args.diagnose.as_deref();
    let diagnose = diagnose.map(|p| anyhow::Ok((findings::load(p)?, t(p))));
    let validation = args.validate_json.as_deref();
    let validation =
        validation.map(|p| anyhow::Ok((crate::report_html::validation::load(p)?, t(p))));
    let held_out = match &args.validate {
        Some(v) => Some(t(v)),
        None if args.holdout.holds_out() => Some(format!(
            "{} of the data",
            args.holdout.describe(split.valid_poses)
        )),
        None => None,
    };
    let files = Sources::files(
        (&input.robot, &args.model, &input.data),
        held_out,
        (args.diagnose.as_deref(), args.validate_json.as_deref()),
    );
    let options = Options {
        parameters: &args.parameters,
        obs: &args.obs,
        stall_rms_mm: args.stall_rms_mm,
    };
    let inputs = Inputs {
        file,
        nominal,
        model_file,
        model,
        model_origin: t(&args.model),
        robot_origin: t(&input.robot),
        validated: args.validate.as_deref().map(t),
        split,
        sources: Sources {
            files,
            units: input.units.described(),
            told,
        },
        diagnose: diagnose.transpose()?,
        validation: validation.transpose()?,
    };
    let built = report(&options, inputs)?;
    crate::output::atomic::write_atomic(&args.out, built.html.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", args.out.display()))?;
    if !built.summary.converged {
        eprintln!("{}", built.summary.error_line(&args.model));
    }
    Ok(built.summary)
}
