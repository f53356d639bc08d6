//! Identification on the desktop: split the data, start the base, run a method, report errors
//! before and after in the units and keys of docs/formats.md "Command line: exit status and JSON".

pub mod acceptance;
pub mod arm_size;
pub mod base_moved;
pub mod check;
pub mod column_hint;
pub mod coupling_hint;
pub mod drift;
pub mod effects_in_degrees;
pub mod extrapolation;
pub mod folds;
pub mod held_geometry;
pub mod inputs;
pub mod joint_scale;
pub mod method;
pub mod orientation_slip;
pub mod outliers;
pub mod prior;
pub mod pso_search;
pub mod recalibration;
pub mod reflector_labels;
pub mod replay;
pub mod residual_table;
pub mod selection;
pub mod stats;
pub mod thermal;
pub mod thin_data;
pub mod tool_check;
pub mod validate;
pub mod weights;
pub mod wrapped_readings;
pub mod zero_moved;

use crate::compute::vec_lm::VecLm;
use kinecal::identify::lm::{Levenberg, LmConfig, LmStop};
use kinecal::model::param::{value, Param};
use kinecal::{ForwardKinematics, Measurement, Robot};
use serde::Serialize;
use std::collections::BTreeMap;

/// Position errors of a model over one data set.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct ErrorStats {
    pub rms_mm: f64,
    pub mean_mm: f64,
    pub max_mm: f64,
}

impl ErrorStats {
    pub fn of(errors: &[f64]) -> Option<Self> {
        Self::of_sums(&[Sums::of(errors)], errors.len())
    }

    /// [`ErrorStats::of`] the [`pose_errors`] of `robot` on `data`, without holding the
    /// errors: each part of the data ([`crate::compute::parallel::map_parts`]) is summed on
    /// its thread and the parts' sums are added in order. The same figures as `of`; bit for
    /// bit when the data are one part (fewer than
    /// [`crate::compute::parallel::PARALLEL_MIN_POSES`] poses), else to rounding.
    pub fn of_model<const N: usize, V: kinecal::ValueStorage>(
        robot: &Robot<f64, N, V>,
        data: &[Measurement<f64, N>],
    ) -> Option<Self> {
        if data.is_empty() {
            return None;
        }
        let parts = crate::compute::parallel::map_parts(data, |part| {
            let e: Vec<f64> = pose_error_vectors_of(robot, part)
                .map(|v| v.norm())
                .collect();
            Sums::of(&e)
        });
        Self::of_sums(&parts, data.len())
    }

    /// The statistics of `n` errors from the sums of their parts, added in order; `None`
    /// for none.
    fn of_sums(parts: &[Sums], n: usize) -> Option<Self> {
        if n == 0 {
            return None;
        }
        let n = n as f64;
        Some(Self {
            rms_mm: (parts.iter().map(|p| p.squares).sum::<f64>() / n).sqrt(),
            mean_mm: parts.iter().map(|p| p.sum).sum::<f64>() / n,
            max_mm: parts.iter().map(|p| p.max).fold(0.0, f64::max),
        })
    }
}

/// What [`ErrorStats`] needs of a run of errors: the sums of their squares and of themselves,
/// and the largest.
#[derive(Clone, Copy, Debug)]
struct Sums {
    squares: f64,
    sum: f64,
    max: f64,
}

impl Sums {
    fn of(errors: &[f64]) -> Self {
        Self {
            squares: errors.iter().map(|e| e * e).sum(),
            sum: errors.iter().sum(),
            max: errors.iter().cloned().fold(0.0, f64::max),
        }
    }
}

/// Per-pose 3-D position errors (mm) of `robot` on `data`: the lengths of
/// [`pose_error_vectors`].
pub fn pose_errors<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Vec<f64> {
    pose_error_vectors(robot, data)
        .iter()
        .map(|e| e.norm())
        .collect()
}

/// Per-pose position errors, measured − model (mm, measurement frame), of `robot` on `data`;
/// NaN where the model cannot be evaluated.
pub fn pose_error_vectors<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Vec<nalgebra::Vector3<f64>> {
    crate::compute::parallel::map_parts(data, |part| {
        pose_error_vectors_of(robot, part).collect::<Vec<_>>()
    })
    .concat()
}

