//! Observability indices and design criteria: single numbers that say how well a set of
//! measurement poses determines the parameters (the indices) or predicts the tool point (KPI).
//!
//! With `σ_1 ≥ … ≥ σ_m > 0` the singular values of the scaled identification Jacobian `J` on
//! the identifiable subspace (`m` = its dimension) and `n` the number of poses:
//!
//! | index | who | formula | better |
//! |---|---|---|---|
//! | O1 | Borm & Menq 1991 | `(σ_1⋯σ_m)^(1/m) / √n` | larger |
//! | O2 | Driels & Pathre 1990 | `σ_1 / σ_m` (condition number) | smaller |
//! | O3 | Nahvi et al. 1994 | `σ_m` | larger |
//! | O4 | Nahvi & Hollerbach 1996 (noise amplification) | `σ_m² / σ_1` | larger |
//! | O5 | Sun & Hollerbach 2008 | `1 / Σ 1/σ_i` | larger |
//!
//! O1 is a monotone function of `det JᵀJ` for a fixed number of poses, so maximising it
//! selects the same design as D-optimality. The classical criteria are functions of the
//! covariance `C = σ²(JᵀJ)⁺`: A = trace C, D = (det C)^(1/m), E = λ_max(C); the KPI-A criterion
//! is `trace Σ_s C_s`, the summed variance of the tool point at the working configurations
//! (Jost et al. 2017).

// `!(x > y)` is deliberate: it is also true for NaN. Index loops mirror the formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::planning::information::{Covariance, PoseRows};
use crate::Real;

/// The five observability indices of a design.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Indices<T: Real> {
    /// Borm & Menq: `(σ_1⋯σ_m)^(1/m) / √n`; larger is better.
    pub o1: T,
    /// Driels & Pathre: the condition number `σ_1 / σ_m`; smaller is better.
    pub o2: T,
    /// Nahvi et al.: the smallest singular value `σ_m`; larger is better.
    pub o3: T,
    /// Nahvi & Hollerbach (noise amplification): `σ_m² / σ_1`; larger is better.
    pub o4: T,
    /// Sun & Hollerbach: `1 / Σ 1/σ_i`; larger is better.
    pub o5: T,
}

/// Classical and KPI criteria of a design (all in mm² of scaled parameters, smaller is better).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Criteria<T: Real> {
    /// Trace of the parameter covariance.
    pub a: T,
    /// Geometric mean of the covariance eigenvalues, `(det C)^(1/m)`.
    pub d: T,
    /// Largest covariance eigenvalue.
    pub e: T,
    /// Trace of the summed tool-point covariance at the working configurations.
    pub kpi: T,
}

/// Observability indices of the design behind `cov` (`poses` = number of measured poses).
/// All zero when nothing is identifiable.
pub fn indices<T: Real, const P: usize>(cov: &Covariance<T, P>, poses: usize) -> Indices<T> {
    let ev = cov.identifiable_eigenvalues();
    let m = ev.len();
    if m == 0 || poses == 0 {
        let z = T::zero();
        return Indices {
            o1: z,
            o2: T::max_value().unwrap_or(T::one()),
            o3: z,
            o4: z,
            o5: z,
        };
    }
    // Ascending eigenvalues of JᵀJ: σ_min² first.
    let smin = ev[0].max(T::zero()).sqrt();
    let smax = ev[m - 1].max(T::zero()).sqrt();
    let mut log_sum = T::zero();
    let mut inv_sum = T::zero();
    for l in ev {
        let s = l.max(T::zero()).sqrt();
        log_sum += s.ln();
        inv_sum += T::one() / s;
    }
    Indices {
        o1: (log_sum / T::of(m as f64)).exp() / T::of(poses as f64).sqrt(),
        o2: smax / smin,
        o3: smin,
        o4: smin * smin / smax,
        o5: T::one() / inv_sum,
    }
}

/// The A, D, E and KPI-A criteria; `work` holds the scaled Jacobian of the tool point at each
/// working configuration.
pub fn criteria<T: Real, const P: usize>(
    cov: &Covariance<T, P>,
    work: &[PoseRows<T, P>],
) -> Criteria<T> {
    let ev = cov.identifiable_eigenvalues();
    let s2 = cov.sigma2();
    let mut a = T::zero();
    let mut log_det = T::zero();
    for l in ev {
        a += s2 / *l;
        log_det += (s2 / *l).ln();
    }
    let m = ev.len();
    let d = if m > 0 {
        (log_det / T::of(m as f64)).exp()
    } else {
        T::zero()
    };
    let e = if m > 0 { s2 / ev[0] } else { T::zero() };
    let mut kpi = T::zero();
    for js in work {
        kpi += cov.tool_variance(js);
    }
    Criteria { a, d, e, kpi }
}
