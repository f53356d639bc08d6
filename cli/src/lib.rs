//! kinecal on the desktop: the `kinecal` command line and the application behind it.
//!
//! Layers, bottom to top (each uses only those before it; `scripts/module_graph.py` checks):
//!
//! - this file: [`Refused`] input (exit status 2), the exit statuses, [`with_joints!`], [`Tell`]
//!   (where an application function's warnings go);
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
//! - [`application`]: application functions that return a report (`identify` in memory);
//! - [`report_html`]: the calibration report, one self-contained HTML page (`report`, `demo`);
//! - [`frames`] and [`compensation`]: the circle-point frames and corrected joint commands, in
//!   memory and from files;
//! - [`constraints`]: calibration from sockets, planes and distances (no tracker);
//! - [`commands`]: one thin module per subcommand; `main.rs` calls [`commands::main`].
//!
//! One engine under every front end: the application functions take what was read (a robot
//! file, measurement sets in mm and degrees, options) and return typed results, telling their
//! warnings to a [`Tell`]; a command module reads the files, calls them, writes the outputs
//! and renders the report, and the Python package (`python/`) calls the same functions on
//! arrays in memory.

pub mod application;
pub mod calibration;
pub mod commands;
pub mod compensation;
pub mod compute;
pub mod constraints;
pub mod diagnose;
pub mod formats;
pub mod frames;
pub mod output;
pub mod plan;
pub mod report_html;
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

/// Where an application function's messages go while it runs: warnings and notes for people,
/// told when they arise (the command line prints each on stderr at once, so that it comes
/// before a later error, as it always has), and the stage a long computation is at (the
/// command line's spinner on a terminal). The functions themselves print nothing.
pub trait Tell {
    /// A warning or a note, as it is to be printed (one or more lines).
    fn line(&mut self, text: &str);
    /// The stage the work is at (ignored unless a front end shows it).
    fn stage(&mut self, _what: &str) {}
}

/// [`Tell`] on stderr: every line printed at once, stages not shown; inside [`captured`],
/// kept for the caller instead.
pub struct Stderr;

impl Tell for Stderr {
    fn line(&mut self, text: &str) {
        let kept = CAPTURED.with(|c| match c.borrow_mut().as_mut() {
            Some(lines) => {
                lines.push(text.to_string());
                true
            }
            None => false,
        });
        if !kept {
            eprintln!("{text}");
        }
    }
}

std::thread_local! {
    /// The lines [`Stderr`] keeps on this thread while [`captured`] runs.
    static CAPTURED: std::cell::RefCell<Option<Vec<String>>> = const { std::cell::RefCell::new(None) };
}

/// Runs `work` with the lines told to [`Stderr`] on this thread kept, not printed: its result
/// and those lines, in order (the Python package raises them as warnings).
pub fn captured<R>(work: impl FnOnce() -> R) -> (R, Vec<String>) {
    /// Puts the outer capture (or none) back when dropped, also when `work` panics.
    struct Restore(Option<Vec<String>>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let outer = self.0.take();
            CAPTURED.with(|c| *c.borrow_mut() = outer);
        }
    }
    let restore = Restore(CAPTURED.with(|c| c.borrow_mut().replace(Vec::new())));
    let r = work();
    let lines = CAPTURED.with(|c| c.borrow_mut().take()).unwrap_or_default();
    drop(restore);
    (r, lines)
}

/// Exit status of a command that ran but whose result must not be trusted as calibrated
/// (`identify` stopped at its iteration limit or stalled): the JSON is still written.
pub const EXIT_NOT_CONVERGED: i32 = 3;
/// Exit status of refused input.
pub const EXIT_REFUSED: i32 = 2;

/// Effect-value capacity of host-side models: room for per-joint tables on every joint.
pub const VCAP: usize = 2048;

pub use compute::host_values::HostValues;

/// The host's robot model: `f64`, `N` joints, up to [`VCAP`] effect values on the heap.
pub type HostRobot<const N: usize> = kinecal::Robot<f64, N, HostValues>;

