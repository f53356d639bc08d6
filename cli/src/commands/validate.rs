//! `kinecal validate`: a calibrated model judged on another session's data, against the nominal
//! robot registered the same way ([`crate::calibration::validate`]; docs/formats.md).

use super::inputs::InputArgs;
use crate::calibration::validate::{validate, Inputs, Options, Register};
use crate::formats::observations::{observe, ObservationArgs};
use crate::formats::robot_file::load_robot;
use crate::reports::validate::ValidateReport;
use crate::with_joints;
use std::path::PathBuf;

/// Arguments of `kinecal validate` (docs/formats.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The nominal robot file, the session's measurements and their units.
    #[command(flatten)]
    pub input: InputArgs,
    /// The calibrated model (`identify --robot R --data D1 --out M`).
    #[arg(long)]
    pub model: PathBuf,
    /// What is fitted to the session, for both robots alike: nothing, the base pose, or the
    /// base pose and the tool point(s) (and the tool orientation with 6-D data).
    #[arg(long, value_enum, default_value = "base+tool")]
    pub register: Register,
    /// Orientation and σ columns: how they weigh in the registration (as for `identify`).
    #[command(flatten)]
    pub obs: ObservationArgs,
}

/// Runs the subcommand; a report that is no acceptance (`worse_than_nominal`, `data_mismatch`,
/// `changed_since_calibration`, `too_few_to_judge`, `gross_outliers`) makes the command exit
/// with 3, with the reason on stderr.
pub fn run(args: &Args) -> anyhow::Result<ValidateReport> {
    let n = crate::calibration::replay::joint_count(&args.input.robot, &args.model)?;
    let report = with_joints!(n, N => run_with_joints::<N>(args))?;
    if let Some(w) = report.thin() {
        eprintln!("{w}");
    }
    if !crate::reports::Report::converged(&report) {
        eprintln!("error: {} (exit 3)", report.verdict);
    }
    Ok(report)
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ValidateReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let (model_file, model) = load_robot::<N>(&args.model)?;
    crate::calibration::replay::same_robot(&nominal, &model, (&input.robot, &args.model))?;
    let ds = crate::formats::loading::load_measurements(
        &input.data,
        &input.units,
        &nominal,
        // A registered session may stand anywhere: its units are judged by shape alone.
        file.base_known() && args.register == Register::None,
    )?;
    let origin = input.data.display().to_string();
    let model_text = args.model.display().to_string();
    if let Some(w) = thermal_without_temperature(&model_file, &ds, &origin) {
        eprintln!("warning: {w}");
    }
    let named = (origin.as_str(), Some(model_text.as_str()));
    let told = crate::formats::table_reach::in_robot_file(&nominal);
    for line in crate::formats::table_reach::lines_except(&ds, &model, named, told) {
        eprintln!("{line}");
    }
    super::inputs::warn_outside_limits(
        crate::calibration::check::OutsideLimits::of(&file, &ds),
        ds.len(),
        &input.data,
        &input.robot,
    );
    let observed = observe(&ds, &file, &args.obs, &origin)?;
    super::inputs::any_rows(&observed.poses, &input.data)?;
    if let Some(n) =
        crate::calibration::replay::itself(&nominal, &model, (&input.robot, &args.model))
    {
        eprintln!("{n}");
    }
    let (robot_origin, model_origin) = (
        input.robot.display().to_string(),
        args.model.display().to_string(),
    );
    let v = validate(
        Inputs {
            nominal: &nominal,
            nominal_base_known: file.base_known(),
            nominal_origin: &robot_origin,
            model: &model,
            model_base_known: model_file.base_known(),
            // Fitted, not copied from the robot file (whose orientation the nominal robot
            // shares: a positions calibration states the file's).
            model_orientation_stated: model_file.tool.rpy_deg.is_some()
                && model_file.tool.rpy_deg != file.tool.rpy_deg,
            model_origin: &model_origin,
            observed: &observed,
            step_check: Some(crate::diagnose::row_step::warning),
        },
        &Options {
            register: args.register,
            obs: args.obs.clone(),
        },
    )?;
    // A model far worse than the robot file that also lies beyond a manufacturing tolerance of
    // it may be of another robot (or typed wrong): "recalibrate" alone would send the user to
    // measure again.
    if v.worse_than_nominal {
        if let Some(what) = crate::application::export::mismatch(
            &model_file,
            &file,
            crate::application::export::MATCH_TOLERANCE_MM,
            crate::application::export::MATCH_TOLERANCE_DEG,
        ) {
            eprintln!(
                "note: {model_origin} lies beyond a manufacturing tolerance of {robot_origin} \
                 ({what}): if it was not calibrated from this robot file, give the one it was, \
                 or correct the value; `export` refuses the pair"
            );
        }
    }
    Ok(ValidateReport::of(
        &v,
        (&robot_origin, &model_origin, &origin),
    ))
}

/// The warning for a model with thermal expansion judged on a session without `temp_c`: the
/// expansion is evaluated at the model's reference temperature on every row (a session on an
/// arm 10 K warmer was "held" at 0.226 mm where its temperatures give 0.017 mm).
fn thermal_without_temperature<const N: usize>(
    model: &crate::formats::robot_file::RobotFile,
    ds: &crate::formats::measurements::Dataset<N>,
    origin: &str,
) -> Option<String> {
    let column = crate::formats::measurements::TEMPERATURE_COLUMN;
    let t0 = model.thermal_reference_c()?;
    if ds.extra_names.iter().any(|n| n == column) {
        return None;
    }
    Some(format!(
        "{origin} has no {column} column: the model's thermal expansion is evaluated at its \
         reference temperature {} °C on every row, and an arm at another temperature is judged \
         as if it had changed; give the session's temperatures (a {column} column, °C)",
        crate::output::numfmt::sig(t0, 4)
    ))
}