/// [`pose_error_vectors`] of one part of the data, on the calling thread.
fn pose_error_vectors_of<'a, const N: usize, V: kinecal::ValueStorage>(
    robot: &'a Robot<f64, N, V>,
    data: &'a [Measurement<f64, N>],
) -> impl Iterator<Item = nalgebra::Vector3<f64>> + 'a {
    let mut fk = ForwardKinematics::new();
    data.iter().map(
        move |m| match fk.compute_at(robot, &m.q, m.tool as usize, m.conditions()) {
            Some(p) => m.point - p,
            None => nalgebra::Vector3::repeat(f64::NAN),
        },
    )
}

/// The joints (0-based, ascending) whose axis tilt a model carries as a parameter: the robot
/// file's `axis-tilt` effects (`file_tilts`) and every tilt a fit estimated (`params`, as
/// `--effect axis-tilt:J` adds it). The model written carries an `axis-tilt` effect on each, so
/// that a re-identification frees them again, and the report names each `beta`.
pub fn tilted_joints(file_tilts: &[usize], params: &[Param]) -> Vec<usize> {
    let mut v: Vec<usize> = file_tilts.to_vec();
    v.extend(params.iter().filter_map(|p| match p {
        Param::Beta(j) => Some(*j as usize),
        _ => None,
    }));
    v.sort_unstable();
    v.dedup();
    v
}

/// Every parameter of a model by name, in report order: base, the MDH rows, the tool point,
/// the tilts of `tilt_joints` (0-based), effect values, the tool orientation (when not the
/// identity) and further tool points. The `parameters` of `identify`'s report and the rows
/// of `report`'s parameter table.
pub fn model_params<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    tilt_joints: &[usize],
) -> Vec<Param> {
    let mut params: Vec<Param> = kinecal::ParamSet::<64>::full(N, true)
        .map(|s| s.as_slice().to_vec())
        .unwrap_or_default();
    params.extend(
        (0..N as u8)
            .map(Param::Beta)
            .filter(|p| tilt_joints.contains(&(p.joint().unwrap_or(99)))),
    );
    params.extend((0..robot.effects().values().len()).map(|k| Param::Effect(k as u16)));
    if !robot.tool_axes_identity() {
        params.extend([Param::ToolRx, Param::ToolRy, Param::ToolRz]);
    }
    for k in 1..robot.tool_point_count() {
        params.extend((0..3).map(|a| Param::ToolPoint(k as u8, a)));
    }
    params
}

/// Per-observation orientation errors (degrees: the angle between measured and model tool
/// frame) of `robot` on the 6-D observations of `data`.
pub fn orientation_errors_deg<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Vec<f64> {
    // In parts on several threads: even a file without orientations is a pass over every
    // observation.
    crate::compute::parallel::map_parts(data, |part| {
        let mut fk = ForwardKinematics::new();
        part.iter()
            .filter_map(|m| {
                let o = m.orientation.as_ref()?;
                fk.compute_at(robot, &m.q, m.tool as usize, m.conditions())?;
                Some(
                    kinecal::model::frame::orientation_error(o, &fk.tool_pose(robot))
                        .norm()
                        .to_degrees(),
                )
            })
            .collect::<Vec<_>>()
    })
    .concat()
}

/// Residual rows of `data`: three per point, three more per orientation.
pub fn residual_rows<const N: usize>(data: &[Measurement<f64, N>]) -> usize {
    data.iter()
        .map(|m| if m.orientation.is_some() { 6 } else { 3 })
        .sum()
}

/// The `before`/`after` object of the identify report.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Residuals {
    pub identification_rms_mm: f64,
    pub validation_rms_mm: Option<f64>,
    pub validation_mean_mm: Option<f64>,
    pub validation_max_mm: Option<f64>,
    /// Orientation RMS (degrees) of 6-D observations, when there are any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub identification_rms_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation_rms_deg: Option<f64>,
}

