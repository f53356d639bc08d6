//! `kinecal check`: validates a robot file and a measurement file and reports how far the
//! nominal model is from the data (interfaces.md §4).
//!
//! When the robot file has no `[base]`, the base pose is first fitted by point-set
//! registration ([`fit_rigid`], Kabsch without scale) of the nominal points to the measured
//! ones: the best rigid placement of the nominal robot, which is also how `identify` starts.

use crate::data;
use crate::robot_file::RobotFile;
use crate::with_joints;
use anyhow::{anyhow, bail};
use kinecal::forward::ForwardKinematics;
use kinecal::{Frame, Measurement, Robot};
use nalgebra::{Matrix3, Vector3};
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
}

/// The rigid transform `(R, t)` minimising `Σ |R·a_i + t − b_i|²` (Kabsch/Umeyama without
/// scale, reflections excluded), as a frame: `b ≈ frame.point(a)`. Fails for fewer than three
/// points, non-finite input, or points on a line (rotation about it undetermined).
pub fn fit_rigid(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> anyhow::Result<Frame<f64>> {
    if a.len() != b.len() {
        bail!(
            "point-set registration: {} model points but {} measured points",
            a.len(),
            b.len()
        );
    }
    if a.len() < 3 {
        bail!(
            "point-set registration needs at least 3 points, got {}",
            a.len()
        );
    }
    if a.iter().chain(b).any(|p| !p.iter().all(|c| c.is_finite())) {
        bail!("point-set registration: non-finite point");
    }
    let n = a.len() as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (pa, pb) in a.iter().zip(b) {
        h += (pa - ca) * (pb - cb).transpose();
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        bail!("point-set registration: SVD failed");
    };
    let mut s = svd.singular_values.as_slice().to_vec();
    s.sort_by(|x, y| y.total_cmp(x));
    if s[1] <= 1e-9 * s[0] || s[0] == 0.0 {
        bail!("point-set registration: the points lie on a line (need configurations spread in space)");
    }
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let t = cb - r * ca;
    let mut f = Frame::from_parts(&r, t);
    f.orthonormalize();
    Ok(f)
}

/// The base pose that places `robot` (its own base ignored) best onto the measurements.
pub fn fit_base<const N: usize, const V: usize>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<Frame<f64>> {
    let mut placed = robot.clone();
    placed
        .set_base(Frame::identity())
        .map_err(|e| anyhow!("{e:?}"))?;
    let mut fk = ForwardKinematics::<f64, N>::new();
    let model: Vec<Vector3<f64>> = data.iter().map(|m| fk.compute(&placed, &m.q)).collect();
    let measured: Vec<Vector3<f64>> = data.iter().map(|m| m.point).collect();
    fit_rigid(&model, &measured)
}

/// Distances |p(q) − measured| (mm) of `robot` over the measurements.
pub fn residuals<const N: usize, const V: usize>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Vec<f64> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    data.iter()
        .map(|m| (fk.compute(robot, &m.q) - m.point).norm())
        .collect()
}

/// Root mean square of distances.
pub fn rms(e: &[f64]) -> f64 {
    if e.is_empty() {
        return 0.0;
    }
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

fn check_n<const N: usize>(
    robot_path: &Path,
    file: &RobotFile,
    data_path: &Path,
    json: bool,
) -> anyhow::Result<serde_json::Value> {
    let mut robot = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", robot_path.display()))?;
    let ds = data::load::<N>(data_path)?;
    if ds.is_empty() {
        bail!("{}: no measurements after the header", data_path.display());
    }
    let meas = ds.measurements::<f64>();
    let outside = meas.iter().filter(|m| !robot.within_limits(&m.q)).count();
    let fitted = !file.base_known();
    if fitted {
        let base = fit_base(&robot, &meas).map_err(|e| anyhow!("{}: {e}", data_path.display()))?;
        robot
            .set_base(base)
            .map_err(|e| anyhow!("fitted base: {e:?}"))?;
    }
    let err = residuals(&robot, &meas);
    let rms_mm = rms(&err);
    let mean_mm = err.iter().sum::<f64>() / err.len() as f64;
    let max_mm = err.iter().cloned().fold(0.0, f64::max);
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
            let [llo, lhi] = file.limits_deg(i);
            println!(
                "  q{}: {lo:9.3} .. {hi:9.3}   (limits {llo} .. {lhi})",
                i + 1
            );
        }
        if outside > 0 {
            println!("warning: {outside} poses have readings outside the joint limits");
        }
        if fitted {
            println!(
                "fitted base: xyz_mm = [{:.3}, {:.3}, {:.3}], rpy_deg = [{:.4}, {:.4}, {:.4}]",
                xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]
            );
        }
        println!(
            "nominal model error: RMS {rms_mm:.4} mm, mean {mean_mm:.4} mm, max {max_mm:.4} mm"
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
    }))
}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(args: &Args, json: bool) -> anyhow::Result<serde_json::Value> {
    let file = RobotFile::load(&args.robot)?;
    with_joints!(file.joint_count(), N => check_n::<N>(&args.robot, &file, &args.data, json))
}
