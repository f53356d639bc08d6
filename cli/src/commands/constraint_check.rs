//! `kinecal check` on a constraint file: reads the robot file and the session, runs
//! [`crate::constraints::check::check`] and returns its report.

use super::check::Args;
use crate::constraints::check::check;
use crate::constraints::read;
use crate::constraints::report::ConstraintCheckReport;
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::reports::path_text;
use crate::with_joints;

/// Runs `check` on the constraint file `args.input.data`.
pub fn run(args: &Args) -> anyhow::Result<ConstraintCheckReport> {
    let n = RobotFile::load(&args.input.robot)?.joint_count();
    with_joints!(n, N => run_with_joints::<N>(args))
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ConstraintCheckReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let session = read::load::<N>(&input.data, &input.units, &file.tool_names())?;
    let data = path_text(&input.data);
    crate::constraints::shapes::check_lengths(&nominal, &session.groups, &data)?;
    let checked = check(&file, &nominal, &session, &data)?;
    Ok(ConstraintCheckReport::of(
        &checked,
        &path_text(&input.robot),
        &data,
    ))
}
