//! The arguments most subcommands share: the robot file, the data file and their units.

use crate::formats::units::UnitArgs;
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

/// The identification and held-out observations of the data file (and `--validate` file or
/// `--holdout` split), as `identify` fits them and `report` judges them.
pub struct Split<const N: usize> {
    /// What the data file observes (names, 6-D, σ); its poses are those of `ident_set` and
    /// `valid_set`.
    pub observed: crate::formats::observations::Observed<N>,
    pub ident: Vec<kinecal::Measurement<f64, N>>,
    pub valid: Vec<kinecal::Measurement<f64, N>>,
    pub ident_poses: usize,
    pub valid_poses: usize,
    /// The pose of each identification observation.
    pub pose_of: Vec<usize>,
    /// The identification and held-out poses themselves (held out: of the `--validate` file
    /// when there is one), each with its line in its file: ranges into `ident` and `valid`.
    pub ident_set: Vec<crate::formats::observations::Pose>,
    pub valid_set: Vec<crate::formats::observations::Pose>,
}

/// Loads the data (and `validate`) in the units of `input` and splits them: the validation
/// file's poses are held out, or those `holdout` chooses; refuses (exit 2) empty files and a
/// split that leaves nothing to identify from.
pub fn load_split<const N: usize>(
    input: &InputArgs,
    file: &crate::formats::robot_file::RobotFile,
    nominal: &kinecal::Robot<f64, N, { crate::VCAP }>,
    obs: &crate::formats::observations::ObservationArgs,
    validate: Option<&std::path::Path>,
    holdout: (&HoldoutArgs, u64),
) -> anyhow::Result<Split<N>> {
    use crate::formats::observations::{observe, Observed};
    let load = |p: &std::path::Path| -> anyhow::Result<Observed<N>> {
        let ds = crate::formats::loading::load_measurements(
            p,
            &input.units,
            nominal,
            file.base_known(),
        )?;
        observe(&ds, file, obs, &p.display().to_string())
    };
    let observed = load(&input.data)?;
    any_rows(&observed.poses, &input.data)?;
    let validate = match validate {
        Some(v) => Some((load(v)?, v.display().to_string())),
        None => None,
    };
    split_observed(
        observed,
        validate,
        holdout,
        &input.data.display().to_string(),
    )
}

/// Splits the poses of `observed` (named `data_origin` in messages): `validate`'s poses are
/// held out, or those `holdout` chooses (with the command's seed); refuses (exit 2) empty
/// data and a split that leaves nothing to identify from.
pub fn split_observed<const N: usize>(
    observed: crate::formats::observations::Observed<N>,
    validate: Option<(crate::formats::observations::Observed<N>, String)>,
    holdout: (&HoldoutArgs, u64),
    data_origin: &str,
) -> anyhow::Result<Split<N>> {
    use crate::formats::observations::pose_of;
    any_rows(&observed.poses, std::path::Path::new(data_origin))?;
    let validate = match validate {
        Some((v, origin)) => {
            any_rows(&v.poses, std::path::Path::new(&origin))?;
            Some(v)
        }
        None => None,
    };
    let kind = observed.kind();
    let (ident_set, valid_set) = split_sets(observed, validate, holdout)?;
    let (ident_poses, valid_poses) = (ident_set.poses.len(), valid_set.poses.len());
    let pose_of = pose_of(&ident_set.poses);
    let (ident, valid) = (ident_set.measurements, valid_set.measurements);
    if ident.is_empty() {
        crate::refuse!("{data_origin}: --holdout leaves no poses to identify from: hold out fewer");
    }
    Ok(Split {
        observed: kind,
        ident,
        valid,
        ident_poses,
        valid_poses,
        pose_of,
        ident_set: ident_set.poses,
        valid_set: valid_set.poses,
    })
}
