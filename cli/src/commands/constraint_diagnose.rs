//! `kinecal diagnose` on a constraint file: reads the robot file and the session, calls
//! [`crate::application::constraint_diagnose::diagnose`], prints its warnings, writes the model
//! (`--out`) and says why not (exit 3 when the geometric fit is no calibration or the extended
//! model predicts the held-out groups worse than the geometric one).

use super::diagnose::Args;
use crate::application::constraint_diagnose::{diagnose, Diagnosed, Inputs, Options};
use crate::constraints::diagnose::SearchOptions;
pub use crate::constraints::diagnose_report::ConstraintDiagnoseReport;
use crate::constraints::read;
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::reports::model_out::{save, NOT_A_CALIBRATION};
use crate::reports::path_text;
use crate::with_joints;

/// Runs `diagnose` on the constraint file `args.input.data`.
pub fn run(args: &Args) -> anyhow::Result<ConstraintDiagnoseReport> {
    for (flag, given) in [
        ("--validate", args.validate.is_some()),
        ("--plots", args.plots.is_some()),
    ] {
        if given {
            crate::refuse!(
                "{flag}: diagnose on a constraint file holds out groups of the session \
                 (--holdout, --split, --seed); leave {flag} out"
            );
        }
    }
    if let Some(out) = &args.out {
        crate::output::atomic::refuse_overwriting_inputs(
            "--out",
            out,
            &[
                ("robot", args.input.robot.as_path()),
                ("data", args.input.data.as_path()),
            ],
        )?;
    }
    if !(2..=20).contains(&args.folds) {
        crate::refuse!("--folds {}: give 2 to 20", args.folds);
    }
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        crate::refuse!("--alpha {}: give a probability between 0 and 1", args.alpha);
    }
    let file = RobotFile::load(&args.input.robot)?;
    let report = with_joints!(file.joint_count(), N => run_with_joints::<N>(args))?;
    if let Some(why) = &report.resized {
        eprintln!("error: the geometric fit {why}; nothing is diagnosed (exit 3)");
    } else if report.held_out_worse {
        eprintln!(
            "error: the extended model predicts the held-out groups worse than the geometric \
             fit: not an improvement (exit 3)"
        );
    }
    Ok(report)
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ConstraintDiagnoseReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let session = read::load::<N>(&input.data, &input.units, &file.tool_names())?;
    super::inputs::warn_outside_limits(
        crate::calibration::check::OutsideLimits::of_rows(&file, session.joint_rows()),
        session.rows(),
        &input.data,
        &input.robot,
    );
    let options = Options {
        search: SearchOptions {
            folds: args.folds,
            alpha: args.alpha,
            max_order: args.max_order.clamp(1, crate::MAX_CYCLIC_ORDER),
            max_effects: args.max_effects,
            seed: args.seed,
        },
        holdout: args.holdout,
        stall_rms_mm: args.stall_rms_mm,
    };
    let inputs = Inputs {
        file,
        nominal,
        session,
        data_origin: path_text(&input.data),
    };
    let Diagnosed {
        mut report,
        model,
        warnings,
    } = diagnose(&options, inputs)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    report.out = save(args.out.as_deref(), model.as_ref().ok_or(NOT_A_CALIBRATION))?;
    Ok(report)
}
