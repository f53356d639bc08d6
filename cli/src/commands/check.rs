//! `kinecal check`: validates a robot file and a measurement file and reports how far the
//! nominal model is from the data (interfaces.md §4).
//!
//! When the robot file has no `[base]`, the base pose is first fitted by point-set
//! registration ([`fit_rigid`], Kabsch without scale) of the nominal points to the measured
//! ones: the best rigid placement of the nominal robot, which is also how `identify` starts.

use crate::calibration::registration::fit_base;
use crate::calibration::{pose_errors, ErrorStats};
use crate::formats::robot_file::RobotFile;
use crate::formats::units::{load_measurements, UnitArgs};
use crate::output::numfmt::sig;
use crate::with_joints;
use anyhow::anyhow;
use serde_json::json;
use std::path::{Path, PathBuf};

/// Arguments of `kinecal check` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot description (TOML, interfaces.md §3).
    #[arg(long)]
    pub robot: PathBuf,
    /// Measurements (CSV with q1..qN, x, y, z).
    #[arg(long)]
    pub data: PathBuf,
    #[command(flatten)]
    pub units: UnitArgs,
}

fn check_n<const N: usize>(
    robot_path: &Path,
    file: &RobotFile,
    data_path: &Path,
    units: &UnitArgs,
    json: bool,
) -> anyhow::Result<serde_json::Value> {
    let mut robot = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", robot_path.display()))?;
    let ds = load_measurements::<N, _>(data_path, units, &robot, file.base_known())?;
    if ds.is_empty() {
        crate::refuse!("{}: no measurements after the header", data_path.display());
    }
    let meas = ds.measurements::<f64>();
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
    if fitted {
        let base = fit_base(&robot, &meas).map_err(|e| anyhow!("{}: {e}", data_path.display()))?;
        robot
            .set_base(base)
            .map_err(|e| anyhow!("fitted base: {e:?}"))?;
    }
    let stats = ErrorStats::of(&pose_errors(&robot, &meas))
        .ok_or_else(|| anyhow!("{}: no measurements", data_path.display()))?;
    let (rms_mm, mean_mm, max_mm) = (stats.rms_mm, stats.mean_mm, stats.max_mm);
    let ranges = ds.joint_ranges_deg();
    let b = robot.base();
    let xyz = [b.o.x, b.o.y, b.o.z];
    let rpy = b.rpy().map(f64::to_degrees);

    if !json {
        println!(
            "robot  {}: \"{}\", {N} joints, {}",
            robot_path.display(),
            file.name,
            if fitted {
                "no [base]: base fitted to the data"
            } else {
                "base from the file"
            }
        );
        let extra = if ds.extra_names.is_empty() {
            String::new()
        } else {
            format!(", extra columns: {}", ds.extra_names.join(", "))
        };
        println!("data   {}: {} poses{extra}", data_path.display(), ds.len());
        println!("joint ranges covered (deg):");
        for (i, (lo, hi)) in ranges.iter().enumerate() {
            let limits = match file.joints.get(i).and_then(|j| j.limits_deg) {
                Some([llo, lhi]) => format!("limits {} .. {}", sig(llo, 6), sig(lhi, 6)),
                None => "no limits in the robot file".to_string(),
            };
            println!("  q{}: {lo:9.3} .. {hi:9.3}   ({limits})", i + 1);
        }
        if outside > 0 {
            println!(
                "warning: {outside} of {} poses have readings outside the joint limits of the robot file",
                ds.len()
            );
        }
        if fitted {
            // Coordinates: fixed decimals (an absolute resolution), unlike the error figures.
            println!(
                "fitted base: xyz_mm = [{:.3}, {:.3}, {:.3}], rpy_deg = [{:.4}, {:.4}, {:.4}]",
                xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]
            );
        }
        println!(
            "nominal model error: RMS {} mm, mean {} mm, max {} mm",
            sig(rms_mm, 3),
            sig(mean_mm, 3),
            sig(max_mm, 3)
        );
    }
    Ok(json!({
        "robot": robot_path.display().to_string(),
        "data": data_path.display().to_string(),
        "name": file.name,
        "joints": N,
        "poses": ds.len(),
        "extra_columns": ds.extra_names,
        "joint_ranges_deg": ranges.iter().map(|(lo, hi)| [*lo, *hi]).collect::<Vec<_>>(),
        "outside_limits": outside,
        "base_fitted": fitted,
        "base": { "xyz_mm": xyz, "rpy_deg": rpy },
        "nominal_rms_mm": rms_mm,
        "nominal_mean_mm": mean_mm,
        "nominal_max_mm": max_mm,
        "coupling_hint": crate::calibration::coupling_hint::check_hint::<N>(file, &meas),
    }))
}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(args: &Args, json: bool) -> anyhow::Result<serde_json::Value> {
    let file = RobotFile::load(&args.robot)?;
    with_joints!(file.joint_count(), N => check_n::<N>(&args.robot, &file, &args.data, &args.units, json))
}
