//! The `kinecal` subcommands, one module each, and [`main`]: the command line itself.
//!
//! Each module holds its clap arguments and a `run` that reads the command's files, calls the
//! application function on what it read (in the domain modules: [`crate::calibration`],
//! [`crate::diagnose`], [`crate::compensation`], [`crate::frames`], [`crate::plan`],
//! [`crate::simulation`]; the Python package calls the same functions on arrays), writes the
//! command's output files and returns its typed report ([`crate::reports`]); `main` prints the
//! report as text or, with `--json`, as one JSON object, and sets the exit status
//! (docs/formats.md).

pub mod check;
pub mod compensate;
pub mod constraint_check;
pub mod constraint_diagnose;
pub mod constraint_identify;
pub mod constraint_plan;
pub mod constraint_report;
pub mod constraint_validate;
pub mod demo;
pub mod diagnose;
pub mod export;
pub mod frames;
pub mod identify;
pub mod import;
pub mod inputs;
pub mod plan;
pub mod report;
pub mod simulate;
pub mod study;
pub mod validate;

mod process;
mod spinner;

pub use process::{exit_status, main};
pub(crate) use spinner::Spinner;

use crate::reports::Report;
use clap::{Parser, Subcommand};

/// The command line: `--json` and one subcommand (also parsed by the Python package, for the
/// options of the functions it calls).
#[derive(Parser, Debug)]
#[command(
    name = "kinecal",
    version,
    about = "Kinematic calibration of serial robot arms"
)]
pub struct Cli {
    /// Print exactly one JSON object on stdout (logs and progress go to stderr).
    #[arg(long, global = true)]
    pub json: bool,
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands with their arguments.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Validate a robot file and a measurement file; nominal RMS error.
    Check(check::Args),
    /// The BPNN-PSO paper's simulation end to end on built-in data.
    Demo(demo::Args),
    /// Make measurement data from a robot with known errors.
    Simulate(simulate::Args),
    /// Fit the model to measurements (LM, PSO, BPNN-PSO, PSO+LM).
    Identify(identify::Args),
    /// Find and name what the geometric model is missing.
    Diagnose(diagnose::Args),
    /// Base frame and tool distances from single-joint sweeps.
    Frames(frames::Args),
    /// Corrected joint commands for target points.
    Compensate(compensate::Args),
    /// Choose measurement poses (optimum experimental design).
    Plan(plan::Args),
    /// The planning study of Jost et al. 2017: KPI vs random vs D-optimal over 90 manipulators.
    Study(study::Args),
    /// A URDF's serial chain as an MDH robot file (`import --urdf F.urdf --out R.toml`).
    Import(import::Args),
    /// A calibrated model into the robot's URDF, or as a table of DH parameters.
    Export(export::Args),
    /// The calibration report: one self-contained HTML page (before/after, parameters,
    /// findings).
    Report(report::Args),
    /// A calibrated model on another session's data: only the registration (base, tool) is
    /// fitted, then model and nominal robot are compared (exit 3 when the model is worse).
    Validate(validate::Args),
}

fn boxed<R: Report + 'static>(r: anyhow::Result<R>) -> anyhow::Result<Box<dyn Report>> {
    r.map(|r| Box::new(r) as Box<dyn Report>)
}

/// Runs the subcommand of `cli` and returns its report (nothing printed but its warnings).
pub fn dispatch(cli: &Cli) -> anyhow::Result<Box<dyn Report>> {
    match &cli.command {
        Command::Check(a) if crate::constraints::read::is_constraint_file(&a.input.data) => {
            boxed(constraint_check::run(a))
        }
        Command::Check(a) => boxed(check::run(a)),
        Command::Demo(a) => boxed(demo::run(a)),
        Command::Simulate(a) => boxed(simulate::run(a)),
        Command::Identify(a) if crate::constraints::read::is_constraint_file(&a.input.data) => {
            boxed(constraint_identify::run(a))
        }
        Command::Identify(a) => boxed(identify::run(a)),
        Command::Diagnose(a) if crate::constraints::read::is_constraint_file(&a.input.data) => {
            boxed(constraint_diagnose::run(a))
        }
        Command::Diagnose(a) => boxed(diagnose::run(a)),
        Command::Frames(a) => boxed(frames::run(a)),
        Command::Compensate(a) => boxed(compensate::run(a)),
        Command::Plan(a) if a.constraints.is_some() => boxed(constraint_plan::run(a)),
        Command::Plan(a) => boxed(plan::run(a)),
        Command::Study(a) => boxed(study::run(a)),
        Command::Import(a) => boxed(import::run(a)),
        Command::Export(a) => boxed(export::run(a, cli.json)),
        Command::Report(a) if crate::constraints::read::is_constraint_file(&a.input.data) => {
            boxed(constraint_report::run(a))
        }
        Command::Report(a) => boxed(report::run(a)),
        Command::Validate(a) if crate::constraints::read::is_constraint_file(&a.input.data) => {
            boxed(constraint_validate::run(a))
        }
        Command::Validate(a) => boxed(validate::run(a)),
    }
}
