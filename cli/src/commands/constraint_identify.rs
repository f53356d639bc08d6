//! `kinecal identify` on a constraint file: reads the robot file and the sessions, calls
//! [`crate::application::constraints::identify`] and writes what it returns (`--residuals`,
//! `--out` unless the model predicts the held-out groups worse than the one it started from).

use super::identify::Args;
use crate::application::constraints::{identify, Inputs};
use crate::constraints::read;
use crate::constraints::report::ConstraintIdentifyReport;
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::reports::model_out::{save, unfit};
use crate::with_joints;

/// Runs `identify` on the constraint file `args.input.data`.
pub fn run(args: &Args) -> anyhow::Result<ConstraintIdentifyReport> {
    super::identify::refuse_outputs_over_inputs(args)?;
    let n = RobotFile::load(&args.input.robot)?.joint_count();
    with_joints!(n, N => run_with_joints::<N>(args))
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ConstraintIdentifyReport> {
    let (file, nominal) = load_robot::<N>(&args.input.robot)?;
    let tools = file.tool_names();
    let session = read::load::<N>(&args.input.data, &args.input.units, &tools)?;
    super::inputs::warn_outside_limits(
        crate::calibration::check::OutsideLimits::of_rows(&file, session.joint_rows()),
        session.rows(),
        &args.input.data,
        &args.input.robot,
    );
    let validate = match &args.validate {
        Some(v) if !read::is_constraint_file(v) => crate::refuse!(
            "--validate {}: not a constraint file (no kind column) while --data is one",
            v.display()
        ),
        Some(v) => Some(read::load::<N>(v, &args.input.units, &tools)?.groups),
        None => None,
    };
    let inputs = Inputs {
        file,
        nominal,
        session,
        data_origin: args.input.data.display().to_string(),
        validate,
    };
    let mut done = identify(&args.options(), inputs)?;
    let report = &mut done.report;
    for w in &report.warnings {
        eprintln!("{w}");
    }
    if let Some(m) = report.acceptance.as_ref().and_then(|a| a.message.as_ref()) {
        eprintln!("warning: {m}");
    }
    if report.n_validation == 0 {
        eprintln!("{}", crate::calibration::acceptance::NOT_JUDGED);
    }
    if let (Some(path), Some(csv)) = (&args.residuals, &done.residuals) {
        crate::output::atomic::write_atomic(path, csv.as_bytes()).map_err(|e| {
            crate::refused(format!("--residuals {}: cannot write: {e}", path.display()))
        })?;
    }
    if !report.converged {
        eprintln!(
            "error: the fit {}; these numbers are not a calibration (exit 3)",
            report.stop
        );
    }
    let worse = report.held_out_worse == Some(true);
    let unfit = unfit(
        worse,
        report.converged,
        "held-out groups",
        "the model it started from",
    );
    report.out = save(
        args.out.as_deref(),
        unfit.as_deref().map_or(Ok(&done.model), Err),
    )?;
    Ok(done.report)
}
