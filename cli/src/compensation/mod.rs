//! Joint commands that bring the identified robot to target points or poses, with
//! [`kinecal::compensate`]: the application behind `kinecal compensate`.
//!
//! Targets file: `q1`…`qN` (the seed: the controller's nominal joints, degrees), `x`,`y`,`z`
//! (target point, mm, measurement frame), optionally `rx`,`ry`,`rz` (degrees, fixed-axis
//! roll/pitch/yaw of the tool orientation, the convention of the robot file's `rpy_deg`) for a
//! full pose target. `--length-unit m` and `--angle-unit rad` read the points, and the seeds and
//! `rx`,`ry`,`rz`, in metres and radians instead ([`crate::formats::units`]; a file that looks like
//! other units than the ones assumed is refused: the seeds must bring the model near the
//! targets). Output: `q1`…`qN` in the angle unit of the targets (degrees with 9 decimals,
//! radians with 11), so the controller gets its own unit back; `status` (`ok`, `singular`,
//! `unreachable`, `limited`, `invalid`); and the model's remaining error at the command in the
//! units its column names say (`error_mm`, `error_deg`).
//!
//! With a nominal robot ([`Job::cartesian`]): instead of joints, the target to send to a
//! controller that keeps its nominal kinematics, [`kinecal::compensate::nominal_reach`] at the
//! command: `x`,`y`,`z` (and `rx`,`ry`,`rz` for pose targets) in the targets' units, then
//! `status`; a row that failed keeps its target.

use crate::formats::loading::load_targets;
use crate::formats::robot_file::RobotFile;
use crate::formats::units::{AngleUnit, UnitArgs};
use crate::reports::compensate::CompensateReport;
use crate::with_joints;
use anyhow::{anyhow, bail};
use kinecal::compensate::{compensate, nominal_reach, Config, Solution, Status, Target, Tracker};
use kinecal::{Frame, Real, Robot};
use nalgebra::Vector3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The solver settings of a compensation run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Most damped Newton steps per target.
    pub iterations: u8,
    /// Largest accepted correction per joint, |command − seed| (degrees).
    pub max_step_deg: f64,
    /// Remaining model error (mm; orientation scaled by the reach) above which a target fails.
    pub accept_mm: f64,
    /// Rows are a trajectory: warm-start each from the previous row's correction.
    pub stream: bool,
    /// Compute in single precision, as the controller does.
    pub f32: bool,
}

impl Default for Settings {
    /// The command line's defaults: 8 steps, 2°, 0.01 mm, independent rows, f64.
    fn default() -> Self {
        Self {
            iterations: 8,
            max_step_deg: 2.0,
            accept_mm: 0.01,
            stream: false,
            f32: false,
        }
    }
}

/// A compensation run on files.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// Identified robot model (robot TOML, effects included).
    pub model: PathBuf,
    /// Targets (CSV): q1..qN seed, x, y, z, optionally rx, ry, rz.
    pub targets: PathBuf,
    /// Output CSV: q1..qN in the targets' angle unit, status, error_mm, error_deg.
    pub out: PathBuf,
    pub settings: Settings,
    /// Units of the targets file and of the joint commands written.
    pub units: UnitArgs,
    /// The nominal robot (robot TOML) of a controller that keeps its kinematics: the output is
    /// then the targets to send it instead of joint commands.
    pub cartesian: Option<PathBuf>,
}

impl Job {
    /// `model`, `targets` → `out` with the default settings and units.
    pub fn new(
        model: impl Into<PathBuf>,
        targets: impl Into<PathBuf>,
        out: impl Into<PathBuf>,
    ) -> Self {
        Self {
            model: model.into(),
            targets: targets.into(),
            out: out.into(),
            settings: Settings::default(),
            units: UnitArgs::default(),
            cartesian: None,
        }
    }
}

/// Compensates every target of `job.targets` with the model `job.model` and writes the joint
/// commands to `job.out` (never over an input); the summary.
pub fn run(job: &Job) -> anyhow::Result<CompensateReport> {
    let mut inputs = vec![
        ("model", job.model.as_path()),
        ("targets", job.targets.as_path()),
    ];
    if let Some(n) = &job.cartesian {
        inputs.push(("robot", n.as_path()));
    }
    crate::output::atomic::refuse_overwriting_inputs("--out", &job.out, &inputs)?;
    let file = RobotFile::load(&job.model)?;
    let n = file.joint_count();
    with_joints!(n, N => compensate_with_joints::<N>(job, &file))
}