impl Residuals {
    pub fn of<const N: usize, V: kinecal::ValueStorage>(
        robot: &Robot<f64, N, V>,
        ident: &[Measurement<f64, N>],
        valid: &[Measurement<f64, N>],
    ) -> Self {
        let i = ErrorStats::of_model(robot, ident);
        let v = ErrorStats::of_model(robot, valid);
        let io = ErrorStats::of(&orientation_errors_deg(robot, ident));
        let vo = ErrorStats::of(&orientation_errors_deg(robot, valid));
        Self {
            identification_rms_mm: i.map_or(0.0, |s| s.rms_mm),
            validation_rms_mm: v.map(|s| s.rms_mm),
            validation_mean_mm: v.map(|s| s.mean_mm),
            validation_max_mm: v.map(|s| s.max_mm),
            identification_rms_deg: io.map(|s| s.rms_mm),
            validation_rms_deg: vo.map(|s| s.rms_mm),
        }
    }
}

/// Which poses `--holdout` keeps out of the fit (`--split`): the last ones of the file (the
/// default: measurement order, so a drift over the session shows up as a held-out error
/// instead of being averaged away), a random choice (`--seed`), or every K-th pose.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SplitKind {
    #[default]
    Last,
    Random,
    /// Poses K, 2K, 3K, … (1-based) are held out.
    Every(usize),
}

impl std::str::FromStr for SplitKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        match s {
            "last" => Ok(Self::Last),
            "random" => Ok(Self::Random),
            _ => match s.strip_prefix("every:").map(str::parse::<usize>) {
                Some(Ok(k)) if k >= 2 => Ok(Self::Every(k)),
                _ => anyhow::bail!(
                    "--split {s}: give last, random or every:K (K ≥ 2: every K-th pose held out)"
                ),
            },
        }
    }
}

/// Which of `n` poses are held out: `holdout` < 1 is the held-out fraction, ≥ 1 the held-out
/// count, chosen by `split` (`seed` for `random`); `every:K` holds out every K-th pose and
/// needs no `holdout`. Refused (exit 2) when nothing would be left to identify from.
pub fn held_out_mask(
    n: usize,
    holdout: Option<f64>,
    split: SplitKind,
    seed: u64,
) -> anyhow::Result<Vec<bool>> {
    let count = |h: f64| -> anyhow::Result<usize> {
        if !(h.is_finite() && h > 0.0) {
            crate::refuse!("--holdout {h}: give a fraction (0 < F < 1) or a count of poses (≥ 1)");
        }
        let k = if h < 1.0 {
            (h * n as f64).round() as usize
        } else if h.fract() == 0.0 && h <= n as f64 {
            h as usize
        } else if h.fract() != 0.0 {
            crate::refuse!(
                "--holdout {h}: a count of poses is a whole number; give a fraction (0 < F < 1) \
                 or a count (≥ 1)"
            );
        } else {
            n
        };
        if k == 0 {
            crate::refuse!(
                "--holdout {h} holds out no pose of {n}: give a larger fraction or a count (≥ 1)"
            );
        }
        if k >= n {
            crate::refuse!(
                "--holdout {h} leaves no poses to identify from ({n} poses): hold out fewer"
            );
        }
        Ok(k)
    };
    let mut mask = vec![false; n];
    match (split, holdout) {
        (SplitKind::Every(k), h) => {
            if let Some(h) = h {
                count(h)?;
            }
            for (i, m) in mask.iter_mut().enumerate() {
                *m = (i + 1) % k == 0;
            }
            if n < k {
                crate::refuse!(
                    "--split every:{k}: the data have {n} poses, so none would be held out: \
                     use a smaller K"
                );
            }
        }
        (_, None) => {}
        (SplitKind::Last, Some(h)) => {
            let k = count(h)?;
            mask[n - k..].iter_mut().for_each(|m| *m = true);
        }
        (SplitKind::Random, Some(h)) => {
            use rand::seq::SliceRandom;
            use rand::SeedableRng;
            let k = count(h)?;
            let mut order: Vec<usize> = (0..n).collect();
            order.shuffle(&mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed));
            for &i in &order[..k] {
                mask[i] = true;
            }
        }
    }
    Ok(mask)
}

/// Named parameter values in file units (degrees for angles, mm for lengths, raw for effects).
pub fn named_values<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    params: &[Param],
) -> BTreeMap<String, f64> {
    params
        .iter()
        .filter_map(|p| {
            let v = value(robot, *p)?;
            let v = match p {
                Param::Effect(_) => v,
                p if p.is_length() => v,
                _ => v.to_degrees(),
            };
            Some((p.name(robot).to_string(), v))
        })
        .collect()
}