// Limits on numbers from the command line and the robot file that size work or storage, or
// that no robot can have (docs/formats.md, "Limits"). Input beyond them is refused (exit 2)
// before anything is allocated or computed.

/// Largest length in a robot file (link lengths and offsets, tool, base position): 100 m.
pub const MAX_LENGTH_MM: f64 = 100_000.0;
/// Largest magnitude of a DH angle (alpha, theta, beta) or a base angle in a robot file.
pub const MAX_ANGLE_DEG: f64 = 720.0;
/// Largest magnitude of a joint limit in a robot file (ten turns).
pub const MAX_JOINT_LIMIT_DEG: f64 = 3600.0;
/// Largest magnitude of a joint table's `start_deg`: the largest joint reading a data file
/// may hold ([`kinecal::io::csv::MAX_ABS_JOINT`]), since a table starts at the readings.
/// The bound is in the file's units; in radians it is the widest in degrees.
pub const MAX_TABLE_START_DEG: f64 =
    kinecal::io::csv::MAX_ABS_JOINT * (180.0 / std::f64::consts::PI);
/// Largest magnitude of an effect value in a robot file or on `simulate --effect` (scale,
/// rad, rad per metre): a correction of more than a radian is not a calibration effect.
pub const MAX_EFFECT_VALUE: f64 = 1.0;
/// Largest magnitude of a coupling ratio (degrees per degree).
pub const MAX_COUPLING_RATIO: f64 = 10.0;
/// Smallest knot spacing of a joint table (degrees).
pub const MIN_TABLE_STEP_DEG: f64 = 0.1;
/// Most knots of one joint table.
pub const MAX_TABLE_KNOTS: usize = 1024;
/// Highest harmonic order of a joint-cyclic effect.
pub const MAX_CYCLIC_ORDER: u16 = 64;
/// Most poses `simulate` writes.
pub const MAX_SIMULATED_POSES: usize = 1_000_000;
/// Most points of one simulated sweep.
pub const MAX_SWEEP_POINTS: usize = 100_000;
/// Most poses `plan` selects (the exchange passes grow with poses × pool).
pub const MAX_PLAN_POSES: usize = 2_000;
/// Largest candidate pool of `plan` and `study`.
pub const MAX_POOL: usize = 100_000;
/// Most exchange passes of `plan` and `study`.
pub const MAX_PASSES: u32 = 1_000;
/// Largest noise standard deviation (mm) of `simulate`, `plan` and `study`.
pub const MAX_NOISE_MM: f64 = 1_000.0;
/// Largest magnitude of a joint reading given on the command line (degrees).
pub const MAX_JOINT_READING_DEG: f64 = 3600.0;

/// A number for an error message: `1e308`, not 309 digits.
pub fn number_text(x: f64) -> String {
    if x.is_finite() && x != 0.0 && !(1e-4..1e6).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Refuses (exit 2) a count outside `min..=max`, naming the flag and the limit.
pub fn check_count(flag: &str, n: usize, min: usize, max: usize) -> anyhow::Result<()> {
    if n < min || n > max {
        refuse!("{flag} {n}: must be {min} to {max} (docs/formats.md, \"Limits\")");
    }
    Ok(())
}

/// Refuses (exit 2) a number that is not finite or lies outside `min..=max`.
pub fn check_number(flag: &str, x: f64, min: f64, max: f64) -> anyhow::Result<()> {
    if !(x.is_finite() && x >= min && x <= max) {
        refuse!(
            "{flag} {}: must be a finite number from {min} to {max}",
            number_text(x)
        );
    }
    Ok(())
}

/// Refuses (exit 2) a number that is not finite and strictly positive (at most `max`).
pub fn check_positive(flag: &str, x: f64, max: f64) -> anyhow::Result<()> {
    if !(x.is_finite() && x > 0.0 && x <= max) {
        refuse!(
            "{flag} {}: must be a finite number > 0 and at most {max}",
            number_text(x)
        );
    }
    Ok(())
}

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
