//! `kinecal check`: validates a robot file and a measurement file and reports how far the
//! nominal model is from the data (docs/formats.md, docs/walkthrough.md).
//!
//! When the robot file has no `[base]`, the base pose is first fitted by point-set
//! registration ([`crate::compute::registration::fit_rigid`], Kabsch without scale) of the
//! nominal points to the measured ones: the best rigid placement of the nominal robot, which
//! is also how `identify` starts.

use super::inputs::InputArgs;
use crate::calibration::coupling_hint;
use crate::calibration::{pose_errors, ErrorStats};
use crate::formats::loading::load_measurements;
use crate::formats::robot_file::RobotFile;
use crate::reports::check::{CheckReport, CouplingHintReport};
use crate::reports::{path_text, FrameReport};
use crate::with_joints;
use anyhow::anyhow;

/// Arguments of `kinecal check`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file, measurements and their units.
    #[command(flatten)]
    pub input: InputArgs,
}

fn check_with_joints<const N: usize>(
    input: &InputArgs,
    file: &RobotFile,
) -> anyhow::Result<CheckReport> {
    let (robot_path, data_path) = (&input.robot, &input.data);
    let mut robot = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", robot_path.display()))?;
    let ds = load_measurements::<N, _>(data_path, &input.units, &robot, file.base_known())?;
    if ds.is_empty() {
        crate::refuse!("{}: no measurements after the header", data_path.display());
    }
    // Several reflectors: every point seen, each against its own tool point.
    let meas = crate::formats::observations::observe(
        &ds,
        file,
        &crate::formats::observations::ObservationArgs::default(),
        &data_path.display().to_string(),
    )?
    .all();
    // Only limits the robot file states are checked: without them nothing is known to violate.
    let stated: Vec<(usize, [f64; 2])> = file
        .joints
        .iter()
        .enumerate()
        .filter_map(|(i, j)| j.limits_deg.map(|l| (i, l)))
        .collect();
    let outside = ds
        .records
        .iter()
        .filter(|r| {
            stated
                .iter()
                .any(|(i, [lo, hi])| !(r.q_deg[*i] >= *lo && r.q_deg[*i] <= *hi))
        })
        .count();
    let fitted = !file.base_known();
    // No [base]: fitted by registration; a tool point the file says is unknown: started from
    // the data (crate::compute::tool_start), so the nominal RMS is the geometry's.
    crate::compute::tool_start::place(&mut robot, &meas, fitted, file.tool_unknown())
        .map_err(|e| anyhow!("{}: {e}", data_path.display()))?;
    let stats = ErrorStats::of(&pose_errors(&robot, &meas))
        .ok_or_else(|| anyhow!("{}: no measurements", data_path.display()))?;
    let b = robot.base();
    // A missing [[couplings]] entry that explains the data (robot files without couplings).
    let hint = if file.couplings.is_empty() {
        file.to_robot::<N>()
            .ok()
            .and_then(|r| coupling_hint::detect(&r, &meas, !file.base_known(), file.tool_unknown()))
    } else {
        None
    };
    if let Some(h) = &hint {
        eprintln!("{}", h.message());
    }
    Ok(CheckReport {
        robot: path_text(robot_path),
        data: path_text(data_path),
        name: file.name.clone(),
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
        base: FrameReport {
            xyz_mm: [b.o.x, b.o.y, b.o.z],
            rpy_deg: b.rpy().map(f64::to_degrees),
        },
        tool_started_mm: file.tool_unknown().then(|| {
            let t = robot.tool();
            [t.x, t.y, t.z]
        }),
        nominal_rms_mm: stats.rms_mm,
        nominal_mean_mm: stats.mean_mm,
        nominal_max_mm: stats.max_mm,
        coupling_hint: hint.as_ref().map(CouplingHintReport::from),
        limits_deg: file.joints.iter().map(|j| j.limits_deg).collect(),
    })
}

/// Runs the subcommand: the report of the two files.
pub fn run(args: &Args) -> anyhow::Result<CheckReport> {
    let file = RobotFile::load(&args.input.robot)?;
    with_joints!(file.joint_count(), N => check_with_joints::<N>(&args.input, &file))
}

/// Columns with a fixed meaning (docs/formats.md, "Observations"): orientations, stated σ
/// and the named reflectors' points are read, not carried along.
const READ_COLUMNS: [&str; 10] = [
    "rx_deg", "ry_deg", "rz_deg", "sx_mm", "sy_mm", "sz_mm", "srot_deg", "srx_deg", "sry_deg",
    "srz_deg",
];

/// The columns of the file that kinecal carries along without reading them (`temp_c`, a
/// timestamp…): every column but the joints, the point and [`READ_COLUMNS`], and but `x_NAME`,
/// `y_NAME`, `z_NAME` of the robot file's reflectors `tools`.
fn carried_columns(extra: &[String], tools: &[String]) -> Vec<String> {
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
