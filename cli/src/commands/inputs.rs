//! The arguments most subcommands share: the robot file, the data file and their units.

use crate::formats::units::UnitArgs;
use std::path::PathBuf;

/// `--robot`, `--data`, `--length-unit`, `--angle-unit` (flatten into a subcommand's
/// arguments with `#[command(flatten)]`).
#[derive(clap::Args, Debug, Clone, PartialEq, Eq)]
pub struct InputArgs {
    /// Robot description (TOML, docs/formats.md). Without `[base]` the base pose is fitted to
    /// the data (`frames` finds it from the sweeps and ignores a `[base]` given).
    #[arg(long)]
    pub robot: PathBuf,
    /// Measurements (CSV: q1…qN, x, y, z; for `frames` also `sweep`, the joint turned on each
    /// row; docs/formats.md).
    #[arg(long)]
    pub data: PathBuf,
    /// Units of the data files (never second-guessed when given).
    #[command(flatten)]
    pub units: UnitArgs,
}

impl InputArgs {
    /// The robot file and data file in the default units (mm, degrees: checked, not assumed).
    pub fn new(robot: impl Into<PathBuf>, data: impl Into<PathBuf>) -> Self {
        Self {
            robot: robot.into(),
            data: data.into(),
            units: UnitArgs::default(),
        }
    }
}

/// `rows` when there is at least one; a file with a header and no rows is refused (exit 2)
/// naming it, wherever a command reads measurements.
pub fn some_rows<T>(rows: Vec<T>, path: &std::path::Path) -> anyhow::Result<Vec<T>> {
    if rows.is_empty() {
        crate::refuse!(
            "{}: no measurement rows (only a header?): give a file with measured poses",
            path.display()
        );
    }
    Ok(rows)
}
