//! The `kinecal` process ([`main`]): the report printed, the exit status set (docs/formats.md).

use super::{dispatch, Cli};
use crate::reports::ErrorReport;
use clap::Parser;

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

/// The `kinecal` command line: parses the arguments, runs the command, prints its report (text,
/// or one JSON object with `--json`) and exits with status 0, 1 (error), 2 (input refused) or 3
/// (not to be taken as calibrated; the report is still printed). A failing command prints
/// `kinecal: <reason>` on stderr and, with `--json`, `{"error": "<reason>"}` on stdout.
pub fn main() {
    crate::compute::heap::keep_freed_blocks();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => usage_error(e),
    };
    quiet_panics(cli.json);
    // Storage is sized from the problem on the heap (the solver's normal equations included):
    // the main thread's ordinary stack is enough.
    match dispatch(&cli) {
        Ok(report) if report.non_finite().is_some() => {
            let error = ErrorReport::non_finite(report.as_ref()).unwrap_or(ErrorReport {
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
