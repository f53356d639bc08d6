//! The subcommands that make data, from Python, in memory: `compensate` (joint commands for
//! targets), `frames` (the robot file with the base found from sweeps), `plan` (measurement
//! poses) and `simulate` (measurements and their true robot). Options are typed
//! ([`crate::options`]: the application's settings and requests, no command line; `plan`'s
//! scene is a cell file the caller names); the results come back as arrays and robot TOML
//! text, never through a file. Messages name the sets as the command line's files would be
//! named (`model`, `targets`, `sweeps`, `robot`).

use crate::commands::{accepted, arrays, finish, Set};
use crate::data::Arrays;
use crate::options;
use crate::py_err;
use crate::robot::{model_named, Robot};
use kinecal_cli::compensation::{compensate_set, Names, Settings};
use kinecal_cli::formats::cell_file::SceneFile;
use kinecal_cli::formats::measurements::{self, Dataset};
use kinecal_cli::formats::origin::Origin;
use kinecal_cli::formats::units::{FileKind, UnitArgs};
use kinecal_cli::plan::design::limits_only_scene;
use kinecal_cli::plan::request::{plan_request, Request as PlanRequest};
use kinecal_cli::reports::{PlanReport, SimulateReport};
use kinecal_cli::simulation::request::{simulate_request, Request as SimulateRequest};
use kinecal_cli::HostRobot;
use kinecal_cli::{with_joints, Stderr};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// `compensate`'s commands: q (n × N, the targets' angle unit), status, error_mm, error_deg.
type Commands = (Array2<f64>, Vec<String>, Array1<f64>, Array1<f64>);

fn compensate_n<const N: usize>(
    model: &Robot,
    (settings, units): (&Settings, &UnitArgs),
    targets: &Arrays<'_>,
    tool: Option<&str>,
) -> PyResult<(String, bool, Commands)> {
    let file = &model.file;
    let m = model_named::<N>(file, "model").map_err(py_err)?;
    settings.check().map_err(py_err)?;
    let all = m.clone();
    let (m, warning) = kinecal_cli::compensation::reflector::of_reflector(file, &m, tool, "model")
        .map_err(py_err)?;
    if let Some(w) = warning {
        kinecal_cli::Tell::line(&mut Stderr, &format!("warning: {w}"));
    }
    let origin = "targets";
    let kind = FileKind::Targets;
    let ds = accepted::<N>(targets, origin, units, &m, true, kind)?;
    let names = Names {
        model: "model".into(),
        targets: Origin::layout(origin, N, &ds.extra_names),
        out: "commands".into(),
        nominal: None,
    };
    let no_nominal: Option<&HostRobot<N>> = None;
    let mut done =
        compensate_set(file, &m, no_nominal, &ds, (settings, units), &names).map_err(py_err)?;
    kinecal_cli::compensation::name_reflector(&mut done, file, &all, tool, &ds);
    // The command line prints it as `warning: …`: the caller gets it as a DataWarning.
    if let Some(w) = &done.report.temperature_warning {
        kinecal_cli::Tell::line(&mut Stderr, &format!("warning: {w}"));
    }
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

/// `kinecal compensate` on arrays: `targets` the seeds and targets `(q_seed, xyz,
/// extra_names, extra)` (`rx`, `ry`, `rz` for poses), `options` the solver settings and units
/// ([`options::Compensate`], [`options::Units`]). Returns the report, whether every target was
/// reached, and per target the command (in the seeds' angle unit; the seed when it failed),
/// its status and the model's remaining error (mm, degrees; NaN without a solution), as the
/// command line writes them but unrounded.
#[pyfunction]
pub fn compensate<'py>(
    py: Python<'py>,
    model: &Robot,
    targets: Set<'_>,
    options: &Bound<'py, PyAny>,
) -> PyResult<Compensated<'py>> {
    let compensate = options::extract::<options::Compensate>("compensate", options)?;
    let (settings, tool) = (compensate.settings(), compensate.tool);
    let units = options::extract::<options::Units>("compensate", options)?.args()?;
    let targets = arrays(&targets);
    let n = model.file.joint_count();
    let r: anyhow::Result<PyResult<(String, bool, Commands)>> = crate::detached(
        py,
        || with_joints!(n, N => Ok(compensate_n::<N>(model, (&settings, &units), &targets, tool.as_deref()))),
    )?;
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
    units: &UnitArgs,
    sweeps: &Arrays<'_>,
) -> PyResult<(String, String)> {
    let file = &robot.file;
    let nominal = model_named::<N>(file, "robot").map_err(py_err)?;
    let kind = FileKind::Sweeps;
    let ds = accepted::<N>(sweeps, "sweeps", units, &nominal, false, kind)?;
    let origin = Origin::layout("sweeps", N, &ds.extra_names);
    let mut found = kinecal_cli::frames::find(file, &nominal, &ds, &origin).map_err(py_err)?;
    found.report.out = Some("framed".into());
    let framed = found.framed.to_toml().map_err(py_err)?;
    let (json, _) = finish(Ok(Box::new(found.report)))?;
    Ok((json, framed))
}

