//! The subcommands that read measurements, from Python: their options typed
//! ([`crate::options`]: the application's option structs and defaults, no command line), the
//! arrays built into measurement sets through the command line's doors, and `identify`,
//! `check` and `diagnose` run on them in memory. The shared pieces ([`finish`], [`Set`],
//! [`accepted`]) serve [`crate::producers`] too.

use crate::data::{dataset, Arrays};
use crate::options;
use crate::robot::{model, Robot};
use crate::{error, py_err};
use kinecal_cli::application::identify::{self as identification, Identified, Inputs};
use kinecal_cli::calibration::check::check as check_set;
use kinecal_cli::diagnose::workflow;
use kinecal_cli::formats::loading::accept_dataset;
use kinecal_cli::formats::measurements::Dataset;
use kinecal_cli::formats::observations::{observe, ObservationArgs, Observed};
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::formats::units::{FileKind, UnitArgs};
use kinecal_cli::reports::{CheckReport, DiagnoseReport, Report};
use kinecal_cli::HostRobot;
use kinecal_cli::{with_joints, Stderr};
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use std::path::Path;

/// The JSON text of a report and whether it may be taken as calibrated; a report with a
/// figure that is not finite is an error, as on the command line.
pub fn finish(r: anyhow::Result<Box<dyn Report>>) -> PyResult<(String, bool)> {
    let r = r.map_err(py_err)?;
    if let Some(e) = kinecal_cli::reports::ErrorReport::non_finite(r.as_ref()) {
        return Err(error("KinecalError", e.error));
    }
    let text = serde_json::to_string(&r.to_json()).map_err(|e| py_err(e.into()))?;
    Ok((text, r.converged()))
}

/// One measurement set from Python: `(q, xyz, extra_names, extra)`.
pub type Set<'py> = (
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    Vec<String>,
    Option<PyReadonlyArray2<'py, f64>>,
);

pub fn arrays<'a>(s: &'a Set<'_>) -> Arrays<'a> {
    Arrays {
        q: s.0.as_array(),
        xyz: s.1.as_array(),
        extra_names: s.2.clone(),
        extra: s.3.as_ref().map(|e| e.as_array()),
    }
}

/// The measurement set `a` (named `origin`) as the command line loads a file of `kind`: the
/// CSV reader's checks on the arrays, then the doors of its loader (a stated base, the units,
/// the angle order) for the model `nominal`; in mm and degrees.
pub fn accepted<const N: usize>(
    a: &Arrays<'_>,
    origin: &str,
    units: &UnitArgs,
    nominal: &HostRobot<N>,
    base_known: bool,
    kind: FileKind,
) -> PyResult<Dataset<N>> {
    let ds = dataset::<N>(a, origin)?;
    accept_dataset(ds, origin, units, nominal, base_known, kind).map_err(py_err)
}

/// The observations of the measurement set `a` (named `origin`) for the robot `file`, as a
/// measurement file's.
fn observed<const N: usize>(
    a: &Arrays<'_>,
    origin: &str,
    (file, nominal): (&RobotFile, &HostRobot<N>),
    units: &UnitArgs,
    obs: &ObservationArgs,
) -> PyResult<Observed<N>> {
    let ds = accepted::<N>(
        a,
        origin,
        units,
        nominal,
        file.base_known(),
        FileKind::Measurements,
    )?;
    observe(&ds, file, obs, origin).map_err(py_err)
}

/// The observations of `data` and of the validation set `validate`, named `data` and
/// `validate` (as `identify` and `diagnose` read them).
fn observed_sets<const N: usize>(
    data: &Arrays<'_>,
    validate: Option<&Arrays<'_>>,
    models: (&RobotFile, &HostRobot<N>),
    units: &UnitArgs,
    obs: &ObservationArgs,
) -> PyResult<(Observed<N>, Option<(Observed<N>, String)>)> {
    let observed = observed(data, "data", models, units, obs)?;
    let validate = match validate {
        Some(v) => Some((
            self::observed(v, "validate", models, units, obs)?,
            "validate".to_string(),
        )),
        None => None,
    };
    Ok((observed, validate))
}

fn identify_n<const N: usize>(
    robot: &Robot,
    (opts, units): (&identification::Options, &UnitArgs),
    data: &Arrays<'_>,
    validate: Option<&Arrays<'_>>,
) -> PyResult<Identified<N>> {
    let file = robot.file.clone();
    let nominal = model::<N>(&file).map_err(py_err)?;
    // As the command loads a file: the reader's checks, the doors of the command line's own
    // loader (a stated base, the units, the angle order), the observations.
    let models = (&file, &nominal);
    let (observed, validate) = observed_sets(data, validate, models, units, &opts.obs)?;
    let inputs = Inputs {
        file: file.clone(),
        nominal,
        observed,
        robot_origin: "robot".into(),
        data_origin: "data".into(),
        validate,
    };
    identification::identify(opts, inputs).map_err(py_err)
}