/// Outcome of one identification run.
#[derive(Clone, Debug)]
pub struct Fit<const N: usize, V: kinecal::ValueStorage> {
    pub robot: Robot<f64, N, V>,
    pub iterations: u32,
    pub evaluations: u64,
    pub unidentifiable: Vec<String>,
    /// Best objective value (sum of squared errors, mm²) per iteration, when the method has one.
    pub history: Vec<f64>,
    /// Why the local solver stopped (`None` for a method without one, such as PSO alone).
    pub stop: Option<LmStop>,
    /// What was held at its start value, and with which estimated parameters it is confounded.
    pub held: Vec<Held>,
    /// 1-σ of each estimated parameter in file units (mm, degrees, raw for effect values),
    /// from the covariance `s²(JᵀWJ)⁻¹` with `s²` the (weighted) residual variance per row.
    pub sigma: BTreeMap<String, f64>,
    /// Weighted cost per degree of freedom (residual rows − estimated parameters): with the
    /// file's σ as weights, the χ² consistency figure (≈ 1 when the σ fit the residuals).
    pub chi2_per_dof: Option<f64>,
    /// The strongest correlations between estimated parameters, from the same covariance,
    /// largest |r| first (at most [`MAX_CORRELATIONS`]).
    pub correlations: Vec<Correlation>,
    /// What the prior did to each parameter it acts on (empty without one:
    /// [`prior::refit`]).
    pub prior: BTreeMap<String, prior::Share>,
}

/// How many correlations a [`Fit`] keeps.
pub const MAX_CORRELATIONS: usize = 12;

/// The correlation coefficient of two estimated parameters' estimates.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Correlation {
    pub a: String,
    pub b: String,
    pub r: f64,
}

impl<const N: usize, V: kinecal::ValueStorage> Fit<N, V> {
    /// A fit with no solver diagnostics (global methods).
    pub fn plain(
        robot: Robot<f64, N, V>,
        iterations: u32,
        evaluations: u64,
        history: Vec<f64>,
    ) -> Self {
        Self {
            robot,
            iterations,
            evaluations,
            unidentifiable: Vec::new(),
            history,
            stop: None,
            held: Vec::new(),
            sigma: BTreeMap::new(),
            chi2_per_dof: None,
            correlations: Vec::new(),
            prior: BTreeMap::new(),
        }
    }

    /// True when the local solver ended at a minimum (cost or step below tolerance), false when
    /// it hit its iteration limit or could not make progress.
    pub fn solver_converged(&self) -> bool {
        !matches!(self.stop, Some(LmStop::MaxIterations | LmStop::NoProgress))
    }
}

/// A parameter the data could not determine, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Held {
    pub name: String,
    /// Estimated parameters whose combination reproduces its effect on the measured points,
    /// strongest first (empty when no pose moves the point with it at all).
    pub confounded_with: Vec<String>,
    /// Each estimated parameter's change that stands in for a unit change of this one (scaled
    /// units, 1 mm at the tool), by name: how much of its manufacturing tolerance they absorb.
    #[serde(skip)]
    pub stand_ins: Vec<(String, f64)>,
}

/// Every k-th observation of `data`, at most `most` of them: the sample on which the checks
/// of a fit refit it ([`base_moved`], [`joint_scale`], [`zero_moved`]).
pub fn every_kth<const N: usize>(
    data: &[Measurement<f64, N>],
    most: usize,
) -> Vec<Measurement<f64, N>> {
    let every = data.len().div_ceil(most.max(1)).max(1);
    data.iter().step_by(every).copied().collect()
}

/// Levenberg–Marquardt from `start` over `params`, its normal equations on the heap sized
/// for exactly these parameters ([`VecLm`]).
pub fn fit_lm<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    params: &[Param],
    data: &[Measurement<f64, N>],
    cfg: LmConfig<f64>,
) -> anyhow::Result<Fit<N, V>> {
    fit_lm_with_solver(start, params, data, cfg).map(|(fit, _)| fit)
}

