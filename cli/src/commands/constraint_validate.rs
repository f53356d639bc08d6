//! `kinecal validate` on a constraint file: the calibrated model and the nominal robot each
//! predict the session's tool points, each group is compared with its own shape refitted to
//! them (a socket's centre, a plane; a distance group's length error), and the figures over the
//! groups are compared (exit 3 when the model is worse, as `validate` on tracker points).
//! Nothing is registered: a constraint residual does not depend on where the robot stands.

use super::validate::Args;
use crate::constraints::read;
use crate::constraints::report::{ConstraintValidateReport, Figures};
use crate::constraints::shapes::{check_lengths, held_out_error};
use crate::formats::robot_file::load_robot;
use crate::reports::path_text;
use crate::with_joints;

/// Runs `validate` on the constraint file `args.input.data`.
pub fn run(args: &Args) -> anyhow::Result<ConstraintValidateReport> {
    let n = crate::calibration::replay::joint_count(&args.input.robot, &args.model)?;
    let report = with_joints!(n, N => run_with_joints::<N>(args))?;
    if report.changed_since_calibration {
        if let Some(r) = &report.recalibration {
            eprintln!(
                "error: {} (or its calibration was much poorer than this session): the model \
                 predicts the session's groups to {} mm RMS, a calibration on its other groups \
                 to {} mm ({} folds; exit 3)",
                crate::reports::validate::RECALIBRATE,
                crate::output::numfmt::sig(r.model_rms_mm, 4),
                crate::output::numfmt::sig(r.recalibrated_rms_mm, 4),
                r.folds
            );
        }
    }
    if report.worse_than_nominal {
        eprintln!(
            "error: the model predicts these constraints worse than the nominal robot ({} mm \
             against {} mm RMS): it is not a calibration for this robot (exit 3)",
            crate::output::numfmt::sig(report.model.rms_mm, 4),
            crate::output::numfmt::sig(report.nominal.rms_mm, 4)
        );
    }
    Ok(report)
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ConstraintValidateReport> {
    let (file, nominal) = load_robot::<N>(&args.input.robot)?;
    let (model_file, model) = load_robot::<N>(&args.model)?;
    let session = read::load::<N>(&args.input.data, &args.input.units, &file.tool_names())?;
    super::inputs::warn_outside_limits(
        crate::calibration::check::OutsideLimits::of_rows(&file, session.joint_rows()),
        session.rows(),
        &args.input.data,
        &args.input.robot,
    );
    check_lengths(&nominal, &session.groups, &path_text(&args.input.data))?;
    let paths = (args.input.robot.as_path(), args.model.as_path());
    crate::calibration::replay::same_robot(&nominal, &model, paths)?;
    if let Some(n) = crate::calibration::replay::itself(&nominal, &model, paths) {
        eprintln!("{n}");
    }
    let errors = |robot| -> Vec<f64> {
        session
            .groups
            .iter()
            .map(|g| held_out_error(robot, g))
            .collect()
    };
    let (m, n) = (Figures::of(&errors(&model)), Figures::of(&errors(&nominal)));
    let recalibration =
        crate::constraints::recalibration::recalibrate(&model, &model_file, &session.groups);
    Ok(ConstraintValidateReport {
        changed_since_calibration: recalibration.as_ref().is_some_and(|r| r.changed()),
        recalibration,
        count_unit: "groups".into(),
        groups: session.groups.len(),
        // NaN counts as worse.
        worse_than_nominal: m.rms_mm.is_nan()
            || m.rms_mm > n.rms_mm + crate::calibration::acceptance::NO_DIFFERENCE_MM,
        model: m,
        nominal: n,
        registered: Vec::new(),
    })
}