/// `kinecal frames` on arrays: `sweeps` the measurements with their `sweep` column, `options`
/// the units ([`options::Units`]). Returns `(json_text, framed_toml)`: the report and the robot
/// file with `[base]` set to the pose found.
#[pyfunction]
pub fn frames(
    py: Python<'_>,
    robot: &Robot,
    sweeps: Set<'_>,
    options: &Bound<'_, PyAny>,
) -> PyResult<(String, String)> {
    let units = options::extract::<options::Units>("frames", options)?.args()?;
    let sweeps = arrays(&sweeps);
    let n = robot.file.joint_count();
    let r: anyhow::Result<PyResult<(String, String)>> = crate::detached(
        py,
        || with_joints!(n, N => Ok(frames_n::<N>(robot, &units, &sweeps))),
    )?;
    r.map_err(py_err)?
}

fn plan_n<const N: usize>(
    robot: &Robot,
    req: &PlanRequest,
    scene: Option<&Path>,
) -> PyResult<(String, Array2<f64>)> {
    req.check().map_err(py_err)?;
    let m = model_named::<N>(&robot.file, "robot").map_err(py_err)?;
    let scene = match scene {
        Some(path) => SceneFile::load(path, N).and_then(|s| s.to_scene()),
        None => limits_only_scene(),
    }
    .map_err(py_err)?;
    let noise = |_: &HostRobot<N>| Ok(req.noise_mm);
    let p = plan_request(&m, &scene, req, noise, &mut Stderr).map_err(py_err)?;
    let q = Array2::from_shape_fn((p.poses.len(), N), |(i, j)| p.poses[i].q[j].to_degrees());
    let report = PlanReport::of(&p, req, "plan");
    let (json, _) = finish(Ok(Box::new(report)))?;
    Ok((json, q))
}

/// `kinecal plan` in memory: `scene` the cell file read (None: the joint limits only),
/// `options` the request ([`options::Plan`]: poses, criterion, working configurations in
/// degrees …). Returns `(json_text, q)`: the report and the planned poses (poses × N, degrees,
/// unrounded).
#[pyfunction]
#[pyo3(signature = (robot, scene, options))]
pub fn plan<'py>(
    py: Python<'py>,
    robot: &Robot,
    scene: Option<PathBuf>,
    options: &Bound<'py, PyAny>,
) -> PyResult<(String, Bound<'py, PyArray2<f64>>)> {
    let req = options::extract::<options::Plan>("plan", options)?.request()?;
    let n = robot.file.joint_count();
    let r: anyhow::Result<PyResult<(String, Array2<f64>)>> = crate::detached(
        py,
        || with_joints!(n, N => Ok(plan_n::<N>(robot, &req, scene.as_deref()))),
    )?;
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
    req: &SimulateRequest,
) -> PyResult<(String, Owned, String)> {
    let file = &robot.file;
    req.checked(N).map_err(py_err)?;
    let nominal = model_named::<N>(file, "robot").map_err(py_err)?;
    let s = simulate_request(file, &nominal, req, "robot", &mut Stderr).map_err(py_err)?;
    // The measurements as the file `--out` writes holds them (and reads back).
    let data = measurements::as_written(&s.data).map_err(py_err)?;
    let report = SimulateReport::of(
        &s,
        req,
        file.base_known(),
        data.len(),
        ("simulated", Some("truth")),
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

/// `kinecal simulate` in memory: `options` the request ([`options::Simulate`]). Returns the
/// report, the measurements `(q, xyz, extra_names, extra)` exactly as the file `--out` would
/// hold them, and the true robot's TOML (what `--truth` writes).
#[pyfunction]
pub fn simulate<'py>(
    py: Python<'py>,
    robot: &Robot,
    options: &Bound<'py, PyAny>,
) -> PyResult<Simulated<'py>> {
    let req = options::extract::<options::Simulate>("simulate", options)?.request()?;
    let n = robot.file.joint_count();
    let r: anyhow::Result<PyResult<(String, Owned, String)>> = crate::detached(
        py,
        || with_joints!(n, N => Ok(simulate_n::<N>(robot, &req))),
    )?;
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
