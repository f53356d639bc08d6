//! `kinecal._native`: the kinecal command line's application (`kinecal_cli`) behind a PyO3
//! module, numpy arrays in and out. The public Python API is the package `kinecal`
//! (`python/kinecal/__init__.py`), which wraps these functions; python/README.md describes it.
//!
//! Every number comes from the functions the `kinecal` subcommands call: `identify` through
//! [`kinecal_cli::commands::identify::identify`] on measurements built in memory through the
//! CSV reader's checks and the units check ([`data`]); `diagnose`, `compensate`, `frames`,
//! `plan`, `simulate` and `check` through the subcommand's own `run` on files the Python side
//! writes exactly ([`commands`]). Errors keep the command line's one-line reasons: refused
//! input raises `kinecal.RefusedError` (a `ValueError`), anything else `kinecal.KinecalError`.

mod cartesian;
mod commands;
mod data;
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
    m.add_function(wrap_pyfunction!(commands::run, m)?)?;
    m.add_function(wrap_pyfunction!(cartesian::compensate_cartesian, m)?)?;
    Ok(())
}