/// The solver of a finished [`fit_lm`] run (its final normal equations).
pub type FitSolver<const N: usize, V> = Box<Levenberg<f64, N, V, VecLm<f64>>>;

/// [`fit_lm`], and the solver at its end: a refit from the fit's result takes its first pass
/// from it ([`prior::refit_after`]).
pub fn fit_lm_with_solver<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    params: &[Param],
    data: &[Measurement<f64, N>],
    cfg: LmConfig<f64>,
) -> anyhow::Result<(Fit<N, V>, FitSolver<N, V>)> {
    // Complete passes: the re-analyses and the final confirmation of the held set read the
    // normal equations a pass left (one or two passes over the data fewer, the same numbers).
    let cfg = LmConfig {
        complete_passes: true,
        ..cfg
    };
    let mut lm = Box::new(
        Levenberg::new(start.clone(), VecLm::new(params), cfg)
            .map_err(|e| anyhow::anyhow!("identification setup: {e:?}"))?,
    );
    let mut history = Vec::new();
    let p = crate::compute::parallel::run_lm(&mut lm, data, |lm, p| {
        if lm.analysed() && history.last() != Some(&p.cost) {
            history.push(p.cost);
        }
    })
    .map_err(|e| anyhow::anyhow!("identification: {e:?}"))?;
    let rows = residual_rows(data);
    let (held, sigma, chi2_per_dof, correlations) = identifiability_report(&lm, rows, p.cost);
    let fit = Fit {
        robot: lm.robot().clone(),
        iterations: p.iteration,
        evaluations: p.evaluations as u64,
        unidentifiable: lm
            .unidentifiable()
            .map(|q| q.name(lm.robot()).to_string())
            .collect(),
        history,
        stop: p.stopped,
        held,
        sigma,
        chi2_per_dof,
        correlations,
        prior: BTreeMap::new(),
    };
    Ok((fit, lm))
}

/// Reads the solver's last normal matrix: for each held parameter the estimated ones it is
/// confounded with (coefficients of its normalised column on theirs), the 1-σ of each
/// estimated parameter and the strongest correlations of their estimates.
#[allow(clippy::type_complexity)]
fn identifiability_report<const N: usize, V: kinecal::ValueStorage>(
    lm: &Levenberg<f64, N, V, VecLm<f64>>,
    rows: usize,
    cost: f64,
) -> (
    Vec<Held>,
    BTreeMap<String, f64>,
    Option<f64>,
    Vec<Correlation>,
) {
    use nalgebra::{DMatrix, DVector};
    let params = lm.params();
    let n = params.len();
    let jtj = |i: usize, j: usize| lm.normal_matrix(i, j);
    let robot = lm.robot();
    let active: Vec<usize> = (0..n).filter(|&k| lm.is_active(k)).collect();
    let m = active.len();
    let a = DMatrix::from_fn(m, m, |i, j| jtj(active[i], active[j]));
    let mut sigma = BTreeMap::new();
    let mut correlations = Vec::new();
    let dof = rows.saturating_sub(m);
    let chi2_per_dof = (dof > 0).then(|| cost / dof as f64);
    let chol = a.clone().cholesky();
    if let (Some(ch), true) = (&chol, dof > 0) {
        let s2 = cost / dof as f64;
        let inv = ch.inverse();
        for (i, &k) in active.iter().enumerate() {
            let sd = (s2 * inv[(i, i)]).max(0.0).sqrt() / lm.scale(k);
            let sd = match params[k] {
                Param::Effect(_) => sd,
                p if p.is_length() => sd,
                _ => sd.to_degrees(),
            };
            sigma.insert(params[k].name(robot).to_string(), sd);
        }
        for i in 0..m {
            for j in 0..i {
                let r = inv[(i, j)] / (inv[(i, i)] * inv[(j, j)]).sqrt();
                if r.is_finite() {
                    correlations.push(Correlation {
                        a: params[active[j]].name(robot).to_string(),
                        b: params[active[i]].name(robot).to_string(),
                        r,
                    });
                }
            }
        }
        correlations.sort_by(|x, y| y.r.abs().total_cmp(&x.r.abs()));
        correlations.truncate(MAX_CORRELATIONS);
    }
    // Correlation-normalised: the coefficients then compare columns of different units.
    let d: Vec<f64> = (0..n).map(|k| jtj(k, k).max(0.0).sqrt()).collect();
    let corr = |i: usize, j: usize| {
        if d[i] > 0.0 && d[j] > 0.0 {
            jtj(i, j) / (d[i] * d[j])
        } else {
            0.0
        }
    };
    let r = DMatrix::from_fn(m, m, |i, j| corr(active[i], active[j]));
    let rchol = r.cholesky();
    let dmax = d.iter().cloned().fold(0.0, f64::max);
    let held = (0..n)
        .filter(|&k| !lm.is_active(k))
        .map(|k| {
            let mut with = Vec::new();
            let mut stand_ins = Vec::new();
            if d[k] > dmax * 1e-8 {
                if let Some(ch) = &rchol {
                    let b = DVector::from_fn(m, |i, _| corr(active[i], k));
                    let c = ch.solve(&b);
                    stand_ins = c
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| v.abs() > 1e-9)
                        .map(|(i, v)| {
                            let j = active[i];
                            (params[j].name(robot).to_string(), v * d[k] / d[j])
                        })
                        .collect();
                    let big = c.iter().fold(0.0f64, |x, v| x.max(v.abs()));
                    let mut terms: Vec<(f64, usize)> = c
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| v.abs() >= 0.2 * big && v.abs() > 1e-6)
                        .map(|(i, v)| (v.abs(), active[i]))
                        .collect();
                    terms.sort_by(|x, y| y.0.total_cmp(&x.0));
                    with = terms
                        .iter()
                        .take(4)
                        .map(|(_, j)| params[*j].name(robot).to_string())
                        .collect();
                }
            }
            Held {
                name: params[k].name(robot).to_string(),
                confounded_with: with,
                stand_ins,
            }
        })
        .collect();
    (held, sigma, chi2_per_dof, correlations)
}

