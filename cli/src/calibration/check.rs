//! The application of `kinecal check`: how far a robot file's nominal model is from a
//! measurement set (already read and in mm and degrees), what the set covers, and a missing
//! `[[couplings]]` entry that would explain it (docs/formats.md, docs/walkthrough.md).
//!
//! When the robot file has no `[base]`, the base pose is first fitted by point-set
//! registration ([`crate::compute::registration::fit_rigid`], Kabsch without scale) of the
//! nominal points to the measured ones: the best rigid placement of the nominal robot, which
//! is also how `identify` starts.

use crate::calibration::coupling_hint::{self, CouplingHint};
use crate::calibration::{pose_errors, ErrorStats};
use crate::formats::measurements::Dataset;
use crate::formats::observations::{observe, ObservationArgs};
use crate::formats::robot_file::RobotFile;
use crate::output::numfmt::sig;
use crate::HostRobot;
use anyhow::anyhow;

/// What [`check`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct Checked {
    pub joints: usize,
    pub poses: usize,
    /// Columns carried along without a fixed meaning ([`carried_columns`]).
    pub extra_columns: Vec<String>,
    /// Per joint, the lowest and highest reading (degrees).
    pub joint_ranges_deg: Vec<[f64; 2]>,
    /// Poses with a reading outside the joint limits the robot file states.
    pub outside_limits: usize,
    /// The robot file has no `[base]`: the base was fitted to the data.
    pub base_fitted: bool,
    /// The base pose the nominal error is with: position (mm), fixed-axis roll, pitch, yaw
    /// (degrees).
    pub base_xyz_mm: [f64; 3],
    pub base_rpy_deg: [f64; 3],
    /// The tool point started from the data, when the robot file gives it as unknown.
    pub tool_started_mm: Option<[f64; 3]>,
    /// The nominal model's position errors.
    pub nominal: ErrorStats,
    /// A `[[couplings]]` entry that would explain the data far better (robot files without
    /// couplings only); the command line prints its message.
    pub coupling_hint: Option<CouplingHint>,
    /// With the base fitted: the RMS (mm) of the nominal points placed by the best mirrored
    /// map, when it is under [`MIRRORED_SHARE`] of the nominal RMS (the data are mirrored).
    pub mirrored_rms_mm: Option<f64>,
    /// The scale and RMS (mm, rescaled to the model's size) of the best similarity placement of
    /// the nominal points on the data, when the scale is off 1 by more than [`SCALED_OFF`] and the
    /// RMS under [`MIRRORED_SHARE`] of the nominal RMS (the points in another length unit).
    pub scaled: Option<(f64, f64)>,
    /// Two joint columns exchanged or one negated that explain the data far better, when no
    /// coupling does better still ([`crate::calibration::column_hint`]).
    pub column_hint: Option<crate::calibration::column_hint::ColumnHint>,
}

/// How far from 1 the scale between the data and the nominal points must be for a length unit
/// to be suspected: no arm is a tenth larger or smaller than its robot file.
pub const SCALED_OFF: f64 = 0.1;

/// How small a share of the nominal RMS the mirrored placement must leave for the data to be
/// called mirrored: a robot file that describes the data leaves a few millimetres either way,
/// and mirrored data of an arm a metre long leave hundreds rigidly (series D with `x` and `y`
/// exchanged by the map: 368 mm).
pub const MIRRORED_SHARE: f64 = 0.2;

/// The least nominal RMS (mm) at which mirrored data are looked for.
pub const MIRRORED_FROM_MM: f64 = 10.0;

/// The poses of a measurement set with a reading outside the joint limits the robot file
/// states (only stated limits are checked: without them nothing is known to violate).
#[derive(Clone, Debug, PartialEq)]
pub struct OutsideLimits {
    /// How many poses have such a reading.
    pub poses: usize,
    /// The first of them: its line, the joint (1-based), the reading and the limits (degrees).
    pub first: (u32, usize, f64, [f64; 2]),
}

impl OutsideLimits {
    /// The poses of `ds` outside `file`'s joint limits, `None` when there are none.
    pub fn of<const N: usize>(file: &RobotFile, ds: &Dataset<N>) -> Option<OutsideLimits> {
        Self::of_rows(file, ds.records.iter().map(|r| (r.line, r.q_deg)))
    }

    /// The rows (each its line and joint readings in degrees) outside `file`'s joint limits,
    /// `None` when there are none.
    pub fn of_rows<const N: usize>(
        file: &RobotFile,
        rows: impl Iterator<Item = (u32, [f64; N])> + Clone,
    ) -> Option<OutsideLimits> {
        let stated: Vec<(usize, [f64; 2])> = file
            .joints
            .iter()
            .enumerate()
            .filter_map(|(i, j)| j.limits_deg.map(|l| (i, l)))
            .filter(|(i, _)| *i < N)
            .collect();
        let beyond = |(line, q): (u32, [f64; N])| {
            stated
                .iter()
                .find(|(i, [lo, hi])| !(q[*i] >= *lo && q[*i] <= *hi))
                .map(|(i, l)| (line, i + 1, q[*i], *l))
        };
        let first = rows.clone().find_map(beyond)?;
        Some(OutsideLimits {
            poses: rows.filter_map(beyond).count(),
            first,
        })
    }

    /// The warning `identify`, `diagnose` and `report` give (`check` lists the count with the
    /// joint ranges), naming the first such reading.
    pub fn warning(&self, poses: usize, data: &str, robot: &str) -> String {
        let (line, j, q, [lo, hi]) = self.first;
        format!(
            "warning: {data}: {} of {poses} poses have readings outside the joint limits of \
             {robot} (line {line}: q{j} = {}°, limits {}° to {}°): check the joints' unit, sign \
             and zero in the data, or limits_deg in the robot file",
            self.poses,
            sig(q, 6),
            sig(lo, 6),
            sig(hi, 6)
        )
    }
}