/// One target row in library units.
struct Row {
    seed: Vec<f64>,
    point: Vector3<f64>,
    /// Roll, pitch, yaw (rad) for a pose target.
    rpy: Option<[f64; 3]>,
}

fn compensate_with_joints<const N: usize>(
    job: &Job,
    file: &RobotFile,
) -> anyhow::Result<CompensateReport> {
    let (args, settings) = (job, &job.settings);
    let robot = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", args.model.display()))?;
    crate::check_positive("--max-step-deg", settings.max_step_deg, 180.0)?;
    crate::check_positive("--accept-mm", settings.accept_mm, 1000.0)?;
    crate::check_count("--iterations", usize::from(settings.iterations), 1, 255)?;
    let nominal = match &args.cartesian {
        None => None,
        Some(path) => {
            let f = RobotFile::load(path)?;
            if f.joint_count() != N {
                crate::refuse!(
                    "{}: the nominal robot has {} joints, the model {}: --robot must be the controller's model of the same arm",
                    path.display(),
                    f.joint_count(),
                    N
                );
            }
            Some(
                f.to_robot::<N>()
                    .map_err(|e| anyhow!("{}: {e}", path.display()))?,
            )
        }
    };
    let rows = read_targets::<N>(&args.targets, &args.units, &robot)?;
    if rows.is_empty() {
        crate::refuse!(
            "{}: no targets (a header and no rows): give at least one target row",
            args.targets.display()
        );
    }
    let poses = rows.iter().filter(|r| r.rpy.is_some()).count();
    if poses > 0 && N < 6 {
        bail!(
            "{}: pose targets (rx, ry, rz) need a robot with six or more joints; the model has {N}",
            args.targets.display()
        );
    }
    let cfg = Config::<f64> {
        iterations: settings.iterations,
        max_step: settings.max_step_deg.to_radians(),
        accept: settings.accept_mm,
        ..Config::default()
    };
    if !cfg.is_valid() {
        bail!("invalid settings: --max-step-deg and --accept-mm must be positive and finite");
    }
    let started = Instant::now();
    let results = if settings.f32 {
        let r32: Robot<f32, N, { crate::VCAP }> = robot
            .cast()
            .map_err(|e| anyhow!("the model does not fit f32: {e:?}"))?;
        let c32 = Config::<f32> {
            iterations: cfg.iterations,
            max_step: cfg.max_step as f32,
            accept: cfg.accept as f32,
            ..Config::default()
        };
        solve_all(&r32, &rows, &c32, settings.stream)
    } else {
        solve_all(&robot, &rows, &cfg, settings.stream)
    };
    let seconds = started.elapsed().as_secs_f64();

    // Output file and summary.
    let mut csv = String::new();
    // Joint commands in the targets' angle unit, with about the same resolution (1e-9°).
    let angle = args.units.angle();
    let decimals = match angle {
        AngleUnit::Deg => 9,
        AngleUnit::Rad => 11,
    };
    if let Some(nominal) = &nominal {
        write_cartesian(
            &mut csv,
            &robot,
            nominal,
            &rows,
            &results,
            &args.units,
            poses > 0,
        );
    } else {
        let head: Vec<String> = (1..=N).map(|i| format!("q{i}")).collect();
        let _ = writeln!(csv, "{},status,error_mm,error_deg", head.join(","));
    }
    let mut counts = std::collections::BTreeMap::<&str, usize>::new();
    let (mut ok_err, mut max_corr, mut sum_corr2, mut ncorr) = (Vec::new(), 0.0f64, 0.0f64, 0usize);
    for (row, (status, sol)) in rows.iter().zip(&results) {
        *counts.entry(status.as_str()).or_default() += 1;
        let q = sol
            .map(|s| s.q)
            .unwrap_or(std::array::from_fn(|j| row.seed[j]));
        let (e, w) = sol
            .map(|s| (s.position_error, s.orientation_error.to_degrees()))
            .unwrap_or((f64::NAN, f64::NAN));
        if nominal.is_none() {
            for v in q {
                let _ = write!(csv, "{:.decimals$},", angle.from_deg(v.to_degrees()));
            }
            let _ = writeln!(csv, "{},{},{}", status.as_str(), fmt_num(e), fmt_num(w));
        }
        if *status == Status::Ok {
            ok_err.push(e);
        }
        for (qj, sj) in q.iter().zip(&row.seed) {
            let c = (qj - sj).to_degrees().abs();
            max_corr = max_corr.max(c);
            sum_corr2 += c * c;
            ncorr += 1;
        }
    }
    crate::output::atomic::write_atomic(&args.out, csv.as_bytes())
        .map_err(|e| anyhow!("{}: cannot write: {e}", args.out.display()))?;
    let ok = counts.get("ok").copied().unwrap_or(0);
    let failed = rows.len() - ok;
    let rms = |v: &[f64]| {
        if v.is_empty() {
            0.0
        } else {
            (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
        }
    };
    let rms_corr = if ncorr > 0 {
        (sum_corr2 / ncorr as f64).sqrt()
    } else {
        0.0
    };
    let per_target_us = if rows.is_empty() {
        0.0
    } else {
        seconds * 1e6 / rows.len() as f64
    };
    Ok(CompensateReport {
        targets: rows.len(),
        ok,
        failed,
        status: counts.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        pose_targets: poses,
        point_targets: rows.len() - poses,
        model_error_rms_mm: (!ok_err.is_empty()).then(|| rms(&ok_err)),
        correction_rms_deg: rms_corr,
        correction_max_deg: max_corr,
        precision: if settings.f32 { "f32" } else { "f64" }.to_string(),
        stream: settings.stream,
        seconds,
        microseconds_per_target: per_target_us,
        out: args.out.display().to_string(),
        model: args.model.display().to_string(),
        model_name: file.name.clone(),
        joints: N,
        effects: robot.effects().len(),
        base_known: file.base_known(),
        targets_file: args.targets.display().to_string(),
        cartesian_nominal: args.cartesian.as_ref().map(|p| p.display().to_string()),
    })
}

/// The `--cartesian` output: per row the target to send to a controller with the `nominal`
/// kinematics (where the nominal robot, placed at the model's base, puts the tool at the
/// compensated command), in the targets' units; a failed row keeps its target.
fn write_cartesian<const N: usize, const V: usize, const W: usize>(
    csv: &mut String,
    model: &Robot<f64, N, V>,
    nominal: &Robot<f64, N, W>,
    rows: &[Row],
    results: &[(Status, Option<Solution<f64, N>>)],
    units: &UnitArgs,
    poses: bool,
) {
    let per_mm = 1.0 / units.length().mm_per_unit();
    let angle = units.angle();
    let _ = writeln!(csv, "x,y,z,{}status", if poses { "rx,ry,rz," } else { "" });
    for (row, (status, sol)) in rows.iter().zip(results) {
        let (p, rpy) = match (status, sol) {
            (Status::Ok, Some(s)) => match nominal_reach(model, nominal, row.rpy.is_some(), &s.q) {
                Target::Pose(f) => (f.o, Some(f.rpy())),
                Target::Point(p) => (p, None),
            },
            _ => (row.point, row.rpy),
        };
        for v in p.iter() {
            let _ = write!(csv, "{},", v * per_mm);
        }
        if poses {
            for a in rpy.unwrap_or([f64::NAN; 3]) {
                let _ = write!(csv, "{},", fmt_plain(angle.from_deg(a.to_degrees())));
            }
        }
        let _ = writeln!(csv, "{}", status.as_str());
    }
}

/// A number in full precision (shortest round-trip form), empty when not finite.
fn fmt_plain(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        String::new()
    }
}

