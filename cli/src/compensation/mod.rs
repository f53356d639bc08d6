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
//!
//! In memory, [`compensate_set`] on a targets set already read (the Python package calls it on
//! arrays) returns the summary and the rows; [`run`] reads the files, calls it and writes the
//! rows ([`Compensated::csv`]).

mod frame_hint;
mod limits;
pub mod reflector;

use crate::formats::loading::load_targets;
use crate::formats::map::TargetAngles;
use crate::formats::measurements::Dataset;
use crate::formats::origin::Origin;
use crate::formats::robot_file::RobotFile;
use crate::formats::rotation_order::RotationOrder;
use crate::formats::units::{AngleUnit, UnitArgs};
use crate::reports::compensate::CompensateReport;
use crate::with_joints;
use crate::HostRobot;
use anyhow::{anyhow, bail};
use kinecal::compensate::{compensate, nominal_reach, Config, Solution, Status, Target, Tracker};
use kinecal::{Frame, Real, Robot};
use nalgebra::Vector3;
use std::fmt::Write as _;
use std::path::PathBuf;
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
    /// How far (mm, degrees) a row of the model may lie from the nominal's of
    /// [`Self::cartesian`] ([`crate::application::export::check_match`]).
    pub tolerance: (f64, f64),
    /// The `[[tools]]` name of the reflector the targets are for (the first when `None`,
    /// [`reflector::of_reflector`]).
    pub tool: Option<String>,
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
            tolerance: (
                crate::application::export::MATCH_TOLERANCE_MM,
                crate::application::export::MATCH_TOLERANCE_DEG,
            ),
            tool: None,
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
    let flange = "its commands would bring the flange to the targets";
    crate::application::export::refuse_unknown_tool(
        &file,
        &job.model.display().to_string(),
        ("compensate with", flange),
    )?;
    let n = file.joint_count();
    with_joints!(n, N => run_with_joints::<N>(job, &file))
}

impl Settings {
    /// Refuses (exit 2) settings outside the command line's limits.
    pub fn check(&self) -> anyhow::Result<()> {
        crate::check_positive("--max-step-deg", self.max_step_deg, 180.0)?;
        crate::check_positive("--accept-mm", self.accept_mm, 1000.0)?;
        crate::check_count("--iterations", usize::from(self.iterations), 1, 255)
    }
}

