//! Side-by-side identification on the same files: the `levenberg-marquardt` crate (MINPACK's
//! algorithm in Rust) with an analytic Jacobian built from [`ForwardKinematics::column`], against
//! kinecal's own Levenberg–Marquardt, as `kinecal identify --method lm` runs it
//! ([`kinecal_cli::calibration::fit_lm`]) and bare ([`kinecal::identify::lm::Levenberg::run`]).
//!
//! ```text
//! cargo build --release -p kinecal-host --features lm-compare --example lm_compare
//! target/release/examples/lm_compare --robot ROBOT.toml --data IDENT.csv --validate VALID.csv
//! ```
//!
//! All three start from the same model and estimate the same parameters as `kinecal identify`:
//! the base pose when the robot file has no `[base]` (the start then has the base registered
//! from the identification poses, as `identify` does before its clock starts), alpha, a, theta, d
//! of every joint, the tool point, the beta of tilted joints and the values of effects the file
//! carries. Only the solve is timed (files read, base registered, output written outside the
//! clock); each method runs `--reps` times and the median and minimum are reported. Prints one
//! JSON object.
//!
//! The crate's parameters are the changes from the start, applied with
//! [`kinecal::model::param::apply_delta`] (so the three base rotation entries are a rotation vector
//! `w`, base rotation `Exp(w)·R0`); its Jacobian is exact there: the columns of the base rotation
//! are mapped through the left Jacobian of SO(3). A central-difference check of that Jacobian is
//! part of the output (`jacobian_check_max_rel_error`).

use clap::Parser;
use kinecal::identify::lm::{Levenberg, LmConfig};
use kinecal::model::param::{apply_delta, Param, ParamSet};
use kinecal::{ForwardKinematics, Measurement, Robot};
use kinecal_cli::calibration::{fit_lm, pose_errors, ErrorStats};
use kinecal_cli::compute::vec_lm::VecLm;
use kinecal_cli::formats::loading::load_measurements;
use kinecal_cli::formats::robot_file::load_robot;
use kinecal_cli::formats::units::UnitArgs;
use kinecal_cli::HostRobot;
use kinecal_cli::{with_joints, VCAP};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::Vector3;
use nalgebra034::{storage::Owned, DMatrix, DVector, Dyn};
use serde_json::json;
use std::cell::Cell;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "levenberg-marquardt crate vs kinecal's LM on the same files (JSON)")]
struct Args {
    /// Robot description (TOML), as given to `kinecal identify --robot`.
    #[arg(long)]
    robot: PathBuf,
    /// Identification measurements (CSV).
    #[arg(long)]
    data: PathBuf,
    /// Held-out measurements (CSV).
    #[arg(long)]
    validate: PathBuf,
    /// Timed repetitions of each solve.
    #[arg(long, default_value_t = 21)]
    reps: usize,
    /// ftol = xtol = gtol of the crate (scipy's `least_squares(method="lm")` default: 1e-8).
    #[arg(long, default_value_t = 1e-8)]
    crate_tol: f64,
    /// Let the crate scale the parameters by the Jacobian's column norms (MINPACK mode 1, the
    /// crate's default) instead of the fixed mm / mrad units scipy_lm.py gives MINPACK.
    #[arg(long)]
    crate_scale_diag: bool,
    #[command(flatten)]
    units: UnitArgs,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let out = run(&args)?;
    println!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}

fn run(args: &Args) -> anyhow::Result<serde_json::Value> {
    let n = kinecal_cli::formats::robot_file::RobotFile::load(&args.robot)?.joint_count();
    with_joints!(n, N => run_n::<N>(args))
}

