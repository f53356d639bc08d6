//! `kinecal report` on a constraint file: reads the robot file, the model and the session,
//! calls [`crate::application::constraint_report::report`], writes the page (atomically, never
//! over an input) and returns its summary (exit 3 when the model is no calibration of these
//! data: it misses the identification rows, or predicts the held-out groups worse than the
//! nominal robot; the page says so).

use super::report::Args;
use crate::application::constraint_report::{report, Inputs, Options};
use crate::constraints::read;
use crate::constraints::report::ConstraintReportSummary;
use crate::formats::robot_file::load_robot;
use crate::reports::path_text;
use crate::with_joints;

/// Runs `report` on the constraint file `args.input.data`.
pub fn run(args: &Args) -> anyhow::Result<ConstraintReportSummary> {
    let input = &args.input;
    for (flag, given) in [
        ("--validate", args.validate.is_some()),
        ("--diagnose", args.diagnose.is_some()),
        ("--validate-json", args.validate_json.is_some()),
    ] {
        if given {
            crate::refuse!(
                "{flag}: a constraint file's report holds out groups of the session itself \
                 (--holdout, --split, --seed as given to identify); leave {flag} out"
            );
        }
    }
    let inputs = [
        ("robot", input.robot.as_path()),
        ("data", input.data.as_path()),
        ("model", args.model.as_path()),
    ];
    crate::output::atomic::refuse_overwriting_inputs("--out", &args.out, &inputs)?;
    crate::check_positive("--stall-rms-mm", args.stall_rms_mm, 1e6)?;
    let n = crate::calibration::replay::joint_count(&input.robot, &args.model)?;
    let mut summary = with_joints!(n, N => run_with_joints::<N>(args))?;
    summary.out = Some(args.out.display().to_string());
    if !summary.converged {
        eprintln!(
            "error: {} is not a calibration of these constraints (exit 3; the page says why)",
            args.model.display()
        );
    }
    Ok(summary)
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ConstraintReportSummary> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let (_, model) = load_robot::<N>(&args.model)?;
    crate::calibration::replay::same_robot(&nominal, &model, (&input.robot, &args.model))?;
    let session = read::load::<N>(&input.data, &input.units, &file.tool_names())?;
    super::inputs::warn_outside_limits(
        crate::calibration::check::OutsideLimits::of_rows(&file, session.joint_rows()),
        session.rows(),
        &input.data,
        &input.robot,
    );
    let held = crate::calibration::held_out_mask(
        session.groups.len(),
        args.holdout.holdout,
        args.holdout.split,
        args.seed,
    )?
    .iter()
    .filter(|h| **h)
    .count();
    let split = if held > 0 {
        format!(
            "{} of {}",
            args.holdout.describe_in(held, ("group", "groups")),
            session.groups.len()
        )
    } else {
        "none".into()
    };
    let sources = vec![
        ("robot file".to_string(), path_text(&input.robot)),
        ("model".to_string(), path_text(&args.model)),
        ("session".to_string(), path_text(&input.data)),
        ("held out".to_string(), split),
        ("units".to_string(), input.units.described()),
    ];
    let built = report(
        &Options {
            holdout: args.holdout,
            seed: args.seed,
            stall_rms_mm: args.stall_rms_mm,
        },
        Inputs {
            file,
            nominal,
            model,
            session,
            data_origin: path_text(&input.data),
            sources,
        },
    )?;
    crate::output::atomic::write_atomic(&args.out, built.html.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", args.out.display()))?;
    Ok(built.summary)
}
