//! The `kinecal` subcommands, one module each, and [`main`]: the command line itself.

pub mod check;
pub mod compensate;
pub mod demo;
pub mod diagnose;
pub mod frames;
pub mod identify;
pub mod plan;
pub mod simulate;
pub mod study;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "kinecal",
    version,
    about = "Kinematic calibration of serial robot arms"
)]
struct Cli {
    /// Print exactly one JSON object on stdout (logs and progress go to stderr).
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
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
}

fn dispatch(cli: Cli) -> anyhow::Result<serde_json::Value> {
    let j = cli.json;
    match &cli.command {
        Command::Check(a) => check::run(a, j),
        Command::Demo(a) => demo::run(a, j),
        Command::Simulate(a) => simulate::run(a, j),
        Command::Identify(a) => identify::run(a, j),
        Command::Diagnose(a) => diagnose::run(a, j),
        Command::Frames(a) => frames::run(a, j),
        Command::Compensate(a) => compensate::run(a, j),
        Command::Plan(a) => plan::run(a, j),
        Command::Study(a) => study::run(a, j),
    }
}

/// The `kinecal` command line: parses the arguments, runs the command, prints and exits with
/// the status of interfaces.md §4.
pub fn main() {
    let cli = Cli::parse();
    let json = cli.json;
    // Storage is sized from the problem on the heap (the solver's normal equations included):
    // the main thread's ordinary stack is enough.
    let result = dispatch(cli);
    match result {
        Ok(v) => {
            if json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&v).unwrap_or_else(|_| "{}".into())
                );
            }
            // A result that must not be taken as calibrated (interfaces.md §4: exit 3).
            if v.get("converged") == Some(&serde_json::Value::Bool(false)) {
                std::process::exit(crate::EXIT_NOT_CONVERGED);
            }
        }
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("kinecal: {msg}");
            let refused = e.chain().any(|c| c.is::<crate::Refused>());
            std::process::exit(if refused { crate::EXIT_REFUSED } else { 1 });
        }
    }
}