/// Median and minimum of `reps` timed runs of `f` (seconds), and the last run's result.
fn timed<R>(
    reps: usize,
    mut f: impl FnMut() -> anyhow::Result<R>,
) -> anyhow::Result<(f64, f64, R)> {
    let mut times = Vec::with_capacity(reps);
    let mut last = None;
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        let r = f()?;
        times.push(t0.elapsed().as_secs_f64());
        last = Some(std::hint::black_box(r));
    }
    times.sort_by(f64::total_cmp);
    let result = last.ok_or_else(|| anyhow::anyhow!("no run"))?;
    Ok((times[times.len() / 2], times[0], result))
}

fn run_n<const N: usize>(args: &Args) -> anyhow::Result<serde_json::Value> {
    let (file, mut start) = load_robot::<N>(&args.robot)?;
    let load = |p: &std::path::Path| {
        load_measurements(p, &args.units, &start, file.base_known())
            .map(|d| d.measurements::<f64>())
    };
    let ident = load(&args.data)?;
    let valid = load(&args.validate)?;
    anyhow::ensure!(
        !ident.is_empty(),
        "{}: no measurements",
        args.data.display()
    );
    let base_unknown = !file.base_known();
    let t0 = Instant::now();
    if base_unknown {
        let base = kinecal_cli::compute::registration::fit_base(&start, &ident)?;
        start
            .set_base(base)
            .map_err(|e| anyhow::anyhow!("estimated base pose is invalid: {e:?}"))?;
    }
    let registration_seconds = t0.elapsed().as_secs_f64();

    // The parameter list of `kinecal identify` (no --fix/--free, no --effect).
    let mut params: Vec<Param> = ParamSet::<64>::full(N, base_unknown)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    params.extend((0..start.effects().values().len()).map(|k| Param::Effect(k as u16)));
    params.extend(file.tilt_joints().iter().map(|&t| Param::Beta(t as u8)));
    let names: Vec<String> = params.iter().map(|p| p.name(&start).to_string()).collect();

    let held_out = |r: &HostRobot<N>| ErrorStats::of(&pose_errors(r, &valid)).map(|s| s.rms_mm);
    let ident_rms = |r: &HostRobot<N>| ErrorStats::of(&pose_errors(r, &ident)).map(|s| s.rms_mm);
    let mut methods = Vec::new();

    // (a) The levenberg-marquardt crate, analytic Jacobian.
    let solver = LevenbergMarquardt::new()
        .with_ftol(args.crate_tol)
        .with_xtol(args.crate_tol)
        .with_gtol(args.crate_tol)
        .with_scale_diag(args.crate_scale_diag);
    let jacobian_check = Problem::new(&start, &params, &ident)?.check_jacobian();
    let (med, min, (problem, report)) = timed(args.reps, || {
        let p = Problem::new(&start, &params, &ident)?;
        Ok(solver.minimize(p))
    })?;
    methods.push(json!({
        "method": "levenberg-marquardt crate 0.15 (analytic Jacobian)",
        "validation_rms_mm": held_out(&problem.robot),
        "identification_rms_mm": ident_rms(&problem.robot),
        "iterations": problem.jacobians.get(),
        "evaluations": report.number_of_evaluations,
        "stop": format!("{:?}", report.termination),
        "seconds_median": med,
        "seconds_min": min,
    }));

    // (b) kinecal's LM as `identify` runs it (with the identifiability report and 1-σ).
    let (med, min, fit) = timed(args.reps, || {
        fit_lm(&start, &params, &ident, LmConfig::default())
    })?;
    methods.push(json!({
        "method": "kinecal_cli::calibration::fit_lm (what identify times)",
        "validation_rms_mm": held_out(&fit.robot),
        "identification_rms_mm": ident_rms(&fit.robot),
        "iterations": fit.iterations,
        "evaluations": fit.evaluations,
        "stop": format!("{:?}", fit.stop),
        "held": fit.unidentifiable,
        "seconds_median": med,
        "seconds_min": min,
    }));

    // (c) The library's solver alone (no report), same parameters and configuration.
    let (med, min, (robot, progress)) = timed(args.reps, || bare_lm(&start, &params, &ident))?;
    methods.push(json!({
        "method": "kinecal::identify::lm::Levenberg::run (library solve only)",
        "validation_rms_mm": held_out(&robot),
        "identification_rms_mm": ident_rms(&robot),
        "iterations": progress.iteration,
        "evaluations": progress.evaluations,
        "stop": format!("{:?}", progress.stopped),
        "seconds_median": med,
        "seconds_min": min,
    }));

    Ok(json!({
        "robot": args.robot.display().to_string(),
        "data": args.data.display().to_string(),
        "validate": args.validate.display().to_string(),
        "n_identification": ident.len(),
        "n_validation": valid.len(),
        "base_unknown": base_unknown,
        "base_registration_seconds": registration_seconds,
        "n_parameters": params.len(),
        "parameters": names,
        "start_validation_rms_mm": held_out(&start),
        "reps": args.reps.max(1),
        "crate_tol": args.crate_tol,
        "crate_scale_diag": args.crate_scale_diag,
        "jacobian_check_max_rel_error": jacobian_check,
        "methods": methods,
    }))
}

