//! Measurement sets between numpy and the command line's [`Dataset`]: arrays checked as the
//! CSV reader checks a file's cells, reading and writing measurement CSV files.

use crate::{py_err, refused};
use kinecal::io::csv::{CsvErrorKind, MAX_ABS_JOINT, MAX_ABS_MM};
use kinecal_cli::formats::measurements::{self, Dataset, Record};
use kinecal_cli::with_joints;
use numpy::ndarray::{Array2, ArrayView2};
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use std::path::PathBuf;

/// Arrays of one measurement set: joint readings (n × N), points (n × 3) and extra columns
/// (n × k, NaN = empty cell) by name, in the file's units.
pub struct Arrays<'a> {
    pub q: ArrayView2<'a, f64>,
    pub xyz: ArrayView2<'a, f64>,
    pub extra_names: Vec<String>,
    pub extra: Option<ArrayView2<'a, f64>>,
}

/// The dataset of `a` for an `N`-joint robot, refused naming `origin` for what the CSV reader
/// refuses in a file: a wrong count of columns, NaN or infinite readings or coordinates, and
/// magnitudes beyond the reader's bounds.
pub fn dataset<const N: usize>(a: &Arrays<'_>, origin: &str) -> PyResult<Dataset<N>> {
    let n = a.q.nrows();
    if a.q.ncols() != N {
        return Err(refused(format!(
            "{origin}: q has {} columns, but the robot has {N} joints (one column per joint, \
             q1…q{N})",
            a.q.ncols()
        )));
    }
    if a.xyz.ncols() != 3 || a.xyz.nrows() != n {
        return Err(refused(format!(
            "{origin}: xyz has shape ({}, {}); give one measured point (x, y, z) per row of q \
             ({n}, 3)",
            a.xyz.nrows(),
            a.xyz.ncols()
        )));
    }
    let k = a.extra_names.len();
    if let Some(e) = &a.extra {
        if e.nrows() != n || e.ncols() != k {
            return Err(refused(format!(
                "{origin}: the extra columns have shape ({}, {}); expected ({n}, {k})",
                e.nrows(),
                e.ncols()
            )));
        }
    } else if k > 0 {
        return Err(refused(format!(
            "{origin}: extra column names without values"
        )));
    }
    // Named as the command line names the cell of the file these arrays make (write_csv):
    // `ORIGIN:LINE:COLUMN: …`, row i on line i + 2 (the header is line 1), q1…qN in columns
    // 1…N and x, y, z after them; then the arrays' own row, 0-based.
    let bad = |row: usize, col: usize, name: &str, v: f64, kind: CsvErrorKind| {
        refused(format!(
            "{origin}:{}:{}: {} in column `{name}`: {v} (row {row} of the arrays)",
            row + 2,
            col + 1,
            kind.describe()
        ))
    };
    let mut records = Vec::with_capacity(n);
    for i in 0..n {
        let mut q_deg = [0.0; N];
        for (j, q) in q_deg.iter_mut().enumerate() {
            let v = a.q[[i, j]];
            let col = format!("q{}", j + 1);
            if !v.is_finite() {
                return Err(bad(i, j, &col, v, CsvErrorKind::NotFinite));
            }
            if v.abs() > MAX_ABS_JOINT {
                return Err(bad(i, j, &col, v, CsvErrorKind::OutOfRange));
            }
            *q = v;
        }
        let mut xyz_mm = [0.0; 3];
        for (c, x) in xyz_mm.iter_mut().enumerate() {
            let v = a.xyz[[i, c]];
            let col = ["x", "y", "z"][c];
            if !v.is_finite() {
                return Err(bad(i, N + c, col, v, CsvErrorKind::NotFinite));
            }
            if v.abs() > MAX_ABS_MM {
                return Err(bad(i, N + c, col, v, CsvErrorKind::OutOfRange));
            }
            *x = v;
        }
        let extra = a
            .extra
            .as_ref()
            .map(|e| e.row(i).to_vec())
            .unwrap_or_default();
        records.push(Record {
            q_deg,
            xyz_mm,
            extra,
            // Row i is line i + 2 of the file these arrays make (header on line 1,
            // kinecal_cli::formats::origin::Origin::layout): messages name the same lines.
            line: (i + 2) as u32,
        });
    }
    Ok(Dataset {
        records,
        extra_names: a.extra_names.clone(),
    })
}

