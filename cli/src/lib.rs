//! kinecal on the desktop: the `kinecal` command line and the application behind it.
//!
//! Layers, bottom to top (each uses only those before it; `scripts/module_graph.py` checks):
//!
//! - this file: [`Refused`] input (exit status 2), the exit statuses, [`with_joints!`];
//! - [`output`]: atomic file writes, numbers for people, SVG charts;
//! - [`compute`]: both cores, the LM's storage on the heap, dense factorisations, registration;
//! - [`formats`]: the files users bring and get (robot TOML, measurement CSV, the cell file of
//!   `plan`) with their schema and unit checks;
//! - [`simulation`]: simulated robots, measurements and sweeps with a known truth;
//! - [`calibration`]: identification of a model from measurements (split, base start, LM, PSO,
//!   BPNN-PSO, errors before and after);
//! - [`diagnose`]: the discrepancy workflow (find, name, add the missing effect, show the
//!   held-out gap shrink);
//! - [`plan`]: measurement planning on the desktop (pools, designs, the study);
//! - [`reports`]: every command's report as a typed value (JSON and text from the same fields);
//! - [`frames`] and [`compensation`]: the circle-point frames and corrected joint commands from
//!   files;
//! - [`commands`]: one thin module per subcommand; `main.rs` calls [`commands::main`].

pub mod calibration;
pub mod commands;
pub mod compensation;
pub mod compute;
pub mod diagnose;
pub mod formats;
pub mod frames;
pub mod output;
pub mod plan;
pub mod reports;
pub mod simulation;

/// Input that kinecal refuses (malformed, or implausible in the units assumed): the command
/// exits with status 2 and the one-line reason (docs/formats.md). Wrap the reason with
/// [`refused`] or the [`refuse!`] macro; `main` finds it anywhere in an error's chain.
#[derive(Debug)]
pub struct Refused(pub String);

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Refused {}

/// An [`anyhow::Error`] that makes the command exit with status 2 (input refused).
pub fn refused(reason: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(Refused(reason.into()))
}

/// `refuse!("fmt", args…)`: returns early with a [`Refused`] error (exit status 2).
#[macro_export]
macro_rules! refuse {
    ($($t:tt)*) => {
        return Err($crate::refused(format!($($t)*)))
    };
}

/// Exit status of a command that ran but whose result must not be trusted as calibrated
/// (`identify` stopped at its iteration limit or stalled): the JSON is still written.
pub const EXIT_NOT_CONVERGED: i32 = 3;
/// Exit status of refused input.
pub const EXIT_REFUSED: i32 = 2;

/// Effect-value capacity of host-side models: room for per-joint tables on every joint.
pub const VCAP: usize = 2048;

/// Runs `$body` with a const `N` equal to the runtime joint count `$n` (2..=8 supported),
/// or evaluates to an error for other counts.
#[macro_export]
macro_rules! with_joints {
    ($n:expr, $N:ident => $body:expr) => {
        match $n {
            2 => {
                const $N: usize = 2;
                $body
            }
            3 => {
                const $N: usize = 3;
                $body
            }
            4 => {
                const $N: usize = 4;
                $body
            }
            5 => {
                const $N: usize = 5;
                $body
            }
            6 => {
                const $N: usize = 6;
                $body
            }
            7 => {
                const $N: usize = 7;
                $body
            }
            8 => {
                const $N: usize = 8;
                $body
            }
            n => Err(anyhow::anyhow!(
                "robots with {} joints are not supported (2 to 8)",
                n
            )),
        }
    };
}
