//! `kinecal report`: the calibration report, one self-contained HTML page
//! ([`crate::report_html`]), from the robot file, the model `identify --out` wrote, the
//! identification data and optionally held-out data and a diagnose JSON.

use super::inputs::InputArgs;
use crate::calibration::replay;
use crate::calibration::selection::Selection;
use crate::calibration::{model_params, weights};
use crate::formats::observations::ObservationArgs;
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::report_html::summary::ReportSummary;
use crate::report_html::{build, findings, Inputs, Sources};
use crate::with_joints;
use std::path::{Path, PathBuf};

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
    /// The parameters `identify` was told to hold (`--fix`), for the 1-σ and the table.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub fix: Vec<String>,
    /// The parameters `identify` was told to add (`--free`).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub free: Vec<String>,
    /// The parameters `identify` was told to estimate alone (`--only`).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub only: Vec<String>,
    /// The prior `identify` was given (`--prior`; the robot file's `[prior]` is read as
    /// identify reads it).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub prior: Vec<String>,
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
    let n = RobotFile::load(&input.robot)?.joint_count();
    let m = RobotFile::load(&args.model)?.joint_count();
    if m != n {
        crate::refuse!(
            "{}: a model of a {m}-joint robot, but {} has {n} joints: give the model that \
             `kinecal identify --robot {} --out M.toml` wrote",
            args.model.display(),
            input.robot.display(),
            input.robot.display()
        );
    }
    let mut summary = with_joints!(n, N => run_with_joints::<N>(args))?;
    summary.out = Some(args.out.display().to_string());
    Ok(summary)
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ReportSummary> {
    let input = &args.input;
    let (file, mut nominal) = load_robot::<N>(&input.robot)?;
    let (model_file, model) = load_robot::<N>(&args.model)?;
    replay::same_robot(&nominal, &model, (&input.robot, &args.model))?;
    let obs = &args.obs;
    let split = super::inputs::load_split(
        input,
        &file,
        &nominal,
        obs,
        args.validate.as_deref(),
        (&args.holdout, args.seed),
    )?;
    let observed = &split.observed;
    // "Before" is the nominal robot placed as identify and check place it.
    let base_unknown = !file.base_known();
    super::inputs::place_nominal(&mut nominal, &file, &split.ident, observed.six_d)?;
    // The parameters identify estimated (calibration/replay.rs).
    let selected = Selection {
        only: &args.only,
        free: &args.free,
        fix: &args.fix,
    };
    let how = (observed.six_d, base_unknown);
    let (tilts, estimated) = replay::estimated(&file, (&model_file, &model), how, &selected)?;
    let weighting = weights::Weighting::of(
        observed.six_d,
        observed.sigma,
        obs,
        split.ident_poses,
        estimated.len(),
    );
    let diagnose = match &args.diagnose {
        Some(p) => Some((findings::load(p)?, p.display().to_string())),
        None => None,
    };
    let t = |p: &Path| p.display().to_string();
    let mut files = vec![
        ("robot file".to_string(), t(&input.robot)),
        ("identified model".to_string(), t(&args.model)),
        ("identification data".to_string(), t(&input.data)),
    ];
    match &args.validate {
        Some(v) => files.push(("held-out data".into(), v.display().to_string())),
        None if args.holdout.holds_out() => files.push((
            "held-out data".into(),
            format!("{} of the data", args.holdout.describe(split.valid_poses)),
        )),
        None => {}
    }
    if let Some(d) = &args.diagnose {
        files.push(("diagnose findings".into(), d.display().to_string()));
    }
    let validation = match &args.validate_json {
        Some(p) => {
            files.push(("another session (validate)".into(), p.display().to_string()));
            Some((
                crate::report_html::validation::load(p)?,
                p.display().to_string(),
            ))
        }
        None => None,
    };
    let all_params = model_params(&model, &tilts);
    let model_origin = args.model.display().to_string();
    let (start, prior) = replay::start_and_prior(
        (&file, &nominal),
        (&model, &model_origin),
        how,
        &estimated,
        &args.prior,
    )?;
    let built = build(Inputs {
        robot_name: file.name.clone(),
        model_name: model_file.name.clone(),
        sources: Sources {
            files,
            units: args.input.units.described(),
        },
        nominal: &nominal,
        base_fitted: base_unknown,
        tool_unknown: file.tool_unknown(),
        model: &model,
        start: &start,
        all_params,
        estimated,
        prior,
        names: observed.names.clone(),
        six_d: observed.six_d,
        sigma: observed.sigma,
        weighting,
        limits_deg: file.joints.iter().map(|j| j.limits_deg).collect(),
        stall_rms_mm: args.stall_rms_mm,
        diagnose,
        validation,
        ident: split.ident,
        valid: split.valid,
        pose_of: split.pose_of,
        ident_poses: split.ident_poses,
        valid_poses: split.valid_poses,
    })?;
    crate::output::atomic::write_atomic(&args.out, built.html.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", args.out.display()))?;
    if !built.summary.converged {
        eprintln!(
            "error: {} misses the identification poses by {} mm RMS: not a calibration of \
             these data (exit 3; the page says so)",
            args.model.display(),
            crate::output::numfmt::sig(built.summary.after.identification_rms_mm, 4)
        );
    }
    Ok(built.summary)
}
