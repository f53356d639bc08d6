//! The constraint fit: Levenberg–Marquardt over the model parameters and the groups' shapes
//! (socket centres, planes), after holding what the constraints cannot determine.
//!
//! Identifiability: the model columns of the weighted Jacobian at the start, with the shapes'
//! columns projected out (what a shape can absorb is not seen by the model), each scaled to
//! unit norm. A column that the projection (nearly, [`ABSORBED`]) empties (the base from
//! distances or sockets: the constraints are invariant to a rigid motion of the whole robot) is
//! held; then, while the
//! smallest singular value is below [`RANK_TOLERANCE`] of the largest (an overall scale from
//! sockets and planes without a length), the parameter that dominates its singular vector is
//! held, base parameters first. Held parameters keep their starting values.

use super::read::Group;
use super::shapes::{fit as fit_shape, points, Shape};
use super::system::{evaluate, step_shapes};
use crate::HostRobot;
use kinecal::model::param::apply_delta;
use kinecal::Param;
use nalgebra::{DMatrix, DVector};

/// Relative singular value (unit-norm columns) below which a direction of the model counts as
/// undetermined. A constraint's invariance is exact only where its residuals vanish (an overall
/// scale changes socket residuals in proportion to them): at the nominal model, millimetres
/// from the data over a reach of metres, such a direction sits near 1e-5 while the weakest
/// determined ones of a socket session sit near 0.1 (ER20, 6 sockets × 10 rows).
pub const RANK_TOLERANCE: f64 = 2e-3;
/// A model column that the shapes absorb to within this fraction of its norm is held: a base
/// rotation is absorbed by the socket centres to the spread of the predicted points over the
/// reach (~1e-3 at the nominal model), exactly by planes and distances.
pub const ABSORBED: f64 = 1e-2;
/// Most LM iterations.
pub const MAX_ITERATIONS: usize = 200;
/// Converged when a step lowers the cost by less than this fraction.
pub const COST_TOLERANCE: f64 = 1e-12;

/// A finished constraint fit.
#[derive(Clone, Debug)]
pub struct Fitted<const N: usize> {
    pub robot: HostRobot<N>,
    pub shapes: Vec<Shape>,
    /// The parameters estimated.
    pub estimated: Vec<Param>,
    /// The parameters held because the data cannot determine them.
    pub unidentifiable: Vec<Param>,
    pub iterations: usize,
    /// Evaluations of the residuals of all rows (the identifiability analysis's included).
    pub evaluations: usize,
    /// 1-σ of each estimated parameter from the data (model units: mm, rad, raw), in the order
    /// of `estimated`: the covariance `s²(JᵀWJ)⁻¹` at the fit, shapes' unknowns included, `s²`
    /// the weighted cost per degree of freedom, as on tracker points; `None` where the normal
    /// matrix cannot be inverted.
    pub data_sigma: Vec<Option<f64>>,
    pub converged: bool,
    /// How the iteration ended, in words.
    pub stop: String,
}

/// What identify would estimate from positions (the full set, the first row held when the base
/// is estimated, the file's tilts and effects, the further tool points, and `extra`: the tilts
/// `--effect` added), before `--fix/--free/--only`. Without tracker points the base is always
/// in the set: the analysis finds it undetermined and holds it.
pub fn candidates<const N: usize>(
    nominal: &HostRobot<N>,
    file: &crate::formats::robot_file::RobotFile,
    base_unknown: bool,
    extra: &[Param],
) -> anyhow::Result<Vec<Param>> {
    let mut params: Vec<Param> = kinecal::model::param::ParamSet::<64>::full(N, base_unknown)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    for t in file.tilt_joints() {
        params.push(Param::Beta(t as u8));
    }
    params.extend(
        extra
            .iter()
            .filter(|p| !params.contains(p))
            .copied()
            .collect::<Vec<_>>(),
    );
    params.extend((0..nominal.effects().values().len()).map(|k| Param::Effect(k as u16)));
    for k in 1..nominal.tool_point_count() {
        params.extend((0..3).map(|a| Param::ToolPoint(k as u8, a)));
    }
    if base_unknown {
        crate::calibration::selection::hold_first_row(&mut params);
    }
    params.dedup();
    Ok(params)
}

/// Each group's shape fitted to the points `robot` predicts (closed form, model held).
pub fn shapes_of<const N: usize>(robot: &HostRobot<N>, groups: &[Group<N>]) -> Vec<Shape> {
    groups
        .iter()
        .map(|g| fit_shape(g.kind, &points(robot, g)))
        .collect()
}

