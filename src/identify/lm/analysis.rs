//! Identifiability analysis of a [`super::Levenberg`] run: which parameters the data (and the
//! penalty) determine at the current model, and when that decision is due again (the module
//! documentation of [`super`] gives the rules).

use super::config::LmConfig;
use super::penalty::PenaltyPartsRef;
use super::storage::LmStorage;
use crate::num::linalg::{pivoted_cholesky_preferring, Flat};
use crate::Real;

/// The penalty's `Π` entry `(i, j)` (solver positions, weights applied).
fn penalty_entry<T: Real>(q: &PenaltyPartsRef<'_, T>, i: usize, j: usize) -> T {
    let mut v = T::zero();
    for (t, w) in q.terms.iter().zip(q.weights) {
        if i >= t.first && j >= t.first {
            let (a, b) = (i - t.first, j - t.first);
            if a < t.len && b < t.len {
                v += *w * t.entry(a, b);
            }
        }
    }
    v
}

/// True when a held parameter's column has grown well beyond its size at the last analysis
/// (the model moved to where the data may see it), and another analysis is allowed (`analyses`
/// made so far).
pub(super) fn held_column_grew<T: Real, Storage: LmStorage<T>>(
    cfg: &LmConfig<T>,
    analyses: u8,
    st: &Storage,
) -> bool {
    // One analysis stays in reserve for the confirmation at the end.
    if analyses.saturating_add(1) >= cfg.max_analyses {
        return false;
    }
    let n = st.params().len();
    let p = st.parts_ref();
    let diag = |k: usize| p.jtj[k * p.stride + k];
    let dmax = (0..n).fold(T::zero(), |a, k| a.max(diag(k)));
    (0..n).any(|k| {
        let d = diag(k);
        !p.active[k]
            && !p.held[k]
            && d > dmax * cfg.rank_tolerance * cfg.rank_tolerance
            && d > T::of(4.0) * p.analysed_diag[k]
    })
}

/// No analysis (`max_analyses = 0`): every parameter the caller does not hold is estimated.
pub(super) fn estimate_all<T: Real, Storage: LmStorage<T>>(st: &mut Storage) {
    let p = st.parts();
    let n = p.params.len();
    for k in 0..n {
        p.active[k] = !p.held[k];
        p.analysed_diag[k] = p.jtj[k * p.stride + k];
    }
}

/// Decides which parameters the data determine at the current model (normal matrix of the
/// last pass, penalised by `pen`), preferring those estimated so far unless this is the run's
/// `first` analysis; true when the set changed.
pub(super) fn analyse<T: Real, Storage: LmStorage<T>>(
    cfg: &LmConfig<T>,
    first: bool,
    st: &mut Storage,
    pen: Option<PenaltyPartsRef<'_, T>>,
) -> bool {
    let n = st.params().len();
    let p = st.parts();
    let s = p.stride;
    // The diagonal goes to analysed_diag (kept for the growth test).
    for i in 0..n {
        p.analysed_diag[i] = p.jtj[i * s + i];
    }
    // With a penalty, the penalised normal matrix decides (a direction the penalty
    // determines is determined); its diagonal goes to `delta` (scratch).
    let d: &[T] = match &pen {
        Some(q) => {
            for i in 0..n {
                p.delta[i] = p.jtj[i * s + i] + penalty_entry(q, i, i);
            }
            p.delta
        }
        None => p.analysed_diag,
    };
    let dmax = d[..n].iter().fold(T::zero(), |a, b| a.max(*b));
    for i in 0..n {
        for j in 0..=i {
            let mut h = p.jtj[i * s + j];
            if let Some(q) = &pen {
                if i.abs_diff(j) <= 2 {
                    h += penalty_entry(q, i, j);
                }
            }
            let v = if d[i] > T::zero() && d[j] > T::zero() {
                h / (d[i] * d[j]).sqrt()
            } else {
                T::zero()
            };
            p.work[i * s + j] = v;
            p.work[j * s + i] = v;
        }
    }
    p.before[..n].copy_from_slice(&p.active[..n]);
    // The first analysis has no estimate to prefer.
    let preferred: &[bool] = if first { &[] } else { &p.before[..n] };
    let rank = Flat::new(p.work, s)
        .and_then(|mut w| {
            pivoted_cholesky_preferring(
                &mut w,
                n,
                p.order,
                cfg.rank_tolerance,
                preferred,
                if first {
                    cfg.rank_tolerance
                } else {
                    cfg.activation_tolerance
                },
            )
        })
        .unwrap_or(0);
    p.active[..n].fill(false);
    for &k in p.order[..rank].iter() {
        // A column with no information at all (relative to the strongest) is dropped too,
        // and the caller's held ones stay held.
        if d[k] > dmax * T::EPS && !p.held[k] {
            p.active[k] = true;
        }
    }
    p.before[..n] != p.active[..n]
}
