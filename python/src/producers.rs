//! The subcommands that make data, from Python, in memory: `compensate` (joint commands for
//! targets), `frames` (the robot file with the base found from sweeps), `plan` (measurement
//! poses) and `simulate` (measurements and their true robot). Options are parsed by the
//! command line's own clap definitions ([`crate::commands::parse`]; the file arguments are
//! names only, but `plan`'s `--scene`, a cell description the caller gives); the results come
//! back as arrays and robot TOML text, never through a file.

use crate::commands::{accepted, arrays, finish, no_map, not_command, parse, Set};
use crate::data::Arrays;
use crate::py_err;
use crate::refused;
use crate::robot::{model_named, Robot};
use kinecal_cli::commands::Command;
use kinecal_cli::compensation::{compensate_set, Names};
use kinecal_cli::formats::cell_file::SceneFile;
use kinecal_cli::formats::measurements::{self, Dataset};
use kinecal_cli::formats::origin::Origin;
use kinecal_cli::formats::units::FileKind;
use kinecal_cli::plan::design::limits_only_scene;
use kinecal_cli::plan::request::plan_request;
use kinecal_cli::reports::{PlanReport, SimulateReport};
use kinecal_cli::simulation::request::simulate_request;
use kinecal_cli::{with_joints, Stderr, VCAP};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

/// `compensate`'s commands: q (n × N, the targets' angle unit), status, error_mm, error_deg.
type Commands = (Array2<f64>, Vec<String>, Array1<f64>, Array1<f64>);

fn compensate_n<const N: usize>(
    model: &Robot,
    args: &kinecal_cli::commands::compensate::Args,
    targets: &Arrays<'_>,
) -> PyResult<(String, bool, Commands)> {
    let job = args.job();
    let file = &model.file;
    let model_name = args.model.display().to_string();
    let m = model_named::<N>(file, &model_name).map_err(py_err)?;
    job.settings.check().map_err(py_err)?;
    let origin = args.targets.display().to_string();
    let kind = FileKind::Targets;
    let ds = accepted::<N>(targets, &origin, &args.units, &m, true, kind)?;
    let names = Names {
        model: model_name,
        targets: Origin::layout(&origin, N, &ds.extra_names),
        out: args.out.display().to_string(),
        nominal: None,
    };
    let no_nominal: Option<&kinecal::Robot<f64, N, VCAP>> = None;
    let done = compensate_set(
        file,
        &m,
        no_nominal,
        &ds,
        (&job.settings, &args.units),
        &names,
    )
    .map_err(py_err)?;
    let c = &done.commands;
    let q = Array2::from_shape_fn((c.len(), N), |(i, j)| c[i].q[j]);
    let status = c.iter().map(|r| r.status.as_str().to_string()).collect();
    let error_mm = c.iter().map(|r| r.error_mm).collect();
    let error_deg = c.iter().map(|r| r.error_deg).collect();
    let (json, converged) = finish(Ok(Box::new(done.report)))?;
    Ok((json, converged, (q, status, error_mm, error_deg)))
}

/// The result of [`compensate`]: `(json_text, converged, q, status, error_mm, error_deg)`.
type Compensated<'py> = (
    String,
    bool,
    Bound<'py, PyArray2<f64>>,
    Vec<String>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// `kinecal compensate` on arrays: `argv` holds the options (`compensate --model model
