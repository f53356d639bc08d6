//! The reports of the `kinecal` subcommands as typed values: one struct per command, built
//! from the application's results, that serialises to the command's `--json` object (the keys
//! of docs/formats.md) and renders the human text (`Display`) from the very same fields.
//!
//! A command's `run` returns its report; `main` prints it as text, or as one JSON object with
//! `--json` ([`Report::to_json`]), and takes the exit status from [`Report::converged`]
//! (`false`: exit 3, the numbers must not be taken as a calibration). A failing command prints
//! [`ErrorReport`] with `--json`.
//!
//! Tests build and inspect a report without running a command: for example
//! [`diagnose::DiagnoseReport::of`] from a [`crate::diagnose::Diagnosis`].

pub mod check;
pub mod compensate;
pub mod demo;
pub mod diagnose;
pub mod finite;
pub mod frames;
pub mod identify;
pub mod model_out;
pub mod plan;
pub mod simulate;
pub mod study;
pub mod urdf;
pub mod validate;

pub use check::CheckReport;
pub use compensate::CompensateReport;
pub use demo::DemoReport;
pub use diagnose::DiagnoseReport;
pub use frames::FramesReport;
pub use identify::IdentifyReport;
pub use plan::PlanReport;
pub use simulate::SimulateReport;
pub use study::StudyReport;
pub use urdf::{ExportReport, ImportReport};
pub use validate::ValidateReport;

use serde::Serialize;
use std::fmt;

/// What `main` needs of every command's report.
pub trait Report: fmt::Display {
    /// The `--json` object. Its keys are sorted (a `serde_json::Map`), as the command line has
    /// always printed them.
    fn to_json(&self) -> serde_json::Value;
    /// Whether the result may be taken as calibrated; `false` makes the command exit with
    /// status 3 ([`crate::EXIT_NOT_CONVERGED`]) after printing the report.
    fn converged(&self) -> bool {
        true
    }
    /// The first figure of the report that is not a finite number (`NaN`, ±∞: JSON would
    /// print `null`), by its path; `main` exits with status 1 instead of printing such a
    /// report as a result. Implement with [`finite::first_non_finite`].
    fn non_finite(&self) -> Option<String>;
}

/// The JSON value of a serialisable report (`null` if it cannot be represented, which no
/// report of this module does: their maps have string keys).
pub fn json_value<T: Serialize>(report: &T) -> serde_json::Value {
    serde_json::to_value(report).unwrap_or(serde_json::Value::Null)
}

/// `json` (a report's object) with the key `accepted`: whether `report` may be taken as
/// calibrated, as the exit status says ([`Report::converged`]). A report's own `converged`
/// says only that its fit converged; `accepted` is false too when the model predicts the
/// held-out poses worse than the nominal robot (`held_out_worse`).
pub fn with_accepted(mut json: serde_json::Value, report: &dyn Report) -> serde_json::Value {
    if let Some(m) = json.as_object_mut() {
        m.insert("accepted".to_string(), report.converged().into());
    }
    json
}

/// Implements [`Report`] for report structs that are always "converged".
macro_rules! plain_report {
    ($($t:ty),*) => {
        $(impl $crate::reports::Report for $t {
            fn to_json(&self) -> serde_json::Value {
                $crate::reports::json_value(self)
            }
            fn non_finite(&self) -> Option<String> {
                $crate::reports::finite::first_non_finite(self)
            }
        })*
    };
}
pub(crate) use plain_report;

/// Implements [`Report`] for a report struct whose verdict is `converged` (an expression of
/// the report bound to the given name); its JSON carries the verdict as `accepted`.
macro_rules! judged_report {
    ($t:ty, |$r:ident| $converged:expr) => {
        impl $crate::reports::Report for $t {
            fn to_json(&self) -> serde_json::Value {
                $crate::reports::with_accepted($crate::reports::json_value(self), self)
            }
            fn converged(&self) -> bool {
                let $r = self;
                $converged
            }
            fn non_finite(&self) -> Option<String> {
                $crate::reports::finite::first_non_finite(self)
            }
        }
    };
}
pub(crate) use judged_report;

/// The `--json` object of a failing command: `{"error": "<the one-line reason>"}`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ErrorReport {
    pub error: String,
}

impl ErrorReport {
    /// The report of `e`: its whole chain on one line, as `kinecal: …` on stderr shows it.
    pub fn of(e: &anyhow::Error) -> Self {
        Self { error: one_line(e) }
    }

    /// The error that replaces a report with a figure that is not a finite number (the command
    /// exits with status 1), `None` when every figure is finite.
    pub fn non_finite(report: &dyn Report) -> Option<Self> {
        let field = report.non_finite()?;
        Some(ErrorReport {
            error: format!(
                "the result is not a finite number ({field}): the inputs are out of any plausible \
                 range for a calibration; check the magnitudes and units of the robot file and the \
                 data"
            ),
        })
    }
}

impl fmt::Display for ErrorReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "kinecal: {}", terminal_safe(&self.error))
    }
}

/// An error's whole chain (`outer: inner: …`) on one line, safe for a terminal
/// ([`terminal_safe`]).
pub fn one_line(e: &anyhow::Error) -> String {
    terminal_safe(&format!("{e:#}").replace('\n', " "))
}

/// Longest message printed (characters); the rest is counted, not shown.
pub const MAX_MESSAGE_CHARS: usize = 1000;

/// `text` with every control character (an escape sequence, a carriage return from a file or
/// a name) written as `\u{…}`, and cut after [`MAX_MESSAGE_CHARS`] characters: a message
/// quoting hostile input cannot move the cursor, recolour the terminal or fill the screen.
pub fn terminal_safe(text: &str) -> String {
    let mut out = String::with_capacity(text.len().min(4 * MAX_MESSAGE_CHARS));
    for (shown, c) in text.chars().enumerate() {
        if shown == MAX_MESSAGE_CHARS {
            let rest = text.chars().count() - shown;
            out.push_str(&format!("… ({rest} more characters)"));
            break;
        }
        if c.is_control() {
            out.push_str(&c.escape_unicode().to_string());
        } else {
            out.push(c);
        }
    }
    out
}

/// A path as reports show it.
pub(crate) fn path_text(p: &std::path::Path) -> String {
    p.display().to_string()
}

/// A frame as reports give it: position (mm) and fixed-axis roll, pitch, yaw (degrees).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameReport {
    pub xyz_mm: [f64; 3],
    pub rpy_deg: [f64; 3],
}
