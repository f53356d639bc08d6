//! What identification and the discrepancy workflow start from: the held-out poses
//! (`--holdout`, `--split`), the refusal of a set without poses, and the nominal robot placed
//! where identification starts. The command line's `identify`, `diagnose` and `report` and the
//! Python package use the same functions ([`crate::commands::inputs`] re-exports them).

use crate::HostRobot;
/// `rows` when there is at least one; a file with a header and no rows is refused (exit 2)
/// naming it, wherever a command reads measurements.
pub fn some_rows<T>(rows: Vec<T>, path: &std::path::Path) -> anyhow::Result<Vec<T>> {
    any_rows(&rows, path)?;
    Ok(rows)
}

/// The refusal of [`some_rows`] without taking (or copying) the rows.
pub fn any_rows<T>(rows: &[T], path: &std::path::Path) -> anyhow::Result<()> {
    if rows.is_empty() {
        crate::refuse!(
            "{}: no measurement rows (only a header?): give a file with measured poses",
            path.display()
        );
    }
    Ok(())
}

/// `--holdout F` and `--split last|random|every:K`: which poses of the data file are kept out
/// of the fit (`--seed` of the command picks the random ones).
#[derive(clap::Args, Debug, Clone, Copy, PartialEq, Default)]
pub struct HoldoutArgs {
    /// Hold out poses for validation: a fraction (< 1) or a count (≥ 1), chosen by --split.
    #[arg(long, conflicts_with = "validate", allow_hyphen_values = true)]
    pub holdout: Option<f64>,
    /// Which poses --holdout keeps out: `last` (the last ones of the file), `random` (by
    /// --seed) or `every:K` (every K-th pose; needs no --holdout).
    #[arg(long, default_value = "last", conflicts_with = "validate")]
    pub split: crate::calibration::SplitKind,
}

impl HoldoutArgs {
    /// Whether any pose of the data file is held out.
    pub fn holds_out(&self) -> bool {
        self.holdout.is_some() || matches!(self.split, crate::calibration::SplitKind::Every(_))
    }

    /// The held-out poses in words (`the last 316 poses`, `every 5th pose`, `316 random poses`).
    pub fn describe(&self, held: usize) -> String {
        self.describe_in(held, ("pose", "poses"))
    }

    /// [`Self::describe`] counting in `unit` (singular, plural): `("group", "groups")`.
    pub fn describe_in(&self, held: usize, (one, many): (&str, &str)) -> String {
        use crate::calibration::SplitKind;
        match self.split {
            SplitKind::Last => format!("the last {held} {many}"),
            SplitKind::Random => format!("{held} {many} chosen at random"),
            SplitKind::Every(k) => format!("every {k}th {one} ({held} {many})"),
        }
    }
}

/// Identification and held-out poses: all of `all` against the `validate` file's poses, or
/// `all` split by `holdout` (`--holdout`, `--split`, and the command's seed), or all and none;
/// each set with its own observation list (the identification set's is `all`'s, compacted in
/// place). The `validate` file is another session: its rows' times are dropped, so that a
/// base-drift term fitted to this session (`calibration::drift`) does not move its poses.
pub fn split_sets<const N: usize>(
    all: crate::formats::observations::Observed<N>,
    validate: Option<crate::formats::observations::Observed<N>>,
    (holdout, seed): (&HoldoutArgs, u64),
) -> anyhow::Result<(
    crate::formats::observations::Observed<N>,
    crate::formats::observations::Observed<N>,
)> {
    if let Some(mut v) = validate {
        // The command line's parser refuses the pair before; callers in memory get here.
        if holdout.holds_out() || holdout.split != crate::calibration::SplitKind::Last {
            crate::refuse!(
                "--holdout and --split cannot be used with --validate: the validation set is \
                 the held-out data; give one or the other"
            );
        }
        for m in v.measurements.iter_mut() {
            m.time_s = None;
        }
        return Ok((all, v));
    }
    let mask =
        crate::calibration::held_out_mask(all.poses.len(), holdout.holdout, holdout.split, seed)?;
    Ok(all.split(&mask))
}

/// Places the nominal robot where identification starts: its base fitted to the
/// identification observations (point-set registration) when the robot file has no `[base]`,
/// and for 6-D data without `[tool] rpy_deg` the measured frame's orientation started from the
/// data; a tool point the file says is unknown is started from the data too
/// ([`crate::compute::tool_start`]). Returns whether the tool orientation was unknown.
pub fn place_nominal<const N: usize>(
    nominal: &mut HostRobot<N>,
    file: &crate::formats::robot_file::RobotFile,
    ident: &[kinecal::Measurement<f64, N>],
    six_d: bool,
) -> anyhow::Result<bool> {
    use anyhow::Context;
    crate::compute::tool_start::place(nominal, ident, !file.base_known(), file.tool_unknown())
        .context(match (file.base_known(), file.tool_unknown()) {
            (false, true) => {
                "placing the model on the data (the base pose and the unknown tool point)"
            }
            (true, true) => "placing the unknown tool point on the data",
            _ => "registering the base pose",
        })?;
    let tool_axes_unknown = six_d && file.tool.rpy_deg.is_none();
    if tool_axes_unknown {
        if let Some(axes) = crate::compute::registration::fit_tool_axes(nominal, ident) {
            nominal
                .set_tool_axes(axes)
                .map_err(|e| anyhow::anyhow!("estimated tool orientation is invalid: {e:?}"))?;
        }
    }
    Ok(tool_axes_unknown)
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

/// (min, max) of joint `j` over the data, rad.
pub fn joint_range<const N: usize>(data: &[kinecal::Measurement<f64, N>], j: usize) -> (f64, f64) {
    data.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
            (lo.min(m.q[j]), hi.max(m.q[j]))
        })
}
