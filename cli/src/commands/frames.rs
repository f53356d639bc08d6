//! `kinecal frames`: base frame and tool distances from single-joint sweeps (the circle-point
//! method; the work is [`crate::frames`], the file format docs/formats.md).
//!
//! The measurement file has an extra column `sweep` naming the joint (1-based) turned on each
//! row; rows with an empty cell or 0 there are ignored. Joints 1 and 2 give the base pose,
//! the last two joints the tool's radial and axial distances from the flange axis.

use super::inputs::InputArgs;
use crate::reports::frames::FramesReport;
use std::path::PathBuf;

/// Arguments of `kinecal frames` (docs/formats.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file (its `[base]`, if any, is ignored), sweep measurements (CSV: q1…qN, x, y, z
    /// and `sweep` = the joint turned on that row) and their units.
    #[command(flatten)]
    pub input: InputArgs,
    /// Write the robot file with `[base]` set to the pose found.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs the subcommand: the frames found (warnings also on stderr).
pub fn run(args: &Args) -> anyhow::Result<FramesReport> {
    let r = crate::frames::from_files(
        &args.input.robot,
        &args.input.data,
        &args.input.units,
        args.out.as_deref(),
    )?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    Ok(r)
}
