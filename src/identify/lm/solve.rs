//! The damped solve of a [`super::Levenberg`] iteration: Marquardt's damping of the
//! normal equations of the estimated parameters (with the ridge and the penalty), solved
//! for the next candidate step.

use super::config::LmConfig;
use super::penalty::PenaltyParts;
use super::status::LmStop;
use super::storage::LmStorage;
use crate::num::linalg::LinalgError;
use crate::Real;

/// What a solve found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Solved {
    /// A candidate step, in the storage's `step` (scaled) and `delta` (parameter units).
    Candidate,
    /// The run would stop here, for this reason (nothing to estimate, a negligible step).
    Stop(LmStop),
    /// The system could not be solved at any damping.
    NoProgress,
}

/// Solves the damped normal equations in `st` (with `pen`'s penalty) for a candidate step at
/// damping `damping` (raised while the system cannot be solved; the value used is left in
/// it). `cost` is the estimate's; `factored`: `st`'s `work` holds the factor of the kept
/// curvature (updated); `predicted` receives the reduction the step promises.
pub(super) fn solve<T: Real, Storage: LmStorage<T>>(
    cfg: &LmConfig<T>,
    cost: T,
    damping: &mut T,
    factored: &mut bool,
    predicted: &mut T,
    st: &mut Storage,
    pen: Option<PenaltyParts<'_, T>>,
) -> Solved {
    let n = st.params().len();
    let mut pen = pen;
    let p = st.parts();
    let s = p.stride;
    // Compact the active parameters into the leading block of `work`.
    let mut m = 0;
    for k in 0..n {
        if p.active[k] {
            p.idx[m] = k;
            m += 1;
        }
    }
    if m == 0 {
        return Solved::Stop(LmStop::Converged);
    }
    let idx = &p.idx[..m];
    let mut mean_diag = T::zero();
    for &k in idx {
        mean_diag += p.jtj[k * s + k];
    }
    mean_diag /= T::of(m as f64);
    let mu = cfg.ridge * mean_diag;
    // With a penalty: `Π u` at the estimate, `Π`'s diagonal (the penalty's scratch), `uᵀΠu`,
    // and the position of every active parameter in the compacted block (`order`).
    let mut pen_cost = T::zero();
    if let Some(q) = &mut pen {
        let (offset, total) = (&*q.offset, &*p.total);
        let u = |k: usize| offset[k] + total[k];
        q.scratch[..n].fill(T::zero());
        q.diagonal[..n].fill(T::zero());
        for (t, w) in q.terms.iter().zip(q.weights.iter()) {
            for i in 0..t.len {
                let k = t.first + i;
                q.scratch[k] += *w * t.product(i, u);
                q.diagonal[k] += *w * t.entry(i, i);
            }
        }
        for k in 0..n {
            pen_cost += u(k) * q.scratch[k];
        }
        for (a, &k) in idx.iter().enumerate() {
            p.order[k] = a;
        }
    }
    // The damping's diagonal: `JᵀJ`'s, plus `Π`'s with a penalty.
    let damping_diag = |k: usize| match &pen {
        Some(q) => p.jtj[k * s + k] + q.diagonal[k],
        None => p.jtj[k * s + k],
    };
    let mut lambda = *damping;
    // With the curvature kept and already factored, a step costs two triangular solves.
    let reused = *factored && {
        for a in 0..m {
            p.g[a] = p.jtr[idx[a]] - mu * p.total[idx[a]];
            if let Some(q) = &pen {
                p.g[a] -= q.scratch[idx[a]];
            }
        }
        p.x[..m].copy_from_slice(&p.g[..m]);
        Storage::resolve_work(p.work, s, p.x, m).is_ok() && p.x[..m].iter().all(|v| v.finite())
    };
    let outcome = if reused {
        Some(())
    } else {
        loop {
            for a in 0..m {
                let ka = idx[a];
                for b in 0..=a {
                    p.work[a * s + b] = p.jtj[ka * s + idx[b]];
                }
                let diag = damping_diag(ka);
                p.work[a * s + a] = diag + lambda * diag.max(mean_diag * T::EPS) + mu;
                p.g[a] = p.jtr[ka] - mu * p.total[ka];
            }
            if let Some(q) = &pen {
                for a in 0..m {
                    p.g[a] -= q.scratch[idx[a]];
                }
                // Off-diagonal penalty entries between active parameters (a band of width 2
                // within each term).
                for (t, w) in q.terms.iter().zip(q.weights.iter()) {
                    for i in 1..t.len {
                        let ki = t.first + i;
                        if !p.active[ki] {
                            continue;
                        }
                        for j in i.saturating_sub(2)..i {
                            let kj = t.first + j;
                            if p.active[kj] {
                                p.work[p.order[ki] * s + p.order[kj]] += *w * t.entry(i, j);
                            }
                        }
                    }
                }
            }
            p.x[..m].copy_from_slice(&p.g[..m]);
            match Storage::solve_work(p.work, s, p.x, m) {
                Ok(()) if p.x[..m].iter().all(|v| v.finite()) => break Some(()),
                Ok(()) | Err(LinalgError::NotPositiveDefinite) | Err(LinalgError::Size) => {
                    // Not solvable at this damping: damp harder and retry, up to a limit.
                    lambda *= T::of(10.0);
                    if !(lambda < T::of(1e16)) {
                        break None;
                    }
                }
            }
        }
    };
    *factored = cfg.keep_curvature && outcome.is_some();
    *damping = lambda;
    if outcome.is_none() {
        return Solved::NoProgress;
    }
    // Predicted reduction of the (ridged, penalised) cost: xᵀ(2g − A x) = xᵀ(g + λ D x).
    let mut pred = T::zero();
    for a in 0..m {
        let diag = damping_diag(idx[a]);
        pred += p.x[a] * (p.g[a] + (lambda * diag.max(mean_diag * T::EPS)) * p.x[a]);
    }
    *predicted = pred;
    p.step[..n].fill(T::zero());
    let mut norm2 = T::zero();
    for a in 0..m {
        p.step[idx[a]] = p.x[a];
        norm2 += p.x[a] * p.x[a];
    }
    if norm2.sqrt() < cfg.step_tolerance {
        return Solved::Stop(LmStop::SmallStep);
    }
    // Lightly damped (λ ≤ 1: at least about half the Gauss–Newton reduction), a step that
    // promises less than the cost tolerance is not worth a pass over the data: converged.
    // (Without this a run spends its last passes on steps that change the 13th digit.)
    if lambda <= T::one() && pred <= cfg.cost_tolerance * (cost + pen_cost) {
        return Solved::Stop(LmStop::Converged);
    }
    // Unscale into parameter units.
    for k in 0..n {
        p.delta[k] = p.step[k] / p.scale[k];
    }
    Solved::Candidate
}
