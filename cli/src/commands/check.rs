//! `kinecal check`: validates a robot file and a measurement file and reports how far the
//! nominal model is from the data (docs/formats.md, docs/walkthrough.md); the work is
//! [`crate::calibration::check`].

use super::inputs::InputArgs;
use crate::formats::loading::load_measurements;
use crate::formats::robot_file::RobotFile;
use crate::reports::check::CheckReport;
use crate::reports::path_text;
use crate::with_joints;
use anyhow::anyhow;

/// Arguments of `kinecal check`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file, measurements and their units.
    #[command(flatten)]
    pub input: InputArgs,
}

fn check_with_joints<const N: usize>(
    input: &InputArgs,
    file: &RobotFile,
) -> anyhow::Result<CheckReport> {
    let (robot_path, data_path) = (&input.robot, &input.data);
    let robot = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", robot_path.display()))?;
    let ds = load_measurements::<N, _>(data_path, &input.units, &robot, file.base_known())?;
    let data = path_text(data_path);
    let checked = crate::calibration::check::check(file, robot, &ds, &data)?;
    if let Some(h) = &checked.coupling_hint {
        eprintln!("{}", h.message());
    }
    if let Some(h) = &checked.column_hint {
        eprintln!("{}", h.message(&data));
    }
    if let Some(m) = checked.mirrored_rms_mm {
        eprintln!(
            "hint: {data}: the data fit the nominal robot mirrored ({} mm RMS against {} mm \
             placed rigidly): an axis of the points has its sign flipped or two are exchanged \
             (the x, y, z columns' order and signs, or the --map's); no calibration can \
             fit them",
            crate::output::numfmt::sig(m, 3),
            crate::output::numfmt::sig(checked.nominal.rms_mm, 3)
        );
    }
    if let Some((scale, rms)) = checked.scaled {
        eprintln!(
            "hint: {data}: the data fit the nominal robot scaled by {} ({} mm RMS against {} mm \
             placed rigidly): {}; no calibration can fit them",
            crate::output::numfmt::sig(scale, 3),
            crate::output::numfmt::sig(rms, 3),
            crate::output::numfmt::sig(checked.nominal.rms_mm, 3),
            crate::formats::units::scale_cause(scale)
        );
    }
    Ok(CheckReport::of(
        &checked,
        file,
        &path_text(robot_path),
        &data,
    ))
}

/// Runs the subcommand: the report of the two files.
pub fn run(args: &Args) -> anyhow::Result<CheckReport> {
    let file = RobotFile::load(&args.input.robot)?;
    with_joints!(file.joint_count(), N => check_with_joints::<N>(&args.input, &file))
}