/// `(q, xyz, extra_names, extra)` in Rust.
type Owned = (Array2<f64>, Array2<f64>, Vec<String>, Array2<f64>);

type Columns<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Vec<String>,
    Bound<'py, PyArray2<f64>>,
);

/// The arrays `(q, xyz, extra)` of `ds` (NaN where a row has no extra value).
pub(crate) fn arrays_of<const N: usize>(
    ds: &Dataset<N>,
) -> (Array2<f64>, Array2<f64>, Array2<f64>) {
    let n = ds.len();
    let k = ds.extra_names.len();
    let q = Array2::from_shape_fn((n, N), |(i, j)| ds.records[i].q_deg[j]);
    let xyz = Array2::from_shape_fn((n, 3), |(i, j)| ds.records[i].xyz_mm[j]);
    let extra = Array2::from_shape_fn((n, k), |(i, j)| {
        ds.records[i].extra.get(j).copied().unwrap_or(f64::NAN)
    });
    (q, xyz, extra)
}

/// Reads a measurement CSV file (docs/formats.md) as written (no unit conversion): returns
/// `(q, xyz, extra_names, extra)`. `joints` defaults to the largest `qK` of the header.
/// Malformed files raise `RefusedError` with the reason `FILE:LINE:COLUMN: …`.
#[pyfunction]
#[pyo3(signature = (path, joints = None))]
pub fn read_csv<'py>(
    py: Python<'py>,
    path: PathBuf,
    joints: Option<usize>,
) -> PyResult<Columns<'py>> {
    let n = match joints {
        Some(n) => n,
        None => measurements::joint_count(&path).map_err(py_err)?,
    };
    let r: anyhow::Result<Owned> = with_joints!(n, N => {
        measurements::load::<N>(&path).map(|ds| {
            let (q, xyz, extra) = arrays_of(&ds);
            (q, xyz, ds.extra_names.clone(), extra)
        })
    });
    let (q, xyz, names, extra) = r.map_err(py_err)?;
    Ok((
        q.into_pyarray(py),
        xyz.into_pyarray(py),
        names,
        extra.into_pyarray(py),
    ))
}

/// Writes a measurement CSV file atomically, every number exactly (it reads back to the same
/// values): `q1…qN, x, y, z` and the extra columns (NaN = empty cell).
#[pyfunction]
#[pyo3(signature = (path, q, xyz, extra_names = Vec::new(), extra = None))]
pub fn write_csv(
    path: PathBuf,
    q: PyReadonlyArray2<'_, f64>,
    xyz: PyReadonlyArray2<'_, f64>,
    extra_names: Vec<String>,
    extra: Option<PyReadonlyArray2<'_, f64>>,
) -> PyResult<()> {
    let a = Arrays {
        q: q.as_array(),
        xyz: xyz.as_array(),
        extra_names,
        extra: extra.as_ref().map(|e| e.as_array()),
    };
    for name in &a.extra_names {
        let ok = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
        if !ok || name.starts_with('q') && name[1..].parse::<usize>().is_ok() {
            return Err(refused(format!(
                "extra column `{name}`: use letters, digits, `_` and `.` (not q1…qN)"
            )));
        }
    }
    let origin = path.display().to_string();
    let n = a.q.ncols();
    let text: anyhow::Result<PyResult<String>> = with_joints!(n, N => Ok(
        dataset::<N>(&a, &origin).map(|ds| measurements::to_exact_csv_string(&ds))
    ));
    let text = text.map_err(py_err)??;
    kinecal_cli::output::atomic::write_atomic(&path, text.as_bytes())
        .map_err(|e| py_err(anyhow::anyhow!("{origin}: cannot write: {e}")))
}
