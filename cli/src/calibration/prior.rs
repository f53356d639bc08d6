//! The prior of `identify`: a Gaussian on every parameter's change from its file value, with a
//! 1-σ per kind of parameter (a real robot's manufacturing tolerances by default; `[prior]` in
//! the robot file, `--prior` on the command line; docs/formats.md "The prior").
//!
//! A fit first runs without it, exactly as before: that run decides what the data cannot
//! determine at all (held, as before) and gives the residual variance `s²` per row. The
//! estimated parameters are then refitted from there minimising
//!
//! `Σ r² + s² · Σ_k (Δ_k / σ_k)²`,
//!
//! the maximum a-posteriori estimate with the data's noise `s²`: a parameter the data determine
//! well (1-σ from the data far below `σ_k`) stays where the data put it, a direction they barely
//! determine stays near its file value instead of running to the centimetres. Parameters whose
//! start is not a file value (an unknown base placed by registration, an unknown tool
//! orientation, effect values added at zero) have no prior unless their kind is given one.
//!
//! Per parameter the fit reports how much of its estimate the data determined: the diagonal of
//! the resolution matrix `(JᵀJ + Π)⁻¹ JᵀJ`, which is `1 − posterior variance / prior variance`
//! (1: the data alone, 0: the prior alone; a parameter the data see only together with others
//! that the prior holds gets a share between).

use super::{Fit, Param};
use crate::compute::vec_lm::{VecLm, VecPenalty};
pub use crate::formats::prior::PriorSpec;
use kinecal::identify::lm::{Levenberg, LmConfig, PenaltyTerm};
use kinecal::{Measurement, Robot};
use serde::Serialize;
use std::collections::BTreeMap;

/// What the prior did to one estimated parameter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Share {
    /// The prior's 1-σ (file units: mm, degrees, raw).
    pub prior_sigma: f64,
    /// 1-σ from the data alone (file units), when the data determine it at all.
    pub data_sigma: Option<f64>,
    /// How much of the estimate the data determined (0 … 1; the rest is the prior's).
    pub data_share: f64,
}

/// Each parameter's prior 1-σ (library units) under `spec`, `None` where its kind has none or
/// `free_start` says its start is not a file value (a base placed by registration, a tool
/// orientation started from the data, effect values added at zero).
pub fn sigmas(
    spec: &PriorSpec,
    params: &[Param],
    free_start: impl Fn(Param) -> bool,
) -> Vec<Option<f64>> {
    params
        .iter()
        .map(|&p| spec.sigma(p, free_start(p)))
        .collect()
}

/// `identify`'s LM fit: [`super::fit_lm`] from `start`, then [`refit`] with the prior `sigma`.
pub fn fit_lm_with_prior<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    params: &[Param],
    sigma: &[Option<f64>],
    data: &[Measurement<f64, N>],
) -> anyhow::Result<Fit<N, V>> {
    let (fit, solver) = super::fit_lm_with_solver(start, params, data, LmConfig::default())?;
    refit_after(start, params, sigma, data, fit, Some(&solver))
}

/// File units of a value in the library's units.
fn file_units(p: Param, v: f64) -> f64 {
    match p {
        Param::Effect(_) => v,
        p if p.is_length() => v,
        _ => v.to_degrees(),
    }
}

/// Refits `fit` (the unpenalised fit of `params` from `start` on `data`) with the prior
/// `sigma` (per parameter of `params`, library units; `None`: none) pulling each parameter
/// towards its value in `start`: the fit with its 1-σ the posterior's and, per parameter with
/// a prior, its [`Share`] (`Fit::prior`). Returns `fit` unchanged when no estimated parameter
/// has a prior or the data leave no degree of freedom to estimate the noise from.
///
/// What the first fit held stays held (the base's rotation about z against theta1, a tool
/// offset along the last axis against d6), and the parameters that stand in for it take its
/// tolerance into theirs (a stand-in for something without a prior gets none).
pub fn refit<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    params: &[Param],
    sigma: &[Option<f64>],
    data: &[Measurement<f64, N>],
    fit: Fit<N, V>,
) -> anyhow::Result<Fit<N, V>> {
    refit_after(start, params, sigma, data, fit, None)
}