type LmOut<const N: usize> = (HostRobot<N>, kinecal::identify::lm::LmProgress<f64>);

/// The solver `fit_lm` runs (same storage, same configuration), without its report.
fn bare_lm<const N: usize>(
    start: &HostRobot<N>,
    params: &[Param],
    data: &[Measurement<f64, N>],
) -> anyhow::Result<LmOut<N>> {
    let mut lm = Box::new(
        Levenberg::new(start.clone(), VecLm::new(params), LmConfig::default())
            .map_err(|e| anyhow::anyhow!("{e:?}"))?,
    );
    let p = lm.run(data).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    Ok((lm.robot().clone(), p))
}

/// The identification as a least-squares problem for the crate: parameters are the changes
/// from `start` in mm and mrad (lengths ×1, angles and effect values ×1000: the units
/// scipy_lm.py hands MINPACK), residuals `p(q) − measured` (mm), three per pose.
struct Problem<'a, const N: usize> {
    start: &'a HostRobot<N>,
    params: Vec<Param>,
    data: &'a [Measurement<f64, N>],
    x: DVector<f64>,
    /// Parameter units: `x_k = s_k · change_k`.
    s: Vec<f64>,
    /// Changes in library units (mm, rad), `x / s`.
    delta: Vec<f64>,
    robot: HostRobot<N>,
    /// False when `apply_delta` refused `x` (non-finite): residuals are then `None`.
    valid: bool,
    /// Positions of base.rx, base.ry, base.rz in the set, if estimated.
    rot: [Option<usize>; 3],
    /// Jacobian evaluations = the crate's outer iterations.
    jacobians: Cell<usize>,
}

impl<'a, const N: usize> Problem<'a, N> {
    fn new(
        start: &'a HostRobot<N>,
        params: &[Param],
        data: &'a [Measurement<f64, N>],
    ) -> anyhow::Result<Self> {
        kinecal::model::param::check_params(params, start).map_err(|e| anyhow::anyhow!("{e:?}"))?;
        let rot = [Param::BaseRx, Param::BaseRy, Param::BaseRz]
            .map(|p| params.iter().position(|q| *q == p));
        let s: Vec<f64> = params
            .iter()
            .map(|p| if p.is_length() { 1.0 } else { 1000.0 })
            .collect();
        Ok(Self {
            start,
            x: DVector::zeros(params.len()),
            delta: vec![0.0; params.len()],
            s,
            params: params.to_vec(),
            data,
            robot: start.clone(),
            valid: true,
            rot,
            jacobians: Cell::new(0),
        })
    }

    /// The base rotation vector `w` of the current parameters.
    fn w(&self) -> Vector3<f64> {
        Vector3::from_fn(|k, _| self.rot[k].map_or(0.0, |i| self.delta[i]))
    }

