//! The arguments most subcommands share: the robot file, the data file and their units.

use crate::formats::units::UnitArgs;
use crate::HostRobot;
use std::path::PathBuf;

pub use crate::calibration::inputs::{any_rows, place_nominal, some_rows, split_sets, HoldoutArgs};

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

/// The observations of the measurement file `path`, read in the units of `input` for the robot
/// file `file` and its model `nominal` (the stated base, the angle order: the loader's doors).
pub fn load_observed<const N: usize>(
    path: &std::path::Path,
    input: &InputArgs,
    (file, nominal): (&crate::formats::robot_file::RobotFile, &HostRobot<N>),
    obs: &crate::formats::observations::ObservationArgs,
) -> anyhow::Result<crate::formats::observations::Observed<N>> {
    load_observed_for(path, input, (file, nominal), obs, None)
}

/// [`load_observed`], also telling which joint tables of a calibrated `model` (its file named)
/// miss the file's readings ([`crate::formats::table_reach`]), as `validate` does.
fn load_observed_for<const N: usize>(
    path: &std::path::Path,
    input: &InputArgs,
    (file, nominal): (&crate::formats::robot_file::RobotFile, &HostRobot<N>),
    obs: &crate::formats::observations::ObservationArgs,
    model: Option<(&HostRobot<N>, &std::path::Path)>,
) -> anyhow::Result<crate::formats::observations::Observed<N>> {
    let ds =
        crate::formats::loading::load_measurements(path, &input.units, nominal, file.base_known())?;
    if let Some((m, origin)) = model {
        let (data, model) = (path.display().to_string(), origin.display().to_string());
        // A table the robot file has too, with the same knots, was told about with it.
        let reach = crate::formats::table_reach::in_robot_file(nominal);
        let named = (data.as_str(), Some(model.as_str()));
        for line in crate::formats::table_reach::lines_except(&ds, m, named, reach) {
            crate::Tell::line(&mut crate::Stderr, &line);
        }
    }
    warn_outside_limits(
        crate::calibration::check::OutsideLimits::of(file, &ds),
        ds.len(),
        path,
        &input.robot,
    );
    crate::formats::observations::observe(&ds, file, obs, &path.display().to_string())
}

/// A refusal of the `--validate` file that suggests a unit flag, saying that the flags apply
/// to both files (following it alone would read the data file in that unit too).
pub fn units_alike(e: anyhow::Error) -> anyhow::Error {
    let text = e.to_string();
    if e.downcast_ref::<crate::Refused>().is_some()
        && (text.contains("--length-unit") || text.contains("--angle-unit"))
    {
        crate::refused(format!(
            "{text} (the unit flags apply to --data and --validate alike: give the --validate \
             file in the data file's units)"
        ))
    } else {
        e
    }
}

/// Loads the data (and `validate`) in the units of `input` and splits them: the validation
/// file's poses are held out, or those `holdout` chooses; refuses (exit 2) empty files and a
/// split that leaves nothing to identify from. The joint tables of the calibrated `model` (its
/// file named) are checked against each file's readings.
pub fn load_split<const N: usize>(
    input: &InputArgs,
    (file, nominal): (&crate::formats::robot_file::RobotFile, &HostRobot<N>),
    model: (&HostRobot<N>, &std::path::Path),
    obs: &crate::formats::observations::ObservationArgs,
    validate: Option<&std::path::Path>,
    holdout: (&HoldoutArgs, u64),
) -> anyhow::Result<crate::calibration::inputs::Split<N>> {
    let load = |p: &std::path::Path| load_observed_for(p, input, (file, nominal), obs, Some(model));
    let observed = load(&input.data)?;
    any_rows(&observed.poses, &input.data)?;
    let validate = match validate {
        Some(v) => Some((load(v).map_err(units_alike)?, v.display().to_string())),
        None => None,
    };
    crate::calibration::inputs::split_observed(
        observed,
        validate,
        holdout,
        &input.data.display().to_string(),
    )
}

/// Tells on stderr that `outside` of the `poses` poses of `data` have readings beyond the
/// joint limits the robot file `robot` states (every command that fits or judges a model;
/// `check` lists the count with the joint ranges).
pub fn warn_outside_limits(
    outside: Option<crate::calibration::check::OutsideLimits>,
    poses: usize,
    data: &std::path::Path,
    robot: &std::path::Path,
) {
    if let Some(o) = outside {
        let w = o.warning(
            poses,
            &data.display().to_string(),
            &robot.display().to_string(),
        );
        crate::Tell::line(&mut crate::Stderr, &w);
    }
}