fn run_with_joints<const N: usize>(
    job: &Job,
    file: &RobotFile,
) -> anyhow::Result<CompensateReport> {
    let robot = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", job.model.display()))?;
    job.settings.check()?;
    let what = job.model.display().to_string();
    let all = robot.clone();
    let (robot, warning) = reflector::of_reflector(file, &robot, job.tool.as_deref(), &what)?;
    if let Some(w) = warning {
        crate::Tell::line(&mut crate::Stderr, &format!("warning: {w}"));
    }
    let nominal = match &job.cartesian {
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
            // The model's own file under another name (only the name may differ).
            let renamed = RobotFile {
                name: file.name.clone(),
                ..f.clone()
            };
            if renamed == *file {
                crate::refuse!(
                    "{}: the same robot as the model {}: the Cartesian corrections would all be \
                     zero; give --robot the nominal robot file the controller uses",
                    path.display(),
                    job.model.display()
                );
            }
            crate::check_positive("--tolerance-mm", job.tolerance.0, 1e6)?;
            crate::check_positive("--tolerance-deg", job.tolerance.1, 1e6)?;
            crate::application::export::check_match(
                file,
                &what,
                &f,
                &path.display().to_string(),
                job.tolerance,
            )?;
            let r = f
                .to_robot::<N>()
                .map_err(|e| anyhow!("{}: {e}", path.display()))?;
            // The controller's model with the same reflector, by name (the model's first
            // without --tool); one that keeps a single tool (its TCP) is taken as it is.
            let what = format!("--robot {}", path.display());
            // Without --tool, the model's first by name when this file has it, else its own
            // first.
            let name = job.tool.clone().or_else(|| {
                file.tool_names()
                    .first()
                    .filter(|n| f.tool_names().contains(n))
                    .cloned()
            });
            if f.tool_names().is_empty() {
                Some(r)
            } else {
                Some(reflector::of_reflector(&f, &r, name.as_deref(), &what)?.0)
            }
        }
    };
    // A controller whose TCP is not the model's tool: the targets are for the model's tool, so
    // the commands bring that point, not the TCP, to them (a gripper's TCP 141 mm from the
    // reflector moved every written target by 141 mm with status `ok` and no word).
    if let (Some(r), Some(path)) = (&nominal, &job.cartesian) {
        let apart = (robot.tool() - r.tool()).norm();
        if apart > job.tolerance.0 {
            crate::Tell::line(
                &mut crate::Stderr,
                &format!(
                    "warning: --robot {}: its tool point lies {} mm from the model's: the \
                     targets are taken as the model's tool's, so the controller will bring that \
                     point, not its own TCP, to each target; if they are the TCP's, give the \
                     model the TCP's point ([tool] xyz_mm) and --robot the same",
                    path.display(),
                    crate::output::numfmt::sig(apart, 3)
                ),
            );
        }
    }
    let targets = load_targets(&job.targets, &job.units, &robot)?;
    // With --map the map's units: the commands and targets go back in them.
    let (units, angles) = crate::formats::map::in_force(&job.units)?;
    let names = Names {
        model: job.model.display().to_string(),
        targets: Origin::file(&job.targets),
        out: job.out.display().to_string(),
        nominal: job.cartesian.as_ref().map(|p| p.display().to_string()),
    };
    let mut done = compensate_set(
        file,
        &robot,
        nominal.as_ref(),
        &targets,
        (&job.settings, &units),
        &names,
    )?;
    name_reflector(&mut done, file, &all, job.tool.as_deref(), &targets);
    crate::output::atomic::write_atomic(&job.out, done.csv(&units, angles).as_bytes())
        .map_err(|e| anyhow!("{}: cannot write: {e}", job.out.display()))?;
    Ok(done.report)
}

/// `done`'s report with the reflector its targets are points of (`tool`, or `file`'s first
/// `[[tools]]` name; none for one `[tool]`) and, when targets (mm, degrees) were not reached
/// and lie near another reflector of `all` (the model with every reflector) at their seeds,
/// the hint that names it.
pub fn name_reflector<const N: usize, V: kinecal::ValueStorage>(
    done: &mut Compensated<N>,
    file: &RobotFile,
    all: &Robot<f64, N, V>,
    tool: Option<&str>,
    targets: &Dataset<N>,
) {
    let names = file.tool_names();
    done.report.reflector = tool.map(String::from).or_else(|| names.first().cloned());
    if done.report.failed == 0 {
        return;
    }
    let chosen = tool
        .and_then(|t| names.iter().position(|n| n == t))
        .unwrap_or(0);
    let unreached: Vec<bool> = done
        .commands
        .iter()
        .map(|c| c.status != Status::Ok)
        .collect();
    let other = frame_hint::other_reflector(all, &names, chosen, targets, &unreached);
    if other.is_some() {
        done.report.hint = other;
    }
}

/// One target row in library units.
pub(crate) struct Row {
    seed: Vec<f64>,
    /// The seed as the file gave it, when it lay beyond a joint limit and `seed` was moved
    /// onto the limit: a command further than `--max-step-deg` from it is a jump.
    reading: Option<Vec<f64>>,
    point: Vector3<f64>,
    /// Roll, pitch, yaw (rad) for a pose target.
    rpy: Option<[f64; 3]>,
    /// The arm's temperature (°C) when it moves there (`temp_c`): what the model's thermal
    /// expansion is evaluated at.
    temp_c: Option<f64>,
    /// The targets file's line.
    line: u32,
}

/// What a compensation names in its report and messages: the model, the targets (and where
/// their header is), the output, the nominal robot of a controller that keeps its kinematics.
#[derive(Clone, Debug, PartialEq)]
pub struct Names {
    pub model: String,
    pub targets: Origin,
    pub out: String,
    /// With a nominal robot: its name, and the output is the targets to send it.
    pub nominal: Option<String>,
}

/// The joint command of one target: in the targets' angle unit (the seed when it failed),
/// the status and the model's remaining error there (NaN without a solution).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Command<const N: usize> {
    pub q: [f64; N],
    pub status: Status,
    pub error_mm: f64,
    pub error_deg: f64,
}