/// --targets targets --out commands [--iterations …] …`; the paths are names only), `targets`
/// the seeds and targets `(q_seed, xyz, extra_names, extra)` (`rx`, `ry`, `rz` for poses).
/// Returns the report, whether every target was reached, and per target the command (in the
/// seeds' angle unit; the seed when it failed), its status and the model's remaining error
/// (mm, degrees; NaN without a solution), as the command line writes them but unrounded.
#[pyfunction]
pub fn compensate<'py>(
    py: Python<'py>,
    model: &Robot,
    argv: Vec<String>,
    targets: Set<'_>,
) -> PyResult<Compensated<'py>> {
    let Command::Compensate(args) = parse(&argv)?.command else {
        return Err(not_command("compensate"));
    };
    if args.robot.is_some() || args.cartesian {
        return Err(refused(
            "compensate: --robot and --cartesian: use kinecal.compensate_cartesian".into(),
        ));
    }
    no_map(&args.units)?;
    let targets = arrays(&targets);
    let n = model.file.joint_count();
    let r: anyhow::Result<PyResult<(String, bool, Commands)>> =
        py.detach(|| with_joints!(n, N => Ok(compensate_n::<N>(model, &args, &targets))));
    let (json, converged, (q, status, e_mm, e_deg)) = r.map_err(py_err)??;
    Ok((
        json,
        converged,
        q.into_pyarray(py),
        status,
        e_mm.into_pyarray(py),
        e_deg.into_pyarray(py),
    ))
}

fn frames_n<const N: usize>(
    robot: &Robot,
    args: &kinecal_cli::commands::frames::Args,
    sweeps: &Arrays<'_>,
) -> PyResult<(String, String)> {
    let file = &robot.file;
    let input = &args.input;
    let nominal = model_named::<N>(file, &input.robot.display().to_string()).map_err(py_err)?;
    let origin = input.data.display().to_string();
    let kind = FileKind::Sweeps;
    let ds = accepted::<N>(sweeps, &origin, &input.units, &nominal, false, kind)?;
    let origin = Origin::layout(&origin, N, &ds.extra_names);
    let mut found = kinecal_cli::frames::find(file, &nominal, &ds, &origin).map_err(py_err)?;
    found.report.out = args.out.as_ref().map(|o| o.display().to_string());
    let framed = found.framed.to_toml().map_err(py_err)?;
    let (json, _) = finish(Ok(Box::new(found.report)))?;
    Ok((json, framed))
}

/// `kinecal frames` on arrays: `argv` holds the options (`frames --robot robot --data sweeps
/// --out framed [--length-unit …]`; the paths are names only), `sweeps` the measurements with
/// their `sweep` column. Returns `(json_text, framed_toml)`: the report and the robot file with
/// `[base]` set to the pose found.
#[pyfunction]
pub fn frames(
    py: Python<'_>,
    robot: &Robot,
    argv: Vec<String>,
    sweeps: Set<'_>,
) -> PyResult<(String, String)> {
    let Command::Frames(args) = parse(&argv)?.command else {
        return Err(not_command("frames"));
    };
    no_map(&args.input.units)?;
    let sweeps = arrays(&sweeps);
    let n = robot.file.joint_count();
    let r: anyhow::Result<PyResult<(String, String)>> =
        py.detach(|| with_joints!(n, N => Ok(frames_n::<N>(robot, &args, &sweeps))));
    r.map_err(py_err)?
}

fn plan_n<const N: usize>(
    robot: &Robot,
    args: &kinecal_cli::commands::plan::Args,
) -> PyResult<(String, Array2<f64>)> {
    let req = args.request();
    req.check().map_err(py_err)?;
    let m = model_named::<N>(&robot.file, &args.robot.display().to_string()).map_err(py_err)?;
    let scene = match &args.scene {
        Some(path) => SceneFile::load(path, N).and_then(|s| s.to_scene()),
        None => limits_only_scene(),
    }
    .map_err(py_err)?;
    let noise = |_: &kinecal::Robot<f64, N, VCAP>| Ok(args.noise_mm);
    let p = plan_request(&m, &scene, &req, noise, &mut Stderr).map_err(py_err)?;
    let q = Array2::from_shape_fn((p.poses.len(), N), |(i, j)| p.poses[i].q[j].to_degrees());
    let report = PlanReport::of(&p, &req, &args.out.display().to_string());
    let (json, _) = finish(Ok(Box::new(report)))?;
    Ok((json, q))
}

