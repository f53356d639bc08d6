//! `kinecal._native`: the kinecal command line's application (`kinecal_cli`) behind a PyO3
//! module, numpy arrays in and out. The public Python API is the package `kinecal`
//! (`python/kinecal/__init__.py`), which wraps these functions; python/README.md describes it.
//!
//! Every number comes from the functions the `kinecal` subcommands call, in memory: the
//! arrays become measurement sets through the CSV reader's checks and the command line's
//! loading doors (units, a stated base, the angle order; [`data`], [`commands::accepted`]);
//! `identify`, `check` and `diagnose` ([`commands`]), `compensate`, `frames`, `plan` and
//! `simulate` ([`producers`]) take typed options ([`options`]: the application's option
//! structs and defaults; no command line is parsed). Each calls the application function its
//! subcommand calls after reading its files; results come back as JSON text, arrays and robot
//! TOML text, never through a file. Errors keep the command line's one-line reasons: refused
//! input raises `kinecal.RefusedError` (a `ValueError`),
//! anything else `kinecal.KinecalError`.

mod cartesian;
mod commands;
mod data;
mod options;
mod producers;
mod robot;

use pyo3::prelude::*;

/// The Python exception for an error of the application: `kinecal.RefusedError` when the
/// input was refused (the command line's exit status 2), `kinecal.KinecalError` otherwise;
/// the message is the command line's one-line reason.
pub(crate) fn py_err(e: anyhow::Error) -> PyErr {
    let refused = kinecal_cli::commands::exit_status(&e) == kinecal_cli::EXIT_REFUSED;
    let text = kinecal_cli::reports::ErrorReport::of(&e).error;
    error(
        if refused {
            "RefusedError"
        } else {
            "KinecalError"
        },
        text,
    )
}

/// A `kinecal._errors` exception of class `class` with `text`.
pub(crate) fn error(class: &str, text: String) -> PyErr {
    Python::attach(
        |py| match py.import("kinecal._errors").and_then(|m| m.getattr(class)) {
            Ok(cls) => PyErr::from_type(cls.cast_into().expect("an exception class"), text),
            Err(e) => e,
        },
    )
}

/// Runs `work` without the GIL, the application's warnings (the lines the command line prints
/// on stderr: units, tables, reflectors …) kept; then raises each as `kinecal.DataWarning`
/// through Python's warnings machinery (filters, `warnings.catch_warnings`, `-W error`), at
/// the caller of the package's function, instead of printing it.
pub(crate) fn detached<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    let (r, lines) = py.detach(|| kinecal_cli::captured(work));
    for line in lines {
        data_warning(py, line.strip_prefix("warning: ").unwrap_or(&line), 2)?;
    }
    Ok(r)
}

/// Raises `text` as `kinecal.DataWarning` through Python's warnings machinery, attributed
/// `stacklevel` frames up (1: the caller of the native function).
pub(crate) fn data_warning(py: Python<'_>, text: &str, stacklevel: i32) -> PyResult<()> {
    let category = py.import("kinecal._errors")?.getattr("DataWarning")?;
    let message = std::ffi::CString::new(text.replace('\0', " "))
        .map_err(|e| PyErr::new::<pyo3::exceptions::PyValueError, _>(e.to_string()))?;
    PyErr::warn(py, &category, &message, stacklevel)
}

/// Refused input (`kinecal.RefusedError`) with the reason `text`.
pub(crate) fn refused(text: String) -> PyErr {
    error("RefusedError", text)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<robot::Robot>()?;
    m.add_function(wrap_pyfunction!(data::read_csv, m)?)?;
    m.add_function(wrap_pyfunction!(data::write_csv, m)?)?;
    m.add_function(wrap_pyfunction!(commands::identify, m)?)?;
    m.add_function(wrap_pyfunction!(commands::check, m)?)?;
    m.add_function(wrap_pyfunction!(commands::diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(producers::compensate, m)?)?;
    m.add_function(wrap_pyfunction!(producers::frames, m)?)?;
    m.add_function(wrap_pyfunction!(producers::plan, m)?)?;
    m.add_function(wrap_pyfunction!(producers::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(cartesian::compensate_cartesian, m)?)?;
    m.add_function(wrap_pyfunction!(cartesian::unreached_error, m)?)?;
    Ok(())
}