/// The target to send a controller that keeps its nominal kinematics: the point (mm) and, for
/// a pose target, the fixed-axis roll, pitch, yaw (rad); a failed row keeps its target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sent {
    pub point_mm: Vector3<f64>,
    pub rpy: Option<[f64; 3]>,
}

/// A compensation done: the summary, each target's joint command and, with a nominal robot,
/// each target to send it.
#[derive(Clone, Debug, PartialEq)]
pub struct Compensated<const N: usize> {
    pub report: CompensateReport,
    pub commands: Vec<Command<N>>,
    pub sent: Option<Vec<Sent>>,
    /// Whether the targets are poses (rx, ry, rz).
    pub poses: bool,
}

impl<const N: usize> Compensated<N> {
    /// The output file's text (`--out`), in the targets' `units`: the joint commands
    /// (`q1`…`qN` with about 1e-9° resolution, `status`, `error_mm`, `error_deg`), or with a
    /// nominal robot the targets to send it (`x`, `y`, `z`[, `rx`, `ry`, `rz`], `status`;
    /// the angles as `angles` says for targets read through a map, else in `units`' angle
    /// unit and kinecal's order).
    pub fn csv(&self, units: &UnitArgs, angles: Option<TargetAngles>) -> String {
        let mut csv = String::new();
        if let Some(sent) = &self.sent {
            let angles = angles.unwrap_or(TargetAngles {
                rotation: RotationOrder::KINECAL,
                unit: units.angle(),
            });
            write_cartesian(&mut csv, sent, &self.commands, (units, angles), self.poses);
            return csv;
        }
        let decimals = match units.angle() {
            AngleUnit::Deg => 9,
            AngleUnit::Rad => 11,
        };
        let head: Vec<String> = (1..=N).map(|i| format!("q{i}")).collect();
        let _ = writeln!(csv, "{},status,error_mm,error_deg", head.join(","));
        for c in &self.commands {
            for v in c.q {
                let _ = write!(csv, "{v:.decimals$},");
            }
            let _ = writeln!(
                csv,
                "{},{},{}",
                c.status.as_str(),
                fmt_num(c.error_mm),
                fmt_num(c.error_deg)
            );
        }
        csv
    }
}

