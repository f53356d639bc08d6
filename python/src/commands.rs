//! The subcommands from Python: their arguments parsed by the command line's own clap
//! definitions (so every default and check is the command line's), `identify` on arrays in
//! memory, the others on files through the subcommand's `run`.

use crate::data::{dataset, Arrays};
use crate::robot::{model, Robot};
use crate::{error, py_err, refused};
use clap::Parser;
use kinecal_cli::commands::identify as identify_cmd;
use kinecal_cli::commands::identify::{Identified, Inputs};
use kinecal_cli::commands::{dispatch, non_finite_error, Cli, Command};
use kinecal_cli::formats::loading::accept_dataset;
use kinecal_cli::formats::observations::observe;
use kinecal_cli::formats::units::FileKind;
use kinecal_cli::reports::Report;
use kinecal_cli::with_joints;
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;

/// `argv` (without the program name) parsed as the command line parses it; a bad argument
/// is refused with clap's first line (`error: …` without `error: `).
fn parse(argv: &[String]) -> PyResult<Cli> {
    let words = std::iter::once("kinecal".to_string()).chain(argv.iter().cloned());
    Cli::try_parse_from(words).map_err(|e| {
        let text = e.to_string();
        let line = text.lines().next().unwrap_or("bad arguments");
        refused(line.trim_start_matches("error: ").to_string())
    })
}

/// The JSON text of a report and whether it may be taken as calibrated; a report with a
/// figure that is not finite is an error, as on the command line.
fn finish(r: anyhow::Result<Box<dyn Report>>) -> PyResult<(String, bool)> {
    let r = r.map_err(py_err)?;
    if let Some(e) = non_finite_error(r.as_ref()) {
        return Err(error("KinecalError", e.error));
    }
    let text = serde_json::to_string(&r.to_json()).map_err(|e| py_err(e.into()))?;
    Ok((text, r.converged()))
}

/// Runs the subcommand `argv` (e.g. `["diagnose", "--robot", R, "--data", D]`) on files,
/// exactly as `kinecal … --json` does ([`dispatch`]); returns `(json_text, converged)`.
#[pyfunction]
pub fn run(py: Python<'_>, argv: Vec<String>) -> PyResult<(String, bool)> {
    let cli = parse(&argv)?;
    py.detach(|| finish(dispatch(&cli)))
}

/// One measurement set from Python: `(q, xyz, extra_names, extra)`.
type Set<'py> = (
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    Vec<String>,
    Option<PyReadonlyArray2<'py, f64>>,
);

fn arrays<'a>(s: &'a Set<'_>) -> Arrays<'a> {
    Arrays {
        q: s.0.as_array(),
        xyz: s.1.as_array(),
        extra_names: s.2.clone(),
        extra: s.3.as_ref().map(|e| e.as_array()),
    }
}

fn identify_n<const N: usize>(
    robot: &Robot,
    args: &identify_cmd::Args,
    data: &Arrays<'_>,
    validate: Option<&Arrays<'_>>,
) -> PyResult<Identified<N>> {
    let file = robot.file.clone();
    let nominal = model::<N>(&file).map_err(py_err)?;
    // As the command loads a file: the reader's checks, the doors of the command line's own
    // loader (a stated base, the units, the angle order), the observations. Arrays are in
    // kinecal's layout: a map describes files.
    if let Some(m) = &args.input.units.map {
        return Err(refused(format!(
            "--map {}: a map says how to read a file; give the arrays in kinecal's columns",
            m.display()
        )));
    }
    let load = |a: &Arrays<'_>, origin: &str| -> PyResult<_> {
        let ds = dataset::<N>(a, origin)?;
        let ds = accept_dataset(
            ds,
            origin,
            &args.input.units,
            &nominal,
            file.base_known(),
            FileKind::Measurements,
        )
        .map_err(py_err)?;
        observe(&ds, &file, &args.obs, origin).map_err(py_err)
    };
    let observed = load(data, "data")?;
    let validate = match validate {
        Some(v) => Some((load(v, "validate")?, "validate".to_string())),
        None => None,
    };
    let inputs = Inputs {
        file: file.clone(),
        nominal,
        observed,
        robot_origin: "robot".into(),
        data_origin: "data".into(),
        validate,
    };
    identify_cmd::identify(args, inputs).map_err(py_err)
}

/// `kinecal identify` on arrays: `argv` holds the options as on the command line (`identify
/// --robot robot --data data [--validate validate] [--method …] …`; the paths are names only),
/// `data` and `validate` the measurement sets `(q, xyz, extra_names, extra)` in the units the
/// options say. Returns `(json_text, model_toml, converged)`.
#[pyfunction]
#[pyo3(signature = (robot, argv, data, validate = None))]
pub fn identify(
    py: Python<'_>,
    robot: &Robot,
    argv: Vec<String>,
    data: Set<'_>,
    validate: Option<Set<'_>>,
) -> PyResult<(String, String, bool)> {
    let Command::Identify(args) = parse(&argv)?.command else {
        return Err(refused("identify: argv must start with `identify`".into()));
    };
    let data = arrays(&data);
    let validate = validate.as_ref().map(arrays);
    let n = robot.file.joint_count();
    let done = py.detach(|| {
        let r: anyhow::Result<PyResult<(String, String, bool)>> = with_joints!(n, N => Ok(
            identify_n::<N>(robot, &args, &data, validate.as_ref()).and_then(|d| {
                let model = d.model.to_toml().map_err(py_err)?;
                let (json, converged) = finish(Ok(Box::new(d.report)))?;
                Ok((json, model, converged))
            })
        ));
        r
    });
    done.map_err(py_err)?
}