/// An effect to add to the model before identification (`--effect KIND:JOINT[:ARG]`;
/// `--effect thermal-expansion[:0[:T0]]`, [`thermal`]).
#[derive(Clone, Debug, PartialEq)]
pub struct EffectRequest {
    /// An id of docs/formats.md "Effects" (`joint-compliance`, `joint-cyclic`, `joint-scale`,
    /// `axis-tilt`, `joint-table`).
    pub kind: String,
    /// 0-based joint.
    pub joint: usize,
    /// Harmonic order (cyclic, default 1), knot spacing in degrees (table, default 3.6) or
    /// reference temperature in °C (thermal-expansion, default the data's mean).
    pub arg: Option<f64>,
}

impl std::str::FromStr for EffectRequest {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        if let Some(r) = thermal::parse_request(s) {
            return r;
        }
        if let Some(r) = drift::parse_request(s) {
            return r;
        }
        let mut it = s.split(':');
        let kind = it.next().unwrap_or_default().to_string();
        let joint: usize = it
            .next()
            .ok_or_else(|| anyhow::anyhow!("--effect {s}: expected KIND:JOINT[:ARG]"))?
            .parse()
            .map_err(|_| anyhow::anyhow!("--effect {s}: JOINT must be a joint number (1-based)"))?;
        let arg = match it.next() {
            Some(a) => Some(
                a.parse::<f64>()
                    .map_err(|_| anyhow::anyhow!("--effect {s}: ARG must be a number"))?,
            ),
            None => None,
        };
        anyhow::ensure!(
            it.next().is_none(),
            "--effect {s}: expected KIND:JOINT[:ARG]"
        );
        anyhow::ensure!(joint >= 1, "--effect {s}: joints are numbered from 1");
        anyhow::ensure!(
            kind == "axis-tilt" || kinecal::EffectKind::from_id(&kind).is_some(),
            "--effect {s}: unknown effect '{kind}' (joint-compliance, joint-cyclic, joint-scale, axis-tilt, joint-table, thermal-expansion, base-drift)"
        );
        if let Some(a) = arg {
            match kind.as_str() {
                "joint-cyclic" => anyhow::ensure!(
                    a.fract() == 0.0 && (1.0..=f64::from(crate::MAX_CYCLIC_ORDER)).contains(&a),
                    "--effect {s}: the order of joint-cyclic must be a whole number from 1 to {}",
                    crate::MAX_CYCLIC_ORDER
                ),
                "joint-table" => anyhow::ensure!(
                    a.is_finite() && (crate::MIN_TABLE_STEP_DEG..=360.0).contains(&a),
                    "--effect {s}: the knot spacing of joint-table must be {} to 360 degrees",
                    crate::MIN_TABLE_STEP_DEG
                ),
                _ => anyhow::bail!("--effect {s}: only joint-cyclic (order) and joint-table (knot spacing) take an ARG"),
            }
        }
        Ok(Self {
            kind,
            joint: joint - 1,
            arg,
        })
    }
}

