//! `compensate_cartesian`: the targets to send to a controller that keeps its nominal
//! kinematics, as `kinecal compensate --robot NOMINAL --cartesian` writes them
//! ([`kinecal::compensate::nominal_target`], the command line's default settings).

use crate::refused;
use crate::robot::{array2, radians, readings, Robot};
use kinecal::compensate::{nominal_target, Config, Status, Target};
use kinecal::Frame;
use kinecal_cli::with_joints;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

/// Per target: the point (n × 3: x, y, z in mm) or pose (n × 6: and rx, ry, rz, fixed-axis
/// roll/pitch/yaw in `angle_unit`) to send to a controller with the `nominal` kinematics so
/// that the robot `model` describes reaches it: where the nominal robot, placed at the model's
/// base, puts the tool at the compensated command (from the seeds: the controller's nominal
/// joints, n × N in `angle_unit`). Returns the sent targets (a failed row keeps its target) and
/// each row's status (`ok`, `singular`, `unreachable`, `limited`, `invalid`). `temp_c`: the
/// arm's temperature (°C; one value or one per target) at which the model's thermal expansion
/// is evaluated (without it, at its reference temperature, and a model with the term warns).
#[pyfunction]
#[pyo3(signature = (model, nominal, seeds, targets, angle_unit = "deg", temp_c = None))]
pub fn compensate_cartesian<'py>(
    py: Python<'py>,
    model: &Robot,
    nominal: &Robot,
    seeds: &Bound<'py, PyAny>,
    targets: &Bound<'py, PyAny>,
    angle_unit: &str,
    temp_c: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Vec<String>)> {
    let rad = radians(angle_unit)?;
    let (seeds, _) = array2(py, seeds, "seeds")?;
    let (targets, _) = array2(py, targets, "targets")?;
    let seeds = seeds.readonly();
    let targets = targets.readonly();
    let t = targets.as_array();
    let pose = match t.ncols() {
        3 => false,
        6 => true,
        k => {
            return Err(refused(format!(
                "targets: {k} columns; give x, y, z (mm) or x, y, z, rx, ry, rz"
            )))
        }
    };
    let n = model.file.joint_count();
    if nominal.file.joint_count() != n {
        return Err(refused(format!(
            "nominal: {} joints, the model {n}: give the controller's model of the same arm",
            nominal.file.joint_count()
        )));
    }
    // A model of another robot (or one typed wrong) is refused as `export` and the command
    // line refuse it.
    kinecal_cli::application::export::check_match(
        &model.file,
        "model",
        &nominal.file,
        "nominal",
        (
            kinecal_cli::application::export::MATCH_TOLERANCE_MM,
            kinecal_cli::application::export::MATCH_TOLERANCE_DEG,
        ),
    )
    .map_err(crate::py_err)?;
    let at = ("compensate_cartesian", 2);
    let temps = crate::robot::temperatures(py, &model.file, temp_c, t.nrows(), at)?;
    let to_rad = |a: f64| if rad { a } else { a.to_radians() };
    let from_rad = |a: f64| if rad { a } else { a.to_degrees() };
    type Sent = (Array2<f64>, Vec<String>);
    let r: anyhow::Result<PyResult<Sent>> = with_joints!(n, N => Ok((|| -> PyResult<Sent> {
        let m = crate::robot::model::<N>(&model.file).map_err(crate::py_err)?;
        let nom = crate::robot::model::<N>(&nominal.file).map_err(crate::py_err)?;
        let q = readings::<N>(seeds.as_array(), rad, "seeds")?;
        if q.len() != t.nrows() {
            return Err(refused(format!(
                "seeds: {} rows, targets {}: one seed per target",
                q.len(),
                t.nrows()
            )));
        }
        let mut out = Array2::<f64>::zeros((t.nrows(), t.ncols()));
        let mut status = Vec::with_capacity(t.nrows());
        for (i, (seed, row)) in q.iter().zip(t.outer_iter()).enumerate() {
            if row.iter().any(|v| !v.is_finite()) {
                return Err(refused(format!("targets: row {i} is not finite")));
            }
            let p = [row[0], row[1], row[2]];
            let target = if pose {
                Target::Pose(Frame::from_xyz_rpy(p, [row[3], row[4], row[5]].map(to_rad)))
            } else {
                Target::Point(nalgebra::Vector3::from(p))
            };
            let config = Config {
                temperature_c: temps.as_ref().map(|t| t[i]),
                ..Config::default()
            };
            let r = nominal_target(&m, &nom, &target, seed, &config);
            let sent = match &r {
                Ok((sent, _)) => match sent {
                    Target::Pose(f) => {
                        let rpy = f.rpy().map(from_rad);
                        vec![f.o.x, f.o.y, f.o.z, rpy[0], rpy[1], rpy[2]]
                    }
                    Target::Point(v) => vec![v.x, v.y, v.z],
                },
                Err(_) => row.to_vec(),
            };
            for (o, v) in out.row_mut(i).iter_mut().zip(sent) {
                *o = v;
            }
            let st = match &r {
                Ok(_) => Status::Ok,
                Err(e) => e.status(),
            };
            status.push(st.as_str().to_string());
        }
        Ok((out, status))
    })()));
    let (out, status) = r.map_err(crate::py_err)??;
    Ok((out.into_pyarray(py), status))
}

/// The command line's error for `failed` of `targets` not reached (`kinecal compensate` prints
/// it and exits 3; `cartesian`: `--cartesian`'s rows): one text for both front ends.
#[pyfunction]
#[pyo3(signature = (failed, targets, cartesian = false))]
pub fn unreached_error(failed: usize, targets: usize, cartesian: bool) -> Option<String> {
    kinecal_cli::reports::compensate::unreached_error(failed, targets, cartesian)
}
