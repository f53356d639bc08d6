//! A model written by `identify` and `diagnose` (`--out`) only when it is a calibration: a
//! model that predicts unseen poses worse than the one it started from, or numbers that are
//! no calibration, are not written, so that nothing a later step (`validate`, `export` to the
//! controller) could take for a calibration is left behind.

use crate::formats::robot_file::RobotFile;
use std::path::Path;

/// Writes the model to `out` (when given), or, when `model` is the reason it is no
/// calibration, tells that reason on stderr as a note instead. Returns the path written, as
/// the reports give it.
pub fn save(out: Option<&Path>, model: Result<&RobotFile, &str>) -> anyhow::Result<Option<String>> {
    let Some(out) = out else {
        return Ok(None);
    };
    match model {
        Ok(model) => {
            model.save(out)?;
            Ok(Some(out.display().to_string()))
        }
        Err(why) => {
            eprintln!("note: {} not written: {why}", out.display());
            Ok(None)
        }
    }
}

/// Why a fit's model is no calibration (`None`: it is one): it predicts the `unseen` poses (or groups) worse than
/// the model it started from (`started`), or the fit did not converge.
pub fn unfit(held_out_worse: bool, converged: bool, unseen: &str, started: &str) -> Option<String> {
    if held_out_worse {
        Some(format!(
            "the model predicts the {unseen} worse than {started}"
        ))
    } else if !converged {
        Some(NOT_A_CALIBRATION.to_string())
    } else {
        None
    }
}

/// The note's reason for a fit that did not converge.
pub const NOT_A_CALIBRATION: &str = "these numbers are not a calibration";
