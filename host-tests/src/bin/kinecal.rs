//! `kinecal`: robot calibration from the command line (interfaces.md §4).

use clap::{Parser, Subcommand};
use kinecal_host::cli;

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
    Check(cli::check::Args),
    /// The BPNN-PSO paper's simulation end to end on built-in data.
    Demo(cli::demo::Args),
    /// Make measurement data from a robot with known errors.
    Simulate(cli::simulate::Args),
    /// Fit the model to measurements (LM, PSO, BPNN-PSO, PSO+LM).
    Identify(cli::identify::Args),
    /// Find and name what the geometric model is missing.
    Diagnose(cli::diagnose::Args),
    /// Base frame and tool distances from single-joint sweeps.
    Frames(cli::frames::Args),
    /// Corrected joint commands for target points.
    Compensate(cli::compensate::Args),
    /// Choose measurement poses (optimum experimental design).
    Plan(cli::plan::Args),
    /// The planning study of Jost et al. 2017: KPI vs random vs D-optimal over 90 manipulators.
    Study(cli::study::Args),
}

fn dispatch(cli: Cli) -> anyhow::Result<serde_json::Value> {
    let j = cli.json;
    match &cli.command {
        Command::Check(a) => cli::check::run(a, j),
        Command::Demo(a) => cli::demo::run(a, j),
        Command::Simulate(a) => cli::simulate::run(a, j),
        Command::Identify(a) => cli::identify::run(a, j),
        Command::Diagnose(a) => cli::diagnose::run(a, j),
        Command::Frames(a) => cli::frames::run(a, j),
        Command::Compensate(a) => cli::compensate::run(a, j),
        Command::Plan(a) => cli::plan::run(a, j),
        Command::Study(a) => cli::study::run(a, j),
    }
}

fn main() {
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
                std::process::exit(kinecal_host::EXIT_NOT_CONVERGED);
            }
        }
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("kinecal: {msg}");
            let refused = e.chain().any(|c| c.is::<kinecal_host::Refused>());
            std::process::exit(if refused {
                kinecal_host::EXIT_REFUSED
            } else {
                1
            });
        }
    }
}