/// Compensates every target of `targets` (in mm and degrees, through the targets door
/// [`crate::formats::loading`]) with `robot`, the model of the robot file `file`, with
/// `settings`; `units` are the targets' (the commands come back in their angle unit). With
/// `nominal` (the controller's kinematics), also the targets to send it. Refuses (exit 2)
/// settings outside their limits, implausible seeds and targets, and an empty set.
pub fn compensate_set<const N: usize, V: kinecal::ValueStorage>(
    file: &RobotFile,
    robot: &HostRobot<N>,
    nominal: Option<&Robot<f64, N, V>>,
    targets: &Dataset<N>,
    (settings, units): (&Settings, &UnitArgs),
    names: &Names,
) -> anyhow::Result<Compensated<N>> {
    settings.check()?;
    let origin = &names.targets;
    let mut rows = target_rows(targets, origin, units)?;
    if let Some(w) = limits::onto_limits(&mut rows, robot, targets, origin) {
        crate::Tell::line(&mut crate::Stderr, &w);
    }
    if rows.is_empty() {
        crate::refuse!("{origin}: no targets (a header and no rows): give at least one target row");
    }
    let poses = rows.iter().filter(|r| r.rpy.is_some()).count();
    if poses > 0 && N < 6 {
        bail!(
            "{origin}: pose targets (rx, ry, rz) need a robot with six or more joints; the model has {N}"
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
        let r32: Robot<f32, N, crate::HostValues> = robot
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
        solve_all(robot, &rows, &cfg, settings.stream)
    };
    let results = limits::no_jumps(results, &rows, cfg.max_step);
    let seconds = started.elapsed().as_secs_f64();

    // Joint commands in the targets' angle unit.
    let angle = units.angle();
    let sent = nominal.map(|nominal| sent_targets(robot, nominal, &rows, &results));
    let mut commands = Vec::with_capacity(rows.len());
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
        commands.push(Command {
            q: q.map(|v| angle.from_deg(v.to_degrees())),
            status: *status,
            error_mm: e,
            error_deg: w,
        });
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
    let ok = counts.get("ok").copied().unwrap_or(0);
    let failed = rows.len() - ok;
    let unreached: Vec<bool> = results.iter().map(|(s, _)| *s != Status::Ok).collect();
    let hint = (failed > 0)
        .then(|| frame_hint::frame_hint(robot, &rows, &unreached, file.base_known()))
        .flatten();
    let rms = |v: &[f64]| {
        if v.is_empty() {
            0.0
        } else {
            crate::calibration::stats::rms(v)
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
    let report = CompensateReport {
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
        out: names.out.clone(),
        model: names.model.clone(),
        model_name: file.name.clone(),
        joints: N,
        effects: robot.effects().len(),
        base_known: file.base_known(),
        targets_file: origin.name().to_string(),
        cartesian_nominal: names.nominal.clone(),
        reflector: None,
        hint,
        temperature_warning: temperature_warning(file, &rows, origin),
        error: crate::reports::compensate::unreached_error(
            failed,
            rows.len(),
            names.nominal.is_some(),
        ),
    };
    Ok(Compensated {
        report,
        commands,
        sent,
        poses: poses > 0,
    })
}

/// Per row the target to send a controller with the `nominal` kinematics: where the nominal
/// robot, placed at the model's base, puts the tool at the compensated command
/// ([`nominal_reach`]); a failed row keeps its target.
fn sent_targets<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    model: &Robot<f64, N, V>,
    nominal: &Robot<f64, N, W>,
    rows: &[Row],
    results: &[(Status, Option<Solution<f64, N>>)],
) -> Vec<Sent> {
    rows.iter()
        .zip(results)
        .map(|(row, (status, sol))| {
            let (p, rpy) = match (status, sol) {
                (Status::Ok, Some(s)) => {
                    match nominal_reach(model, nominal, row.rpy.is_some(), &s.q) {
                        Target::Pose(f) => (f.o, Some(f.rpy())),
                        Target::Point(p) => (p, None),
                    }
                }
                _ => (row.point, row.rpy),
            };
            Sent { point_mm: p, rpy }
        })
        .collect()
}

/// The `--cartesian` output: per row the target to send (`sent`), in the targets' units, and
/// the row's status.
fn write_cartesian<const N: usize>(
    csv: &mut String,
    sent: &[Sent],
    commands: &[Command<N>],
    (units, angles): (&UnitArgs, TargetAngles),
    poses: bool,
) {
    let per_mm = 1.0 / units.length().mm_per_unit();
    let _ = writeln!(csv, "x,y,z,{}status", if poses { "rx,ry,rz," } else { "" });
    for (s, c) in sent.iter().zip(commands) {
        for v in s.point_mm.iter() {
            let _ = write!(csv, "{},", v * per_mm);
        }
        if poses {
            let stated = s.rpy.map_or([f64::NAN; 3], |rpy| {
                let deg = rpy.map(f64::to_degrees);
                if angles.rotation == RotationOrder::KINECAL {
                    deg
                } else {
                    angles
                        .rotation
                        .angles_deg(&RotationOrder::KINECAL.matrix(deg))
                }
            });
            for a in stated {
                let _ = write!(csv, "{},", fmt_plain(angles.unit.from_deg(a)));
            }
        }
        let _ = writeln!(csv, "{}", c.status.as_str());
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

/// The warning for a model with thermal expansion and targets without `temp_c`: the expansion
/// is evaluated at the model's reference temperature there, which a target taken on a warm arm
/// misses by the expansion (2e-5 per kelvin over 10 K: 0.3–0.5 mm on an ER20).
fn temperature_warning(file: &RobotFile, rows: &[Row], origin: &Origin) -> Option<String> {
    // A warm column is told whatever the model (degrees Fahrenheit read as °C).
    let warm = rows
        .iter()
        .filter_map(|r| r.temp_c.map(|t| (r.line, t)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .and_then(|(line, t)| crate::formats::loading::warm_line(&origin.to_string(), line, t))
        .map(|w| w.trim_start_matches("warning: ").to_string());
    let missing = missing_temperatures(file, rows, origin);
    match (missing, warm) {
        (Some(m), Some(w)) => Some(format!("{m}; {w}")),
        (m, w) => m.or(w),
    }
}

/// [`temperature_warning`]'s part for targets without a temperature.
fn missing_temperatures(file: &RobotFile, rows: &[Row], origin: &Origin) -> Option<String> {
    let t0 = file.thermal_reference_c()?;
    let missing = rows.iter().filter(|r| r.temp_c.is_none()).count();
    let column = crate::formats::measurements::TEMPERATURE_COLUMN;
    (missing > 0).then(|| {
        format!(
            "{origin}: {missing} of {} targets have no {column} value: the model's thermal \
             expansion is evaluated at its reference temperature {} °C there, and misses an \
             arm at another temperature by the expansion; give each target the arm's \
             temperature when it moves there (a {column} column, °C)",
            rows.len(),
            crate::output::numfmt::sig(t0, 4)
        )
    })
}

/// Compensates every row (independently, or as a trajectory), in the robot's scalar type;
/// results in `f64` with the status.
fn solve_all<T: Real, const N: usize, V: kinecal::ValueStorage>(
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
            let mut cfg = *cfg;
            cfg.temperature_c = row.temp_c.map(T::of);
            let r = if stream {
                tracker.config.temperature_c = cfg.temperature_c;
                tracker.next(robot, &target, &seed)
            } else {
                compensate(robot, &target, &seed, &cfg)
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

/// The rows of a targets set (already through the targets door): the seeds and points must be
/// ones a controller could have; `rx`, `ry`, `rz` (extra columns) must be all present or all
/// absent, finite on every row. Refusals name `origin`'s lines and columns.
fn target_rows<const N: usize>(
    ds: &Dataset<N>,
    origin: &Origin,
    units: &UnitArgs,
) -> anyhow::Result<Vec<Row>> {
    let idx: Vec<Option<usize>> = ["rx", "ry", "rz"]
        .iter()
        .map(|c| ds.extra_names.iter().position(|n| n == c))
        .collect();
    let pose = match (idx[0], idx[1], idx[2]) {
        (None, None, None) => None,
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => crate::refuse!("{origin}:{}:1: a pose target needs all of rx, ry, rz; the header has only some of them", origin.header_line()),
    };
    if !ds.records.is_empty()
        && ds
            .records
            .iter()
            .all(|r| r.xyz_mm.iter().all(|v| v.is_nan()))
    {
        let named = ds.extra_names.iter().any(|n| n.starts_with("x_"));
        crate::refuse!(
            "{origin}: missing required columns x, y, z: a targets file gives each target point \
             as x, y, z{}",
            if named {
                " (for a reflector's x_NAME, y_NAME, z_NAME: rename them x, y, z and name the \
                 reflector with --tool NAME)"
            } else {
                ""
            }
        );
    }
    let temp = ds
        .extra_names
        .iter()
        .position(|n| n == crate::formats::measurements::TEMPERATURE_COLUMN);
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
                    crate::refuse!("{origin}:{}:{}: `{col}` must be a finite angle on every row of a pose target file", r.line, origin.column(col).unwrap_or(1));
                }
                Some(v.map(|a| units.angle().to_deg(a).to_radians()))
            }
        };
        let temp_c = temp
            .and_then(|i| r.extra.get(i).copied())
            .filter(|t| t.is_finite());
        use crate::formats::observations::{MAX_TEMP_C, MIN_TEMP_C};
        if let Some(t) = temp_c.filter(|t| !(MIN_TEMP_C..=MAX_TEMP_C).contains(t)) {
            crate::refuse!(
                "{origin}:{}: temp_c {t} °C is not the temperature of a robot at work                  ({MIN_TEMP_C} to {MAX_TEMP_C} °C): give °C (from degrees Fahrenheit: (F − 32)                  × 5/9), or leave the column out",
                r.line
            );
        }
        rows.push(Row {
            reading: None,
            seed,
            point: Vector3::from(r.xyz_mm),
            rpy,
            temp_c,
            line: r.line,
        });
    }
    Ok(rows)
}
