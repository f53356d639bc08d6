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
pub mod constraint_identify;
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

use crate::reports::{ErrorReport, Report};
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

/// The command line's [`crate::Tell`]: each line on stderr at once, and the stage in a spinner
/// with the time spent, `{command} {spinner} {stage} {elapsed}` (drawn only when stderr is a
/// terminal, as PSO's and `study`'s bars), from the first stage until it is dropped.
pub(crate) struct Spinner {
    command: &'static str,
    bar: Option<indicatif::ProgressBar>,
}

impl Spinner {
    pub(crate) fn new(command: &'static str) -> Self {
        Self { command, bar: None }
    }
}

impl crate::Tell for Spinner {
    fn line(&mut self, text: &str) {
        eprintln!("{text}");
    }
    fn stage(&mut self, what: &str) {
        let command = self.command;
        let bar = self.bar.get_or_insert_with(|| {
            let bar = indicatif::ProgressBar::new_spinner();
            bar.set_style(
                indicatif::ProgressStyle::with_template(&format!(
                    "{command} {{spinner}} {{msg}} {{elapsed}}"
                ))
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            bar.enable_steady_tick(std::time::Duration::from_millis(120));
            bar
        });
        bar.set_message(what.to_string());
    }
}

impl Drop for Spinner {
    fn drop(&mut self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
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
        Command::Diagnose(a) => boxed(diagnose::run(a)),
        Command::Frames(a) => boxed(frames::run(a)),
        Command::Compensate(a) => boxed(compensate::run(a)),
        Command::Plan(a) => boxed(plan::run(a)),
        Command::Study(a) => boxed(study::run(a)),
        Command::Import(a) => boxed(import::run(a)),
        Command::Export(a) => boxed(export::run(a, cli.json)),
        Command::Report(a) => boxed(report::run(a)),
        Command::Validate(a) if crate::constraints::read::is_constraint_file(&a.input.data) => {
            boxed(constraint_validate::run(a))
        }
        Command::Validate(a) => boxed(validate::run(a)),
    }
}

fn print_json(v: &serde_json::Value) {
    let text = serde_json::to_string_pretty(v).unwrap_or_else(|_| "{}".into());
    print_stdout(&format!("{text}\n"));
}

/// Writes `text` to stdout. A reader that closed the pipe early (`kinecal … | head`) ends the
/// program quietly with the status it would have had; another write error is reported on
/// stderr with status 1 (no panic either way).
fn print_stdout(text: &str) {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            eprintln!("kinecal: cannot write the report to stdout: {e}");
            std::process::exit(1);
        }
    }
}

/// The `kinecal` command line: parses the arguments, runs the command, prints its report
/// (text, or one JSON object with `--json`) and exits with status 0, 1 (error), 2 (input
/// refused) or 3 (the result must not be taken as calibrated; the report is still printed).
/// A failing command prints `kinecal: <reason>` on stderr and, with `--json`,
/// `{"error": "<reason>"}` on stdout.
pub fn main() {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => usage_error(e),
    };
    quiet_panics(cli.json);
    // Storage is sized from the problem on the heap (the solver's normal equations included):
    // the main thread's ordinary stack is enough.
    match dispatch(&cli) {
        Ok(report) if report.non_finite().is_some() => {
            let error = non_finite_error(report.as_ref()).unwrap_or(ErrorReport {
                error: String::new(),
            });
            eprintln!("{error}");
            if cli.json {
                print_json(&crate::reports::json_value(&error));
            }
            std::process::exit(1);
        }
        Ok(report) => {
            if cli.json {
                print_json(&report.to_json());
            } else {
                print_stdout(&report.to_string());
            }
            if !report.converged() {
                std::process::exit(crate::EXIT_NOT_CONVERGED);
            }
        }
        Err(e) => {
            let error = ErrorReport::of(&e);
            eprintln!("{error}");
            if cli.json {
                print_json(&crate::reports::json_value(&error));
            }
            std::process::exit(exit_status(&e));
        }
    }
}

/// A command line clap cannot parse (an unknown flag, a value outside its choices): clap's
/// message on stderr and exit status 2, as clap itself does; with `--json` among the arguments
/// also `{"error": "<its first line>"}` on stdout, as every other failure prints. `--help` and
/// `--version` print as usual.
fn usage_error(e: clap::Error) -> ! {
    use clap::error::ErrorKind;
    let json = std::env::args_os().any(|a| a == "--json");
    if !json
        || matches!(
            e.kind(),
            ErrorKind::DisplayHelp
                | ErrorKind::DisplayVersion
                | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
        )
    {
        e.exit()
    }
    let text = e.render().to_string();
    eprint!("{text}");
    let reason: Vec<&str> = text
        .lines()
        .map(str::trim)
        .take_while(|l| !l.is_empty())
        .collect();
    let error = ErrorReport {
        error: reason.join(" ").trim_start_matches("error: ").to_string(),
    };
    print_json(&crate::reports::json_value(&error));
    std::process::exit(crate::EXIT_REFUSED);
}

/// The error that replaces a report with a figure that is not a finite number (the command
/// exits with status 1), `None` when every figure is finite.
pub fn non_finite_error(report: &dyn Report) -> Option<ErrorReport> {
    let field = report.non_finite()?;
    Some(ErrorReport {
        error: format!(
            "the result is not a finite number ({field}): the inputs are out of any plausible \
             range for a calibration; check the magnitudes and units of the robot file and the \
             data"
        ),
    })
}

/// A last line of defence: a panic (a bug: every input problem is meant to be refused with a
/// reason first) prints one line `kinecal: internal error: …` (and `{"error": …}` with
/// `--json`) and exits with status 1, never a backtrace, whatever `RUST_BACKTRACE` says.
fn quiet_panics(json: bool) {
    std::panic::set_hook(Box::new(move |info| {
        let what = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        let place = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        let error = ErrorReport {
            error: format!(
                "internal error: {what}{place} (a bug: please report it with the command line)"
            ),
        };
        eprintln!("{error}");
        if json {
            print_json(&crate::reports::json_value(&error));
        }
        std::process::exit(1);
    }));
}

/// The exit status of a failed command: 2 when the input was refused
/// ([`crate::Refused`] anywhere in the chain), 1 otherwise.
pub fn exit_status(e: &anyhow::Error) -> i32 {
    if e.chain().any(|c| c.is::<crate::Refused>()) {
        crate::EXIT_REFUSED
    } else {
        1
    }
}
