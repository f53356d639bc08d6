//! `kinecal.Robot`: a robot description (the robot TOML of docs/formats.md) held as the
//! command line's [`RobotFile`], with forward kinematics and the identification Jacobian of
//! the library over arrays of joint readings.

use crate::{py_err, refused};
use kinecal::forward::ForwardKinematics;
use kinecal::model::param::ParamSet;
use kinecal::Param;
use kinecal_cli::formats::robot_file::{BaseSpec, JointSpec, RobotFile, ToolSpec};
use kinecal_cli::with_joints;
use kinecal_cli::HostRobot;
use numpy::ndarray::{Array2, Array3, ArrayView2};
use numpy::{IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use std::path::PathBuf;

/// A robot: modified-DH rows (plus tilt), tool point, optional base pose, effects and
/// couplings, exactly as a robot TOML file describes it (docs/formats.md).
#[pyclass(module = "kinecal", frozen)]
#[derive(Clone)]
pub struct Robot {
    pub file: RobotFile,
}

/// The library model of `file` with `N` joints (a refused error names it `robot`).
pub fn model<const N: usize>(file: &RobotFile) -> anyhow::Result<HostRobot<N>> {
    model_named(file, "robot")
}

/// The library model of `file` with `N` joints (a refused error names `origin`).
pub fn model_named<const N: usize>(file: &RobotFile, origin: &str) -> anyhow::Result<HostRobot<N>> {
    file.to_robot::<N>()
        .map_err(|e| kinecal_cli::refused(format!("{origin}: {e}")))
}

impl Robot {
    /// A robot from a parsed file, refused when its model cannot be built.
    pub fn checked(file: RobotFile, origin: &str) -> PyResult<Self> {
        let n = file.joint_count();
        let r: anyhow::Result<()> = with_joints!(n, N => file
            .to_robot::<N>()
            .map(|_| ())
            .map_err(|e| kinecal_cli::refused(format!("{origin}: {e}"))));
        r.map_err(py_err)?;
        Ok(Self { file })
    }
}

/// Joint readings `q` (n × N) in radians, refused with a one-line reason when a reading is not
/// a finite number or the count of columns is not the robot's joint count.
pub fn readings<const N: usize>(
    q: ArrayView2<'_, f64>,
    radians: bool,
    origin: &str,
) -> PyResult<Vec<[f64; N]>> {
    if q.ncols() != N {
        return Err(refused(format!(
            "{origin}: {} columns of joint readings, but the robot has {N} joints (one column \
             per joint, q1…q{N})",
            q.ncols()
        )));
    }
    let mut out = Vec::with_capacity(q.nrows());
    for (i, row) in q.outer_iter().enumerate() {
        let mut r = [0.0; N];
        for (j, (o, v)) in r.iter_mut().zip(row.iter()).enumerate() {
            if !v.is_finite() {
                return Err(refused(format!(
                    "{origin}: row {i}, q{}: {}",
                    j + 1,
                    kinecal::io::csv::CsvErrorKind::NotFinite.describe()
                )));
            }
            // As the CSV path does (`Measurement::from_deg`): degrees to radians.
            *o = if radians { *v } else { v.to_radians() };
        }
        out.push(r);
    }
    Ok(out)
}

fn fk_n<const N: usize>(
    file: &RobotFile,
    q: ArrayView2<'_, f64>,
    radians: bool,
    temp_c: Option<&[f64]>,
) -> PyResult<Array2<f64>> {
    let robot = model::<N>(file).map_err(py_err)?;
    let qs = readings::<N>(q, radians, "q")?;
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut out = Array2::zeros((qs.len(), 3));
    for (k, q) in qs.iter().enumerate() {
        // A thermal-expansion term is evaluated at the pose's temperature (None: at its
        // reference), as identify evaluates a measurement with a `temp_c`.
        fk.temp_c = temp_c.map(|t| t[k]);
        let p = fk.compute(&robot, q);
        for a in 0..3 {
            out[[k, a]] = p[a];
        }
    }
    Ok(out)
}

/// The parameters `names` (or the default set: what `identify` estimates for this file).
fn params_of<const N: usize>(
    file: &RobotFile,
    robot: &HostRobot<N>,
    names: Option<Vec<String>>,
) -> PyResult<Vec<Param>> {
    match names {
        Some(names) => names
            .iter()
            .map(|n| {
                Param::parse(n.trim())
                    .filter(|p| p.joint().is_none_or(|j| j < N))
                    .ok_or_else(|| {
                        refused(format!(
                            "parameter {n}: not a parameter of this {N}-joint robot (names: \
                             base.x … base.rz, alpha1, a1, theta1, d1, beta1 … d{N}, tool.x, \
                             tool.y, tool.z)"
                        ))
                    })
            })
            .collect(),
        None => {
            let mut p: Vec<Param> = ParamSet::<64>::full(N, !file.base_known())
                .map_err(|e| py_err(anyhow::anyhow!("{e:?}")))?
                .as_slice()
                .to_vec();
            p.extend(file.tilt_joints().iter().map(|j| Param::Beta(*j as u8)));
            p.extend((0..robot.effects().values().len()).map(|k| Param::Effect(k as u16)));
            Ok(p)
        }
    }
}

fn jacobian_n<const N: usize>(
    file: &RobotFile,
    q: ArrayView2<'_, f64>,
    names: Option<Vec<String>>,
    (radians, temp_c): (bool, Option<&[f64]>),
) -> PyResult<(Array3<f64>, Vec<String>)> {
    let robot = model::<N>(file).map_err(py_err)?;
    let params = params_of::<N>(file, &robot, names)?;
    let qs = readings::<N>(q, radians, "q")?;
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut cols = vec![nalgebra_zero(); params.len()];
    let mut out = Array3::zeros((qs.len(), 3, params.len()));
    for (k, q) in qs.iter().enumerate() {
        fk.temp_c = temp_c.map(|t| t[k]);
        fk.compute(&robot, q);
        fk.identification_jacobian(&robot, &params, &mut cols)
            .map_err(|e| refused(format!("jacobian: {e:?}")))?;
        for (c, v) in cols.iter().enumerate() {
            for a in 0..3 {
                out[[k, a, c]] = v[a];
            }
        }
    }
    let names = params.iter().map(|p| p.name(&robot).to_string()).collect();
    Ok((out, names))
}

/// `angle_unit` as a flag: true for radians.
pub fn radians(angle_unit: &str) -> PyResult<bool> {
    match angle_unit {
        "deg" => Ok(false),
        "rad" => Ok(true),
        u => Err(refused(format!(
            "angle_unit {u:?}: give \"deg\" or \"rad\""
        ))),
    }
}

/// The arm's temperature (°C) at each of `n` poses from `temp_c` (one number for all, or one
/// per pose; `None`: not given), refused when it is not finite (naming the row) or its count
/// is not the poses'. Without it, a model with a thermal-expansion term warns
/// (`kinecal.DataWarning`, `stacklevel` frames up) that the term is evaluated at its
/// reference temperature, as `compensate` warns for targets without `temp_c`.
pub fn temperatures(
    py: Python<'_>,
    file: &RobotFile,
    temp_c: Option<&Bound<'_, PyAny>>,
    n: usize,
    (what, stacklevel): (&str, i32),
) -> PyResult<Option<Vec<f64>>> {
    let Some(t) = temp_c.filter(|t| !t.is_none()) else {
        if let Some(t0) = file.thermal_reference_c() {
            crate::data_warning(
                py,
                &format!(
                    "{what}: the model has a thermal expansion and no temp_c was given: it is \
                     evaluated at its reference temperature {t0} °C, and misses an arm at \
                     another temperature by the expansion; pass temp_c= (the arm's \
                     temperature, °C: one value, or one per pose)"
                ),
                stacklevel,
            )?;
        }
        return Ok(None);
    };
    let kw = pyo3::types::PyDict::new(py);
    kw.set_item("dtype", "float64")?;
    let v: Vec<f64> = py
        .import("numpy")?
        .call_method("asarray", (t,), Some(&kw))
        .and_then(|a| a.call_method1("reshape", (-1,)))
        .and_then(|a| a.call_method0("tolist"))
        .and_then(|a| a.extract())
        .map_err(|e| refused(format!("temp_c: not a number or an array of numbers ({e})")))?;
    let v = match v.len() {
        1 => vec![v[0]; n],
        k if k == n => v,
        k => {
            return Err(refused(format!(
                "temp_c: {k} values for {n} poses: give one temperature (°C), or one per row of q"
            )))
        }
    };
    if let Some(i) = v.iter().position(|t| !t.is_finite()) {
        return Err(refused(format!(
            "temp_c: row {i}: {}: give the arm's temperature (°C) at every pose",
            kinecal::io::csv::CsvErrorKind::NotFinite.describe()
        )));
    }
    Ok(Some(v))
}

/// Parameter names: a list, or one name as a string.
fn names_of(params: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<String>>> {
    match params.filter(|p| !p.is_none()) {
        None => Ok(None),
        Some(p) => match p.extract::<String>() {
            Ok(one) => Ok(Some(vec![one])),
            Err(_) => p
                .extract::<Vec<String>>()
                .map(Some)
                .map_err(|e| refused(format!("params: give parameter names, a list of str ({e})"))),
        },
    }
}

/// `obj` as a float64 (n, k) array (a 1-D array is one row: the flag says so).
pub fn array2<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<(Bound<'py, PyArray2<f64>>, bool)> {
    let np = py.import("numpy")?;
    let kw = pyo3::types::PyDict::new(py);
    kw.set_item("dtype", "float64")?;
    let a = np
        .call_method("ascontiguousarray", (obj,), Some(&kw))
        .map_err(|e| refused(format!("{name}: not an array of numbers ({e})")))?;
    let ndim: usize = a.getattr("ndim")?.extract()?;
    let (a, one) = match ndim {
        1 => (a.call_method1("reshape", (1, -1))?, true),
        2 => (a, false),
        d => {
            let shape = a.getattr("shape")?.str()?.to_string();
            return Err(refused(format!(
                "{name}: shape {shape} ({d} dimensions); give (n, N): one row per pose"
            )));
        }
    };
    Ok((a.cast_into::<PyArray2<f64>>()?, one))
}

fn nalgebra_zero() -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::zeros()
}

#[pymethods]
impl Robot {
    /// Reads a robot TOML file (docs/formats.md); refused (`RefusedError`) with the command
    /// line's reason naming file, line and column.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        let file = RobotFile::load(&path).map_err(py_err)?;
        Self::checked(file, &path.display().to_string())
    }

    /// Parses the text of a robot TOML file; `origin` names it in error messages.
    #[staticmethod]
    #[pyo3(signature = (text, origin = "<toml>"))]
    fn from_toml(text: &str, origin: &str) -> PyResult<Self> {
        let file = RobotFile::parse(text, origin).map_err(py_err)?;
        Self::checked(file, origin)
    }

    /// A robot from modified-DH rows (n × 4: alpha_deg, a_mm, theta_deg, d_mm; or n × 5 with
    /// beta_deg), the tool point, optionally the base pose, joint limits (n × 2, degrees) and
    /// the measured frame's orientation. Checked as a robot file is.
    #[staticmethod]
    #[pyo3(signature = (rows, tool_xyz_mm, base_xyz_mm = None, base_rpy_deg = None, limits_deg = None, tool_rpy_deg = None, name = "robot"))]
    #[allow(clippy::too_many_arguments)]
    fn from_mdh(
        rows: PyReadonlyArray2<'_, f64>,
        tool_xyz_mm: [f64; 3],
        base_xyz_mm: Option<[f64; 3]>,
        base_rpy_deg: Option<[f64; 3]>,
        limits_deg: Option<PyReadonlyArray2<'_, f64>>,
        tool_rpy_deg: Option<[f64; 3]>,
        name: &str,
    ) -> PyResult<Self> {
        let rows = rows.as_array();
        if !(rows.ncols() == 4 || rows.ncols() == 5) {
            return Err(refused(format!(
                "rows: {} columns; give alpha_deg, a_mm, theta_deg, d_mm (and beta_deg) per joint",
                rows.ncols()
            )));
        }
        let limits = limits_deg.map(|l| l.as_array().to_owned());
        if let Some(l) = &limits {
            if l.nrows() != rows.nrows() || l.ncols() != 2 {
                return Err(refused(format!(
                    "limits_deg: shape ({}, {}); give one (lower, upper) row per joint ({}, 2)",
                    l.nrows(),
                    l.ncols(),
                    rows.nrows()
                )));
            }
        }
        let joints = rows
            .outer_iter()
            .enumerate()
            .map(|(i, r)| JointSpec {
                alpha_deg: r[0],
                a_mm: r[1],
                theta_deg: r[2],
                d_mm: r[3],
                beta_deg: r.get(4).copied().filter(|b| *b != 0.0),
                limits_deg: limits.as_ref().map(|l| [l[[i, 0]], l[[i, 1]]]),
            })
            .collect();
        let base = match (base_xyz_mm, base_rpy_deg) {
            (None, None) => None,
            (x, r) => Some(BaseSpec {
                xyz_mm: x.unwrap_or([0.0; 3]),
                rpy_deg: r.unwrap_or([0.0; 3]),
            }),
        };
        let file = RobotFile {
            name: name.to_string(),
            joints,
            tool: ToolSpec {
                xyz_mm: tool_xyz_mm,
                rpy_deg: tool_rpy_deg,
                unknown: false,
            },
            tools: Vec::new(),
            base,
            effects: Vec::new(),
            couplings: Vec::new(),
            prior: None,
        };
        // Through the text, so the checks and their messages are the file's.
        let text = file.to_toml().map_err(py_err)?;
        Self::from_toml(&text, "<mdh rows>")
    }

    /// The robot TOML text (what `save` writes).
    fn to_toml(&self) -> PyResult<String> {
        self.file.to_toml().map_err(py_err)
    }

    /// Writes the robot TOML file atomically.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.file.save(&path).map_err(py_err)
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> String {
        self.file.name.clone()
    }

    /// Number of joints.
    #[getter]
    fn joints(&self) -> usize {
        self.file.joint_count()
    }

    /// Whether the file gives the base pose (`[base]`); without it FK is in the robot base
    /// frame and `identify` fits the base.
    #[getter]
    fn base_known(&self) -> bool {
        self.file.base_known()
    }

    /// The base pose `(xyz_mm, rpy_deg)`, or None.
    #[getter]
    fn base(&self) -> Option<([f64; 3], [f64; 3])> {
        self.file.base.as_ref().map(|b| (b.xyz_mm, b.rpy_deg))
    }

    /// The tool point, mm, in the flange frame.
    #[getter]
    fn tool_xyz_mm(&self) -> [f64; 3] {
        self.file.tool.xyz_mm
    }

    /// The MDH rows, n × 5: alpha_deg, a_mm, theta_deg, d_mm, beta_deg.
    #[getter]
    fn mdh<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let j = &self.file.joints;
        Array2::from_shape_fn((j.len(), 5), |(i, c)| {
            let r = &j[i];
            [
                r.alpha_deg,
                r.a_mm,
                r.theta_deg,
                r.d_mm,
                r.beta_deg.unwrap_or(0.0),
            ][c]
        })
        .into_pyarray(py)
    }

    /// Joint limits, n × 2, degrees (±180 where the file gives none).
    #[getter]
    fn limits_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let n = self.file.joint_count();
        Array2::from_shape_fn((n, 2), |(i, c)| self.file.limits_deg(i)[c]).into_pyarray(py)
    }

    /// Forward kinematics of the measured point at joint readings `q`: an (n, N) array (or one
    /// pose, (N,)) in degrees, or radians with `angle_unit="rad"`. Returns (n, 3) (or (3,)),
    /// mm, in the measurement frame (the robot base frame when the file has no `[base]`).
    /// Couplings and joint corrections of the file are applied to the readings, as everywhere.
    /// `temp_c`: the arm's temperature (°C; one value, or one per pose), at which a
    /// `thermal-expansion` term is evaluated (a measurement's `temp_c`); without it the term is
    /// evaluated at its reference temperature, and `kinecal.DataWarning` says so.
    #[pyo3(signature = (q, angle_unit = "deg", temp_c = None))]
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        angle_unit: &str,
        temp_c: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let radians = radians(angle_unit)?;
        let (q, one) = array2(py, q, "q")?;
        let q = q.readonly();
        let n = self.file.joint_count();
        let t = temperatures(py, &self.file, temp_c, q.as_array().nrows(), ("fk", 1))?;
        let t = t.as_deref();
        let r: anyhow::Result<PyResult<Array2<f64>>> =
            with_joints!(n, N => Ok(fk_n::<N>(&self.file, q.as_array(), radians, t)));
        let out = r.map_err(py_err)??;
        let out = out.into_pyarray(py).into_any();
        if one {
            out.call_method1("reshape", (3,))
        } else {
            Ok(out)
        }
    }

    /// The identification Jacobian at joint readings `q` ((n, N) or (N,), degrees or radians
    /// with `angle_unit="rad"`): returns `(J, names)` with J of shape (n, 3, P) (or (3, P)),
    /// the derivative of the measured point (mm) by each parameter in `params` (names as
    /// `identify` prints them: `base.x`, `alpha2`, `d6`, `tool.z`, …; lengths per mm, angles
    /// per radian) or, by default, by the parameters `identify` estimates for this robot.
    /// `temp_c` as for `fk`: the temperature (°C) a `thermal-expansion` term is evaluated at.
    #[pyo3(signature = (q, params = None, angle_unit = "deg", temp_c = None))]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        params: Option<&Bound<'py, PyAny>>,
        angle_unit: &str,
        temp_c: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(Bound<'py, PyAny>, Vec<String>)> {
        let radians = radians(angle_unit)?;
        let params = names_of(params)?;
        let (q, one) = array2(py, q, "q")?;
        let q = q.readonly();
        let n = self.file.joint_count();
        let t = temperatures(
            py,
            &self.file,
            temp_c,
            q.as_array().nrows(),
            ("jacobian", 1),
        )?;
        let at = (radians, t.as_deref());
        let r: anyhow::Result<PyResult<(Array3<f64>, Vec<String>)>> =
            with_joints!(n, N => Ok(jacobian_n::<N>(&self.file, q.as_array(), params, at)));
        let (a, names) = r.map_err(py_err)??;
        let p = names.len();
        let a = a.into_pyarray(py).into_any();
        let a = if one {
            a.call_method1("reshape", (3, p))?
        } else {
            a
        };
        Ok((a, names))
    }

    /// The names of the parameters `identify` estimates for this robot (the default columns
    /// of `jacobian`).
    fn parameter_names(&self) -> PyResult<Vec<String>> {
        let n = self.file.joint_count();
        let r: anyhow::Result<PyResult<Vec<String>>> = with_joints!(n, N => Ok(
            model::<N>(&self.file).map_err(py_err).and_then(|robot| {
                params_of::<N>(&self.file, &robot, None)
                    .map(|p| p.iter().map(|p| p.name(&robot).to_string()).collect())
            })
        ));
        r.map_err(py_err)?
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.file == other.file
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot(name={:?}, joints={}, base_known={})",
            self.file.name,
            self.file.joint_count(),
            self.file.base_known()
        )
    }
}