/// Adds `req` to `robot` with zero values and returns the parameters it makes free.
/// Tables span the joint range the data covers (`q_range_rad`), knots every `arg` degrees.
pub fn add_effect<const N: usize, V: kinecal::ValueStorage>(
    robot: &mut Robot<f64, N, V>,
    req: &EffectRequest,
    q_range_rad: (f64, f64),
) -> anyhow::Result<Vec<Param>> {
    if req.joint >= N {
        crate::refuse!(
            "--effect {}:{}: the robot has {N} joints (number them 1 to {N})",
            req.kind,
            req.joint + 1
        );
    }
    if req.kind == "axis-tilt" {
        return Ok(vec![Param::Beta(req.joint as u8)]);
    }
    let kind = kinecal::EffectKind::from_id(&req.kind)
        .ok_or_else(|| anyhow::anyhow!("unknown effect '{}'", req.kind))?;
    let first = robot.effects().values().len();
    let (order, start, step, len) = match kind {
        kinecal::EffectKind::Cyclic => {
            let n = req.arg.unwrap_or(1.0);
            if !(n.fract() == 0.0 && (1.0..=f64::from(crate::MAX_CYCLIC_ORDER)).contains(&n)) {
                crate::refuse!(
                    "--effect joint-cyclic:{}:{n}: the order must be a whole number from 1 to {}",
                    req.joint + 1,
                    crate::MAX_CYCLIC_ORDER
                );
            }
            (n as u16, 0.0, 0.0, 2)
        }
        kinecal::EffectKind::Table => {
            let step_deg = req.arg.unwrap_or(3.6);
            if !(step_deg.is_finite() && (crate::MIN_TABLE_STEP_DEG..=360.0).contains(&step_deg)) {
                crate::refuse!(
                    "--effect joint-table:{}:{step_deg}: the knot spacing must be {} to 360 degrees",
                    req.joint + 1,
                    crate::MIN_TABLE_STEP_DEG
                );
            }
            let step = step_deg.to_radians();
            let (lo, hi) = q_range_rad;
            if !(lo.is_finite() && hi.is_finite() && hi >= lo) {
                crate::refuse!(
                    "--effect joint-table:{}: the data give no range of joint {}",
                    req.joint + 1,
                    req.joint + 1
                );
            }
            let start = (lo / step).floor() * step;
            // Counted in f64 before any allocation: a tiny step over a wide range must not
            // size a vector (or wrap a usize).
            let knots_f = ((hi - start) / step).ceil() + 1.0;
            let have = robot.effects().values().len();
            let room = crate::MAX_TABLE_KNOTS.min(crate::VCAP.saturating_sub(have));
            if !(knots_f.is_finite() && knots_f <= room as f64) {
                crate::refuse!(
                    "--effect joint-table:{}:{step_deg}: {:.0} knots over the {:.1}° the data cover; \
                     at most {room} fit (a table has at most {} knots): use a wider spacing",
                    req.joint + 1,
                    knots_f,
                    (hi - lo).to_degrees(),
                    crate::MAX_TABLE_KNOTS
                );
            }
            (0, start, step, (knots_f as usize).max(2))
        }
        _ => (0, 0.0, 0.0, 1),
    };
    let zeros = vec![0.0; len];
    robot
        .effects_mut()
        .push(kind, req.joint, N, order, start, step, &zeros)
        .map_err(|e| {
            crate::refused(format!(
                "--effect {}:{}: cannot add it to the model ({e:?}): too many effects",
                req.kind,
                req.joint + 1
            ))
        })?;
    Ok((first..first + len)
        .map(|k| Param::Effect(k as u16))
        .collect())
}