/// `kinecal plan` in memory: `argv` holds the options (`plan --robot robot --scene SCENE
/// --poses … --criterion … --work=… --out plan …`; `--scene` is the cell file read, the other
/// paths are names only). Returns `(json_text, q)`: the report and the planned poses (poses ×
/// N, degrees, unrounded).
#[pyfunction]
pub fn plan<'py>(
    py: Python<'py>,
    robot: &Robot,
    argv: Vec<String>,
) -> PyResult<(String, Bound<'py, PyArray2<f64>>)> {
    let Command::Plan(args) = parse(&argv)?.command else {
        return Err(not_command("plan"));
    };
    if args.noise_from.is_some() {
        return Err(refused(
            "plan: --noise-from reads a tracker file: give noise_mm".into(),
        ));
    }
    let n = robot.file.joint_count();
    let r: anyhow::Result<PyResult<(String, Array2<f64>)>> =
        py.detach(|| with_joints!(n, N => Ok(plan_n::<N>(robot, &args))));
    let (json, q) = r.map_err(py_err)??;
    Ok((json, q.into_pyarray(py)))
}

/// `(q, xyz, extra_names, extra)` of a measurement set.
type Owned = (Array2<f64>, Array2<f64>, Vec<String>, Array2<f64>);

fn owned<const N: usize>(ds: &Dataset<N>) -> Owned {
    let (q, xyz, extra) = crate::data::arrays_of(ds);
    (q, xyz, ds.extra_names.clone(), extra)
}

fn simulate_n<const N: usize>(
    robot: &Robot,
    args: &kinecal_cli::commands::simulate::Args,
) -> PyResult<(String, Owned, String)> {
    let file = &robot.file;
    let req = args.request();
    req.checked(N).map_err(py_err)?;
    let name = args.robot.display().to_string();
    let nominal = model_named::<N>(file, &name).map_err(py_err)?;
    let s = simulate_request(file, &nominal, &req, &name, &mut Stderr).map_err(py_err)?;
    // The measurements as the file `--out` writes holds them (and reads back).
    let data = measurements::as_written(&s.data).map_err(py_err)?;
    let out = args.out.display().to_string();
    let truth = args.truth.as_ref().map(|t| t.display().to_string());
    let report = SimulateReport::of(
        &s,
        &req,
        file.base_known(),
        data.len(),
        (&out, truth.as_deref()),
    );
    let truth = s.truth_file.to_toml().map_err(py_err)?;
    let (json, _) = finish(Ok(Box::new(report)))?;
    Ok((json, owned(&data), truth))
}

/// The result of [`simulate`]: `(json_text, (q, xyz, extra_names, extra), truth_toml)`.
type Simulated<'py> = (
    String,
    (
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Vec<String>,
        Bound<'py, PyArray2<f64>>,
    ),
    String,
);

/// `kinecal simulate` in memory: `argv` holds the options (`simulate --robot robot --out
/// simulated --truth truth [--poses …] …`; the paths are names only). Returns the report, the
/// measurements `(q, xyz, extra_names, extra)` exactly as the file `--out` would hold them,
/// and the true robot's TOML (what `--truth` writes).
#[pyfunction]
pub fn simulate<'py>(
    py: Python<'py>,
    robot: &Robot,
    argv: Vec<String>,
) -> PyResult<Simulated<'py>> {
    let Command::Simulate(args) = parse(&argv)?.command else {
        return Err(not_command("simulate"));
    };
    if args.constraints.is_some() {
        return Err(refused(
            "simulate: --constraints writes a constraint session file: use the command line".into(),
        ));
    }
    let n = robot.file.joint_count();
    let r: anyhow::Result<PyResult<(String, Owned, String)>> =
        py.detach(|| with_joints!(n, N => Ok(simulate_n::<N>(robot, &args))));
    let (json, (q, xyz, names, extra), truth) = r.map_err(py_err)??;
    Ok((
        json,
        (
            q.into_pyarray(py),
            xyz.into_pyarray(py),
            names,
            extra.into_pyarray(py),
        ),
        truth,
    ))
}