/// The parameters of `params` the constraints of `groups` cannot determine at `robot`, in the
/// order they were found.
pub fn unidentifiable<const N: usize>(
    robot: &HostRobot<N>,
    groups: &[Group<N>],
    params: &[Param],
) -> anyhow::Result<Vec<Param>> {
    let shapes = shapes_of(robot, groups);
    let (_, jac) = evaluate(robot, groups, &shapes, params, true)?;
    let np = params.len();
    let model = jac.columns(0, np).into_owned();
    let nuisance = jac.columns(np, jac.ncols() - np).into_owned();
    let mut seen = model.clone();
    if nuisance.ncols() > 0 {
        let svd = nuisance.svd(true, false);
        let u = svd.u.expect("U requested");
        let smax = svd.singular_values.max();
        for (k, s) in svd.singular_values.iter().enumerate() {
            if *s > 1e-12 * smax {
                let uk = u.column(k);
                let proj = uk.transpose() * &seen;
                seen -= uk * proj;
            }
        }
    }
    // Columns in mm per mm or per rad at the reach: one that is zero against the largest (a
    // base rotation seen by distances only) is held as well.
    let reach = robot.reach();
    let scaled = |k: usize, n: f64| n / params[k].scale(reach);
    let largest = (0..np).fold(0.0, |m: f64, k| m.max(scaled(k, model.column(k).norm())));
    let mut held = Vec::new();
    let mut free: Vec<usize> = Vec::new();
    for (k, p) in params.iter().enumerate() {
        let (before, after) = (model.column(k).norm(), seen.column(k).norm());
        if after <= ABSORBED * before || scaled(k, after) <= 1e-9 * largest {
            held.push(*p);
        } else {
            free.push(k);
        }
    }
    loop {
        if free.is_empty() {
            break;
        }
        // At least as many rows as columns (zeros below): a wide matrix's SVD has only as many
        // singular values as rows, and would hide the directions that fewer equations than
        // parameters leave undetermined.
        let mut a = DMatrix::zeros(seen.nrows().max(free.len()), free.len());
        for (c, &k) in free.iter().enumerate() {
            let col = seen.column(k);
            a.view_mut((0, c), (col.nrows(), 1))
                .copy_from(&(col / col.norm()));
        }
        let svd = a.svd(false, true);
        let s = &svd.singular_values;
        let (kmin, smin) = (s.imin(), s.min());
        if smin > RANK_TOLERANCE * s.max() {
            break;
        }
        let v = svd.v_t.expect("V requested").row(kmin).into_owned();
        let weight = |k: usize| if params[k].is_base() { 4.0 } else { 1.0 };
        let pick = (0..free.len())
            .max_by(|&i, &j| {
                (v[i].abs() * weight(free[i])).total_cmp(&(v[j].abs() * weight(free[j])))
            })
            .expect("free is not empty");
        held.push(params[free[pick]]);
        free.remove(pick);
    }
    Ok(held)
}

/// The equations of `groups` left once their shapes' unknowns and the `estimated` parameters
/// have taken theirs: at 0 or below, a fit meets every constraint exactly whatever the robot
/// (a plane of 8 rows takes 3 for itself, two planes leave 10 for 10 parameters).
pub fn spare_equations<const N: usize>(
    groups: &[Group<N>],
    shapes: &[Shape],
    estimated: &[Param],
) -> i64 {
    let (rows, unknowns) = equations(groups, shapes);
    rows as i64 - unknowns as i64 - estimated.len() as i64
}

/// The equations of `groups` and how many of them their `shapes`' unknowns take.
fn equations<const N: usize>(groups: &[Group<N>], shapes: &[Shape]) -> (usize, usize) {
    (
        super::system::rows(groups),
        shapes.iter().map(|s| s.unknowns()).sum(),
    )
}

/// Refuses a fit of `groups` that has no equation to spare ([`spare_equations`]): its error
/// is zero whatever the data, so it is no calibration and no test of one.
pub fn refuse_exact<const N: usize>(
    fitted: &Fitted<N>,
    groups: &[Group<N>],
    origin: &str,
) -> anyhow::Result<()> {
    let (rows, unknowns) = equations(groups, &fitted.shapes);
    if rows > unknowns + fitted.estimated.len() {
        return Ok(());
    }
    let shapes = if unknowns > 0 {
        format!("{unknowns} of them taken by the sockets' centres and the planes, the rest")
    } else {
        "all of them".to_string()
    };
    crate::refuse!(
        "{origin}: {} group{} give{} {rows} equations, {shapes} by the {} parameters they \
         determine: the fit meets every constraint exactly whatever the robot; measure more \
         rows or groups (a socket's row adds 3 equations, a plane's or a distance's 1), or \
         hold parameters with --fix",
        groups.len(),
        if groups.len() == 1 { "" } else { "s" },
        if groups.len() == 1 { "s" } else { "" },
        fitted.estimated.len()
    );
}

/// Fewer spare equations than this ([`spare_equations`]) leave a fit that nearly meets every
/// constraint whatever the robot: its RMS says little (as χ²/dof on fewer degrees of freedom,
/// [`super::outliers::chi2_per_dof`]).
pub const MIN_SPARE: i64 = 10;