fn fmt_num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e}")
    } else {
        String::new()
    }
}

/// Compensates every row (independently, or as a trajectory), in the robot's scalar type;
/// results in `f64` with the status.
fn solve_all<T: Real, const N: usize, const V: usize>(
    robot: &Robot<T, N, V>,
    rows: &[Row],
    cfg: &Config<T>,
    stream: bool,
) -> Vec<(Status, Option<Solution<f64, N>>)> {
    let mut tracker = Tracker::new(*cfg);
    rows.iter()
        .map(|row| {
            let seed: [T; N] = std::array::from_fn(|j| T::of(row.seed[j]));
            let p = row.point.map(T::of);
            let target = match row.rpy {
                Some(rpy) => Target::Pose(Frame::from_xyz_rpy([p.x, p.y, p.z], rpy.map(T::of))),
                None => Target::Point(p),
            };
            let r = if stream {
                tracker.next(robot, &target, &seed)
            } else {
                compensate(robot, &target, &seed, cfg)
            };
            let status = Status::of(&r);
            let best = match &r {
                Ok(s) => Some(s),
                Err(e) => e.best(),
            };
            let sol = best.map(|s| Solution {
                q: s.q.map(|v| v.to_f64()),
                position_error: s.position_error.to_f64(),
                orientation_error: s.orientation_error.to_f64(),
                sigma: s.sigma.to_f64(),
                iterations: s.iterations,
            });
            (status, sol)
        })
        .collect()
}