/// `kinecal identify` on arrays: `data` and `validate` the measurement sets `(q, xyz,
/// extra_names, extra)` in the units `options` say; `options` the keyword arguments of
/// `kinecal.identify` ([`options::Identify`], [`options::Units`], [`options::Observations`]).
/// Messages name the sets `data` and `validate` and the robot `robot`. Returns
/// `(json_text, model_toml, converged)`.
#[pyfunction]
#[pyo3(signature = (robot, data, validate, options))]
pub fn identify(
    py: Python<'_>,
    robot: &Robot,
    data: Set<'_>,
    validate: Option<Set<'_>>,
    options: &Bound<'_, PyAny>,
) -> PyResult<(String, String, bool)> {
    let obs: options::Observations = options::extract("identify", options)?;
    let opts = options::extract::<options::Identify>("identify", options)?.options(&obs)?;
    let units = options::extract::<options::Units>("identify", options)?.args()?;
    let data = arrays(&data);
    let validate = validate.as_ref().map(arrays);
    let n = robot.file.joint_count();
    let done = crate::detached(py, || {
        let r: anyhow::Result<PyResult<(String, String, bool)>> = with_joints!(n, N => Ok(
            identify_n::<N>(robot, (&opts, &units), &data, validate.as_ref()).and_then(|d| {
                let model = d.model.to_toml().map_err(py_err)?;
                let (json, converged) = finish(Ok(Box::new(d.report)))?;
                Ok((json, model, converged))
            })
        ));
        r
    })?;
    done.map_err(py_err)?
}

fn check_n<const N: usize>(
    robot: &Robot,
    units: &UnitArgs,
    data: &Arrays<'_>,
) -> PyResult<(String, bool)> {
    let file = &robot.file;
    let (robot_name, data_name) = ("robot", "data");
    let nominal = crate::robot::model_named::<N>(file, robot_name).map_err(py_err)?;
    let kind = FileKind::Measurements;
    let ds = accepted::<N>(data, data_name, units, &nominal, file.base_known(), kind)?;
    let c = check_set(file, nominal, &ds, data_name).map_err(py_err)?;
    finish(Ok(Box::new(CheckReport::of(
        &c, file, robot_name, data_name,
    ))))
}

/// `kinecal check` on arrays: `data` the measurement set, `options` the units
/// ([`options::Units`]). Returns `(json_text, converged)`.
#[pyfunction]
pub fn check(
    py: Python<'_>,
    robot: &Robot,
    data: Set<'_>,
    options: &Bound<'_, PyAny>,
) -> PyResult<(String, bool)> {
    let units = options::extract::<options::Units>("check", options)?.args()?;
    let data = arrays(&data);
    let n = robot.file.joint_count();
    let r: anyhow::Result<PyResult<(String, bool)>> = crate::detached(
        py,
        || with_joints!(n, N => Ok(check_n::<N>(robot, &units, &data))),
    )?;
    r.map_err(py_err)?
}

/// `(json_text, extended model TOML or None, converged, text)` of `diagnose`; `text` is the
/// report as the command line prints it without `--json` (its held-out lines included).
type Diagnosed = (String, Option<String>, bool, String);

fn diagnose_n<const N: usize>(
    robot: &Robot,
    (opts, units, plots): (&workflow::Options, &UnitArgs, Option<&Path>),
    data: &Arrays<'_>,
    validate: Option<&Arrays<'_>>,
) -> PyResult<Diagnosed> {
    let file = robot.file.clone();
    let nominal = crate::robot::model_named::<N>(&file, "robot").map_err(py_err)?;
    let models = (&file, &nominal);
    let (observed, validate) = observed_sets(data, validate, models, units, &opts.obs)?;
    let inputs = workflow::Inputs {
        file,
        nominal,
        observed,
        data_origin: "data".into(),
        validate,
    };
    let w = workflow::run(inputs, opts, &mut Stderr).map_err(py_err)?;
    let mut report = DiagnoseReport::of_workflow(&w, opts.stall_rms_mm);
    let model = if w.held_out_worse() {
        None
    } else {
        // The model comes back as text; the report names it as the command's `--out`.
        report.out = Some("model".into());
        Some(w.model.to_toml().map_err(py_err)?)
    };
    // The plots are the caller's output, in the folder it names.
    if let Some(dir) = plots {
        let files = kinecal_cli::diagnose::residual_plots::write_all(dir, &w.diagnosis, &w.search)
            .map_err(py_err)?;
        report.plots = Some(files.iter().map(|p| p.display().to_string()).collect());
    }
    let text = report.to_string();
    let (json, converged) = finish(Ok(Box::new(report)))?;
    Ok((json, model, converged, text))
}

/// `kinecal diagnose` on arrays: `data` and `validate` the measurement sets, `options` the
/// keyword arguments of `kinecal.diagnose` ([`options::Diagnose`], [`options::Observations`],
/// [`options::Units`]; nothing is written but the plots, into the folder `plots` names).
/// Returns `(json_text, model_toml, converged, text)`; `model_toml` is None when the extended
/// model predicts the held-out poses worse than the nominal robot (the command line does not
/// write it then).
#[pyfunction]
#[pyo3(signature = (robot, data, validate, options))]
pub fn diagnose(
    py: Python<'_>,
    robot: &Robot,
    data: Set<'_>,
    validate: Option<Set<'_>>,
    options: &Bound<'_, PyAny>,
) -> PyResult<Diagnosed> {
    let kw: options::Diagnose = options::extract("diagnose", options)?;
    let obs: options::Observations = options::extract("diagnose", options)?;
    let opts = kw.options(&obs)?;
    let units = options::extract::<options::Units>("diagnose", options)?.args()?;
    workflow::check_plots_dir(kw.plots.as_deref()).map_err(py_err)?;
    let data = arrays(&data);
    let validate = validate.as_ref().map(arrays);
    let n = robot.file.joint_count();
    let plots = kw.plots.as_deref();
    let r: anyhow::Result<PyResult<Diagnosed>> = crate::detached(py, || {
        with_joints!(n, N => Ok(diagnose_n::<N>(
            robot,
            (&opts, &units, plots),
            &data,
            validate.as_ref()
        )))
    })?;
    r.map_err(py_err)?
}