/// [`refit`] in the column scales of `solver`, the solver `fit` came from
/// ([`super::fit_lm_with_solver`]), and its first pass taken from it when that gives the same
/// numbers (one pass over the data fewer: [`Levenberg::complete_first_pass_from`]); a solver
/// whose passes cut the data differently: a pass of its own. `None`: [`refit`].
pub fn refit_after<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    params: &[Param],
    sigma: &[Option<f64>],
    data: &[Measurement<f64, N>],
    fit: Fit<N, V>,
    solver: Option<&super::FitSolver<N, V>>,
) -> anyhow::Result<Fit<N, V>> {
    let s2 = match fit.chi2_per_dof {
        Some(s2) if s2.is_finite() && s2 > 0.0 => s2,
        _ => return Ok(fit),
    };
    let reach = start.reach();
    let name = |p: &Param| p.name(start).to_string();
    // Prior variance of each parameter's scaled change (mm²), `None`: no prior.
    let var = |p: &Param, s: Option<f64>| s.map(|s| (s * p.scale(reach)).powi(2));
    let held = |p: &Param| fit.held.iter().find(|h| h.name == name(p));
    let mut active: Vec<(Param, Option<f64>)> = params
        .iter()
        .zip(sigma)
        .filter(|(p, _)| held(p).is_none())
        .map(|(p, s)| (*p, var(p, *s)))
        .collect();
    for h in &fit.held {
        let Some(k) = params.iter().position(|p| name(p) == h.name) else {
            continue;
        };
        let held_var = var(&params[k], sigma[k]);
        for (who, coef) in &h.stand_ins {
            if coef.abs() < 1e-3 {
                continue;
            }
            if let Some(a) = active.iter_mut().find(|(p, _)| name(p) == *who) {
                a.1 = match (a.1, held_var) {
                    (Some(v), Some(h)) => Some(v + coef * coef * h),
                    _ => None,
                };
            }
        }
    }
    if active.iter().all(|(_, v)| v.is_none()) {
        return Ok(fit);
    }
    let prior: Vec<Option<f64>> = active.iter().map(|(_, v)| *v).collect();
    let active: Vec<Param> = active.into_iter().map(|(p, _)| p).collect();
    let terms: Vec<PenaltyTerm<f64>> = prior
        .iter()
        .enumerate()
        .map(|(k, v)| PenaltyTerm {
            first: k,
            len: 1,
            ridge: v.map_or(0.0, |v| s2 / v),
            smoothness: 0.0,
            relative: false,
        })
        .collect();
    let mut penalty = VecPenalty::new(active.len(), terms);
    for (k, p) in active.iter().enumerate() {
        penalty.prior_mut()[k] = kinecal::model::param::value(start, *p).unwrap_or(0.0);
    }
    let cfg = LmConfig {
        max_analyses: 0,
        ..LmConfig::default()
    };
    let mut lm = Box::new(
        Levenberg::with_penalty(fit.robot.clone(), VecLm::new(&active), penalty, cfg)
            .map_err(|e| anyhow::anyhow!("identification with the prior: {e:?}"))?,
    );
    // The first fit's final normal equations are this run's first pass when both summed the
    // poses in the same parts (a refused copy leaves the run to its own pass).
    // Scaled as the first fit was (the same refit, preconditioned alike), so that the copy is
    // the pass's own numbers.
    if let Some(first) = solver {
        if lm.adopt_scales_of(first).is_ok()
            && crate::compute::parallel::same_parts(first.params().len(), active.len(), data.len())
        {
            let _ = lm.complete_first_pass_from(first);
        }
    }
    let p = crate::compute::parallel::run_lm(&mut lm, data, |_, _| {})
        .map_err(|e| anyhow::anyhow!("identification with the prior: {e:?}"))?;
    // Posterior covariance s²(A + Π)⁻¹ and resolution (A + Π)⁻¹A in scaled units.
    let m = active.len();
    let pen_diag = |k: usize| {
        lm.penalty_parts()
            .map_or(0.0, |q| q.weights[k] * q.terms[k].ridge)
    };
    let a = nalgebra::DMatrix::from_fn(m, m, |i, j| lm.normal_matrix(i, j));
    let ap = nalgebra::DMatrix::from_fn(m, m, |i, j| {
        a[(i, j)] + if i == j { pen_diag(i) } else { 0.0 }
    });
    let mut out = fit;
    let mut shares = BTreeMap::new();
    if let Some(ch) = ap.cholesky() {
        let inv = ch.inverse();
        let res = &inv * &a;
        let mut sigma_post = BTreeMap::new();
        for (k, q) in active.iter().enumerate() {
            let name = q.name(lm.robot()).to_string();
            let sd = file_units(*q, (s2 * inv[(k, k)]).max(0.0).sqrt() / lm.scale(k));
            sigma_post.insert(name.clone(), sd);
            if let Some(v) = prior[k] {
                shares.insert(
                    name.clone(),
                    Share {
                        prior_sigma: file_units(*q, v.sqrt() / q.scale(reach)),
                        data_sigma: out.sigma.get(&name).copied(),
                        data_share: res[(k, k)].clamp(0.0, 1.0),
                    },
                );
            }
        }
        out.sigma = sigma_post;
    }
    out.robot = lm.robot().clone();
    out.iterations += p.iteration;
    out.evaluations += p.evaluations as u64;
    if matches!(
        p.stopped,
        Some(
            kinecal::identify::lm::LmStop::MaxIterations
                | kinecal::identify::lm::LmStop::NoProgress
        )
    ) {
        out.stop = p.stopped;
    }
    // The data's cost per degree of freedom at the final model (the run's cost leaves the
    // penalty out).
    let dof = super::residual_rows(data).saturating_sub(m);
    if dof > 0 {
        out.chi2_per_dof = Some(p.cost / dof as f64);
    }
    out.prior = shares;
    Ok(out)
}