/// Reads the targets file: the library's CSV reader for q, x, y, z; `rx`, `ry`, `rz` arrive as
/// extra columns and must be all present or all absent (per file), finite on every row.
fn read_targets<const N: usize>(
    path: &Path,
    units: &UnitArgs,
    model: &Robot<f64, N, { crate::VCAP }>,
) -> anyhow::Result<Vec<Row>> {
    let ds = load_targets(path, units, model)?;
    let origin = path.display();
    let idx: Vec<Option<usize>> = ["rx", "ry", "rz"]
        .iter()
        .map(|c| ds.extra_names.iter().position(|n| n == c))
        .collect();
    let pose = match (idx[0], idx[1], idx[2]) {
        (None, None, None) => None,
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => crate::refuse!("{origin}:{}:1: a pose target needs all of rx, ry, rz; the header has only some of them", header_line(path)),
    };
    let mut rows = Vec::with_capacity(ds.len());
    for r in &ds.records {
        // Seeds and points a controller could have: a seed of 1e300° would otherwise come back
        // as the command of a failed target.
        if let Some((j, q)) = r
            .q_deg
            .iter()
            .enumerate()
            .find(|(_, q)| !(q.is_finite() && q.abs() <= crate::MAX_JOINT_READING_DEG))
        {
            crate::refuse!(
                "{origin}:{}: seed q{} = {}° is implausible (joint readings are within ±{}°): check the targets file and --angle-unit",
                r.line,
                j + 1,
                crate::number_text(*q),
                crate::MAX_JOINT_READING_DEG
            );
        }
        if let Some(v) = r
            .xyz_mm
            .iter()
            .find(|v| !(v.is_finite() && v.abs() <= crate::MAX_LENGTH_MM))
        {
            crate::refuse!(
                "{origin}:{}: target coordinate {} mm is implausible (within ±{} mm): check the targets file and --length-unit",
                r.line,
                crate::number_text(*v),
                crate::MAX_LENGTH_MM
            );
        }
        let seed: Vec<f64> = r.q_deg.iter().map(|q| q.to_radians()).collect();
        let rpy = match pose {
            None => None,
            Some(k) => {
                let v = k.map(|i| r.extra.get(i).copied().unwrap_or(f64::NAN));
                if let Some(bad) = (0..3).find(|i| !v[*i].is_finite()) {
                    let col = ["rx", "ry", "rz"][bad];
                    crate::refuse!("{origin}:{}:{}: `{col}` must be a finite angle on every row of a pose target file", r.line, header_column(path, col));
                }
                Some(v.map(|a| units.angle().to_deg(a).to_radians()))
            }
        };
        rows.push(Row {
            seed,
            point: Vector3::from(r.xyz_mm),
            rpy,
        });
    }
    Ok(rows)
}

/// The first line that is neither blank nor a comment (1-based), and its cells.
fn header(path: &Path) -> (usize, Vec<String>) {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    for (i, l) in text.lines().enumerate() {
        let t = l.trim().trim_start_matches('\u{feff}');
        if !t.is_empty() && !t.starts_with('#') {
            return (
                i + 1,
                t.split(',')
                    .map(|c| kinecal::io::csv::column_name(c).to_string())
                    .collect(),
            );
        }
    }
    (1, Vec::new())
}

fn header_line(path: &Path) -> usize {
    header(path).0
}

/// 1-based column of `name` in the header (1 if absent).
fn header_column(path: &Path, name: &str) -> usize {
    header(path)
        .1
        .iter()
        .position(|c| c == name)
        .map_or(1, |i| i + 1)
}