    /// Largest |analytic − central difference| / max(1, |column|) over all entries, at a point
    /// away from the start (so that the base rotation's left Jacobian matters).
    fn check_jacobian(mut self) -> f64 {
        let n = self.params.len();
        let x0 = DVector::from_fn(n, |i, _| 50.0 * (((i * 7919) % 13) as f64 - 6.0) / 6.0);
        self.set_params(&x0);
        let Some(j) = self.jacobian() else {
            return f64::NAN;
        };
        let mut worst: f64 = 0.0;
        for k in 0..n {
            let h = 1e-5;
            let mut xp = x0.clone();
            xp[k] += h;
            self.set_params(&xp);
            let rp = self.residuals();
            let mut xm = x0.clone();
            xm[k] -= h;
            self.set_params(&xm);
            let rm = self.residuals();
            let (Some(rp), Some(rm)) = (rp, rm) else {
                return f64::NAN;
            };
            let col = j.column(k);
            let fd = (rp - rm) / (2.0 * h);
            let err = (&fd - col).amax() / col.amax().max(1.0);
            worst = worst.max(err);
        }
        worst
    }
}

/// Left Jacobian of SO(3): `Exp(w + δ) ≈ Exp(J_l(w)·δ)·Exp(w)`.
fn left_jacobian(w: &Vector3<f64>) -> nalgebra::Matrix3<f64> {
    let t2 = w.norm_squared();
    let t = t2.sqrt();
    let (a, b) = if t < 1e-4 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        ((1.0 - t.cos()) / t2, (t - t.sin()) / (t2 * t))
    };
    let k = w.cross_matrix();
    nalgebra::Matrix3::identity() + k * a + k * k * b
}

impl<const N: usize> LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_, N> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
        for ((d, x), s) in self.delta.iter_mut().zip(x.iter()).zip(&self.s) {
            *d = x / s;
        }
        self.robot.clone_from(self.start);
        self.valid = apply_delta(&mut self.robot, &self.params, &self.delta).is_ok();
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        if !self.valid {
            return None;
        }
        let mut fk = ForwardKinematics::new();
        let mut r = DVector::zeros(3 * self.data.len());
        for (i, m) in self.data.iter().enumerate() {
            let e = fk.compute(&self.robot, &m.q) - m.point;
            for c in 0..3 {
                r[3 * i + c] = e[c];
            }
        }
        Some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        if !self.valid {
            return None;
        }
        self.jacobians.set(self.jacobians.get() + 1);
        let params = &self.params;
        let rotating = self.rot.iter().any(Option::is_some);
        let jl = left_jacobian(&self.w());
        let mut fk = ForwardKinematics::new();
        let mut j = DMatrix::zeros(3 * self.data.len(), params.len());
        for (i, m) in self.data.iter().enumerate() {
            fk.compute(&self.robot, &m.q);
            for (k, p) in params.iter().enumerate() {
                let c = fk.column(&self.robot, *p).ok()? / self.s[k];
                for r in 0..3 {
                    j[(3 * i + r, k)] = c[r];
                }
            }
            if rotating {
                // Columns of an incremental rotation e_k about the base origin, mapped to the
                // rotation vector's entries: ∂p/∂w_i = Σ_k c_k · J_l[k][i].
                let c = [Param::BaseRx, Param::BaseRy, Param::BaseRz]
                    .map(|p| fk.column(&self.robot, p));
                let [Ok(cx), Ok(cy), Ok(cz)] = c else {
                    return None;
                };
                for (col, idx) in self.rot.iter().enumerate() {
                    if let Some(idx) = *idx {
                        let v = (cx * jl[(0, col)] + cy * jl[(1, col)] + cz * jl[(2, col)])
                            / self.s[idx];
                        for r in 0..3 {
                            j[(3 * i + r, idx)] = v[r];
                        }
                    }
                }
            }
        }
        Some(j)
    }
}