/// A warning when the fit of `groups` has a few equations to spare but fewer than
/// [`MIN_SPARE`] (none: [`refuse_exact`]): 18 distances for 17 parameters fitted to 0.0005 mm
/// at 0.05 mm noise.
pub fn thin_warning<const N: usize>(fitted: &Fitted<N>, groups: &[Group<N>]) -> Option<String> {
    let spare = spare_equations(groups, &fitted.shapes, &fitted.estimated);
    (1..MIN_SPARE).contains(&spare).then(|| {
        format!(
            "only {spare} of the session's equations are left once the shapes and the {} \
             parameters have taken theirs: the fit nearly meets every constraint whatever the \
             robot, so its RMS says little; measure more rows or groups, or judge the model on \
             held-out groups (--holdout) or another session (--validate)",
            fitted.estimated.len()
        )
    })
}

/// Fits `params` of `start` and the groups' shapes to `groups`; holds what the data cannot
/// determine (see the module).
pub fn fit<const N: usize>(
    start: &HostRobot<N>,
    groups: &[Group<N>],
    params: &[Param],
) -> anyhow::Result<Fitted<N>> {
    let held = unidentifiable(start, groups, params)?;
    let estimated: Vec<Param> = params
        .iter()
        .copied()
        .filter(|p| !held.contains(p))
        .collect();
    let np = estimated.len();
    let mut robot = start.clone();
    let mut shapes = shapes_of(&robot, groups);
    let (mut r, mut jac) = evaluate(&robot, groups, &shapes, &estimated, true)?;
    // The analysis's evaluation and this one.
    let mut evaluations = 2;
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut stop = String::from("stopped at its iteration limit before converging");
    let mut converged = false;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let jtj = jac.transpose() * &jac;
        let g = jac.transpose() * &r;
        let diag: DVector<f64> = jtj.diagonal().map(|d| d.max(1e-12));
        let mut stepped = false;
        while lambda < 1e16 {
            let mut a = jtj.clone();
            for k in 0..a.nrows() {
                a[(k, k)] += lambda * diag[k];
            }
            let Some(delta) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial = robot.clone();
            if apply_delta(&mut trial, &estimated, &delta.as_slice()[..np]).is_err() {
                lambda *= 10.0;
                continue;
            }
            let trial_shapes = step_shapes(&shapes, &delta.as_slice()[np..]);
            let (tr, _) = evaluate(&trial, groups, &trial_shapes, &estimated, false)?;
            evaluations += 1;
            let trial_cost = tr.norm_squared();
            if trial_cost.is_finite() && trial_cost < cost {
                let drop = (cost - trial_cost) / cost.max(f64::MIN_POSITIVE);
                robot = trial;
                shapes = trial_shapes;
                cost = trial_cost;
                lambda = (lambda / 10.0).max(1e-12);
                stepped = true;
                if drop < COST_TOLERANCE {
                    converged = true;
                    stop = "converged (the cost no longer decreases)".into();
                }
                break;
            }
            lambda *= 10.0;
        }
        if !stepped {
            // No step lowers the cost however short: a minimum to the rounding of the cost.
            converged = true;
            stop = "converged (no shorter step lowers the cost)".into();
        }
        if converged {
            break;
        }
        (r, jac) = evaluate(&robot, groups, &shapes, &estimated, true)?;
        evaluations += 1;
    }
    // The Jacobian at the model and shapes reached (the loop's is one step behind).
    let (r, jac) = evaluate(&robot, groups, &shapes, &estimated, true)?;
    evaluations += 1;
    let data_sigma = sigmas(&r, &jac, np);
    Ok(Fitted {
        robot,
        shapes,
        estimated,
        unidentifiable: held,
        iterations,
        evaluations,
        data_sigma,
        converged,
        stop,
    })
}

/// The first `np` unknowns' 1-σ from the weighted residuals `r` and their Jacobian `jac`:
/// `s²(JᵀJ)⁻¹` with `s²` the cost per degree of freedom, the columns scaled to unit norm for
/// the inversion (`None` each when it fails or no degree of freedom is left).
fn sigmas(r: &DVector<f64>, jac: &DMatrix<f64>, np: usize) -> Vec<Option<f64>> {
    let n = jac.ncols();
    let dof = r.len().saturating_sub(n);
    let norms: Vec<f64> = (0..n).map(|k| jac.column(k).norm()).collect();
    if dof == 0 || norms.iter().any(|v| *v <= 0.0 || !v.is_finite()) {
        return vec![None; np];
    }
    let s2 = r.norm_squared() / dof as f64;
    let mut scaled = jac.clone();
    for (k, v) in norms.iter().enumerate() {
        scaled.column_mut(k).scale_mut(1.0 / v);
    }
    let Some(inv) = (scaled.transpose() * &scaled)
        .cholesky()
        .map(|c| c.inverse())
    else {
        return vec![None; np];
    };
    (0..np)
        .map(|k| {
            let v = s2 * inv[(k, k)] / (norms[k] * norms[k]);
            (v.is_finite() && v >= 0.0).then(|| v.sqrt())
        })
        .collect()
}
