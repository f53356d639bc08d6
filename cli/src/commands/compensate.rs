//! `kinecal compensate`: joint commands that bring the identified robot to target points or
//! poses; the work is [`crate::compensation`], the file formats are in docs/formats.md.
//!
//! Targets file: `q1`…`qN` (the seed: the controller's nominal joints, degrees), `x`,`y`,`z`
//! (target point, mm, measurement frame), optionally `rx`,`ry`,`rz` (degrees, fixed-axis
//! roll/pitch/yaw of the tool orientation) for a full pose target. Output: `q1`…`qN` in the
//! angle unit of the targets, `status`, `error_mm`, `error_deg`. With `--robot NOMINAL
//! --cartesian`: instead of joints, the targets to send to a controller that keeps the nominal
//! kinematics (`x`, `y`, `z`[, `rx`, `ry`, `rz`] in the targets' units, `status`).

use crate::compensation::{Job, Settings};
use crate::formats::units::UnitArgs;
use crate::reports::compensate::CompensateReport;
use std::path::PathBuf;

/// Arguments of `kinecal compensate` (docs/formats.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Identified robot model (TOML, docs/formats.md), effects included.
    #[arg(long)]
    pub model: PathBuf,
    /// Targets (CSV): q1..qN seed, x, y, z, optionally rx, ry, rz; in mm and degrees unless
    /// --length-unit / --angle-unit say otherwise.
    #[arg(long)]
    pub targets: PathBuf,
    /// Output CSV: q1..qN in the targets' angle unit (degrees, or radians with
    /// --angle-unit rad or a --map's joints = "rad"), status, error_mm (mm), error_deg
    /// (degrees).
    #[arg(long)]
    pub out: PathBuf,
    /// Most damped Newton steps per target.
    #[arg(long, default_value_t = Settings::default().iterations)]
    pub iterations: u8,
    /// Largest accepted correction per joint, |command − seed| (degrees).
    #[arg(long, default_value_t = Settings::default().max_step_deg)]
    pub max_step_deg: f64,
    /// Remaining model error (mm; orientation scaled by the reach) above which a target fails.
    #[arg(long, default_value_t = Settings::default().accept_mm)]
    pub accept_mm: f64,
    /// The nominal robot (TOML) whose kinematics the controller keeps: with --cartesian.
    #[arg(long)]
    pub robot: Option<PathBuf>,
    /// Write, instead of joint commands, the point (and orientation for pose targets) that the
    /// nominal robot (--robot), placed at the model's [base], reaches at the compensated joints:
    /// the targets to send to a controller that keeps its nominal model (columns x, y, z[, rx,
    /// ry, rz] in the targets' units, then status).
    #[arg(long, requires = "robot")]
    pub cartesian: bool,
    /// A model row further than this from --robot's (mm) is taken for a model of another
    /// robot and refused, as by `export` (with --cartesian).
    #[arg(long, default_value_t = crate::application::export::MATCH_TOLERANCE_MM)]
    pub tolerance_mm: f64,
    /// The same for angles, degrees.
    #[arg(long, default_value_t = crate::application::export::MATCH_TOLERANCE_DEG)]
    pub tolerance_deg: f64,
    /// The reflector the targets are for: a [[tools]] name of the model (default its first;
    /// a model with several warns).
    #[arg(long, value_name = "NAME")]
    pub tool: Option<String>,
    /// Rows are a trajectory: warm-start each from the previous row's correction.
    #[arg(long)]
    pub stream: bool,
    /// Compute in single precision, as the controller does.
    #[arg(long)]
    pub f32: bool,
    /// Units of the targets file, and of the joint commands written (never second-guessed
    /// when given).
    #[command(flatten)]
    pub units: UnitArgs,
}

impl Args {
    /// The compensation run these arguments ask for.
    pub fn job(&self) -> Job {
        Job {
            model: self.model.clone(),
            targets: self.targets.clone(),
            out: self.out.clone(),
            settings: Settings {
                iterations: self.iterations,
                max_step_deg: self.max_step_deg,
                accept_mm: self.accept_mm,
                stream: self.stream,
                f32: self.f32,
            },
            units: self.units.clone(),
            cartesian: self.cartesian.then(|| self.robot.clone()).flatten(),
            tolerance: (self.tolerance_mm, self.tolerance_deg),
            tool: self.tool.clone(),
        }
    }
}

/// Runs the subcommand: writes the joint commands and returns the summary.
pub fn run(args: &Args) -> anyhow::Result<CompensateReport> {
    if args.robot.is_some() && !args.cartesian {
        crate::refuse!(
            "--robot names the nominal robot of --cartesian: add --cartesian, or drop --robot for joint commands"
        );
    }
    let r = crate::compensation::run(&args.job())?;
    if !r.base_known {
        eprintln!(
            "kinecal compensate: {} has no [base]: targets are taken in the robot base frame",
            args.model.display()
        );
    }
    if let Some(e) = &r.error {
        eprintln!("error: {e}");
    }
    if let Some(h) = &r.hint {
        eprintln!("{h}");
    }
    if let Some(w) = &r.temperature_warning {
        eprintln!("warning: {w}");
    }
    Ok(r)
}