/// Checks the measurement set `ds` (named `data_origin` in messages; in mm and degrees, through
/// the doors of [`crate::formats::loading`]) against the robot file `file` and its model
/// `robot`. Refuses (exit 2) an empty set.
pub fn check<const N: usize>(
    file: &RobotFile,
    mut robot: HostRobot<N>,
    ds: &Dataset<N>,
    data_origin: &str,
) -> anyhow::Result<Checked> {
    if ds.is_empty() {
        crate::refuse!("{data_origin}: no measurements after the header");
    }
    // Several reflectors: every point seen, each against its own tool point.
    let meas = observe(ds, file, &ObservationArgs::default(), data_origin)?.all();
    let outside = OutsideLimits::of(file, ds).map_or(0, |o| o.poses);
    let fitted = !file.base_known();
    // No [base]: fitted by registration; a tool point the file says is unknown: started from
    // the data (crate::compute::tool_start), so the nominal RMS is the geometry's.
    crate::compute::tool_start::place(&mut robot, &meas, fitted, file.tool_unknown())
        .map_err(|e| e.context(data_origin.to_string()))?;
    let stats = ErrorStats::of(&pose_errors(&robot, &meas))
        .ok_or_else(|| anyhow!("{data_origin}: no measurements"))?;
    // Mirrored data (an axis's sign flipped, two columns exchanged): no rigid placement fits
    // them, a mirrored one does. Only a fitted base can tell (a stated one places them wrong
    // for every reason).
    let placed = (stats.rms_mm > MIRRORED_FROM_MM).then(|| {
        let errors = crate::calibration::pose_error_vectors(&robot, &meas);
        let measured: Vec<nalgebra::Vector3<f64>> = meas.iter().map(|m| m.point).collect();
        let model: Vec<nalgebra::Vector3<f64>> =
            measured.iter().zip(&errors).map(|(p, e)| p - e).collect();
        (model, measured)
    });
    let mirrored_rms_mm = placed
        .as_ref()
        .filter(|_| fitted)
        .and_then(|(model, measured)| crate::compute::registration::mirrored_rms(model, measured))
        .filter(|m| *m < MIRRORED_SHARE * stats.rms_mm);
    // Points in another length unit (inches, centimetres read as millimetres): a similarity
    // with a scale far from 1 places the nominal points where no rigid placement does, with the
    // base stated or fitted (a similarity finds its own placement). Its RMS is in the data's
    // unit: rescaled to the model's millimetres.
    let scaled = placed
        .as_ref()
        .and_then(|(model, measured)| crate::compute::registration::scaled_fit(model, measured))
        .map(|(s, rms)| (s, rms / s))
        .filter(|(s, rms)| (s - 1.0).abs() > SCALED_OFF && *rms < MIRRORED_SHARE * stats.rms_mm);
    let b = robot.base();
    // A missing or wrong [[couplings]] entry: another reading of the joints explains the data.
    let hint = file
        .to_robot::<N>()
        .ok()
        .and_then(|r| coupling_hint::detect(&r, &meas, !file.base_known(), file.tool_unknown()));
    // Joint columns in another order or sign, when no coupling explains the data better and
    // the points are neither mirrored nor in another unit (negating q1 brings mirrored points
    // closer, never close: 244 mm against 1,229 mm).
    let column_hint = (mirrored_rms_mm.is_none() && scaled.is_none())
        .then(|| file.to_robot::<N>().ok())
        .flatten()
        .and_then(|r| {
            crate::calibration::column_hint::detect(&r, &meas, fitted, file.tool_unknown())
        })
        .filter(|c| hint.as_ref().is_none_or(|h| c.rms_mm < h.rms_mm));
    let hint = hint.filter(|_| column_hint.is_none());
    Ok(Checked {
        column_hint,
        joints: N,
        poses: ds.len(),
        extra_columns: carried_columns(&ds.extra_names, &file.tool_names()),
        joint_ranges_deg: ds
            .joint_ranges_deg()
            .iter()
            .map(|(lo, hi)| [*lo, *hi])
            .collect(),
        outside_limits: outside,
        base_fitted: fitted,
        base_xyz_mm: [b.o.x, b.o.y, b.o.z],
        base_rpy_deg: b.rpy().map(f64::to_degrees),
        tool_started_mm: file.tool_unknown().then(|| {
            let t = robot.tool();
            [t.x, t.y, t.z]
        }),
        nominal: stats,
        coupling_hint: hint,
        mirrored_rms_mm,
        scaled,
    })
}

/// Columns with a fixed meaning (docs/formats.md, "Observations"): orientations, stated σ
/// and the named reflectors' points are read, not carried along.
const READ_COLUMNS: [&str; 10] = [
    "rx_deg", "ry_deg", "rz_deg", "sx_mm", "sy_mm", "sz_mm", "srot_deg", "srx_deg", "sry_deg",
    "srz_deg",
];

/// The columns of the file that kinecal carries along without reading them (`temp_c`, a
/// timestamp…): every column but the joints, the point and `READ_COLUMNS`, and but `x_NAME`,
/// `y_NAME`, `z_NAME` of the robot file's reflectors `tools`.
pub fn carried_columns(extra: &[String], tools: &[String]) -> Vec<String> {
    let reflector = |c: &str| {
        tools
            .iter()
            .any(|t| ["x_", "y_", "z_"].iter().any(|p| c == format!("{p}{t}")))
    };
    extra
        .iter()
        .filter(|c| !READ_COLUMNS.contains(&c.as_str()) && !reflector(c))
        .cloned()
        .collect()
}
