//! Is a candidate's held-out improvement real? And how large is the measurement noise?
//!
//! **The test.** Every pose is held out exactly once in the k-fold cross-validation, so the
//! current model and the candidate model each leave one held-out squared error per pose.
//! The differences `d_i = e_current,i − e_candidate,i` are tested with a one-sided paired
//! Student t test (H0: `E[d] ≤ 0`, the candidate does not predict unseen poses better).
//!
//! Why it holds the false-alarm rate: given the fold fits, `d_i ≈ 2 r_i·Δ_i − |Δ_i|²`, where
//! `r_i` is the held-out residual (its noise is independent of the fit that excluded it) and
//! `Δ_i` the change the candidate makes to the prediction. With nothing missing the first term
//! has mean zero and independent pose-to-pose noise, which the sample variance estimates, and
//! the second term is ≤ 0: the test is exact to conservative, and the t approximation is good
//! for the ~100 poses of a calibration. The candidate tested is the best of the `m` screened in
//! that round (selected on the same data), so its p-value is compared with `α / m`
//! (Bonferroni; for the one hypothesis that is then tested, Holm's step-down is the same): the
//! chance that *any* of the `m` candidates passes on data with nothing missing is at most `α`.
//! A false alarm on such data needs the first round to pass, so the whole search names
//! something with probability at most `α` (5 %).
//!
//! **The noise floor.** From repeated poses when the data have them (identical joint readings:
//! the pooled within-group scatter has nothing to do with the model), otherwise from the final
//! model's cross-validated held-out errors, corrected for what the fold fits add to them
//! ([`held_out_noise`]): `σ² = Σ|r_i|² / (3n + Σ_f tr B_f)`. Reported in the sense of a held-out
//! RMS of 3-D errors: `√3 σ`, with an approximate 95 % interval ([`noise_floor_interval`]).
//!
//! Why not the held-out RMS itself, nor the fit's residual: a held-out error is the pose's own
//! noise plus the error of a fit made without it, so the held-out RMS overstates the noise, by a
//! lot when each fold fit has few poses for many parameters (24 poses, 5 folds: 1.2–1.5×).
//! The in-sample `SSR / (3n − p_eff)` is unbiased for a correct linear model, but it is a
//! different sample of the noise than the held-out errors it is compared with and, with few
//! poses and real (not quite white) errors, it can land above them — a "floor" the model
//! already beats on unseen poses. Dividing the held-out sum of squares by its own expectation
//! per unit σ² removes the fold fits' share exactly (for the linearised model) and, since
//! `tr B_f ≥ 0`, can never exceed the held-out RMS it is computed from.

use kinecal::Measurement;

/// Outcome of the paired one-sided test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairedTest {
    pub n: usize,
    /// Mean improvement of the squared held-out error (mm²).
    pub mean: f64,
    /// Its standard error.
    pub standard_error: f64,
    pub t: f64,
    /// One-sided p-value: the chance of so large an improvement if the candidate does not help.
    pub p: f64,
}

/// One-sided paired t test of `before − after` (per-pose squared held-out errors).
pub fn paired_improvement(before: &[f64], after: &[f64]) -> PairedTest {
    let n = before.len().min(after.len());
    if n < 2 {
        return PairedTest {
            n,
            mean: 0.0,
            standard_error: 0.0,
            t: 0.0,
            p: 1.0,
        };
    }
    let d: Vec<f64> = before.iter().zip(after).map(|(b, a)| b - a).collect();
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
    let se = (var / n as f64).sqrt();
    let (t, p) = if se > 0.0 {
        let t = mean / se;
        (t, student_t_sf(t, (n - 1) as f64))
    } else if mean > 0.0 {
        (f64::INFINITY, 0.0)
    } else {
        (0.0, 1.0)
    };
    PairedTest {
        n,
        mean,
        standard_error: se,
        t,
        p,
    }
}

/// `P(T > t)` for Student's t with `nu` degrees of freedom.
pub fn student_t_sf(t: f64, nu: f64) -> f64 {
    if t.is_nan() || nu.is_nan() || nu <= 0.0 {
        return f64::NAN;
    }
    if t.is_infinite() {
        return if t > 0.0 { 0.0 } else { 1.0 };
    }
    let x = nu / (nu + t * t);
    let tail = 0.5 * incomplete_beta(0.5 * nu, 0.5, x);
    if t > 0.0 {
        tail
    } else {
        1.0 - tail
    }
}

/// `P(F > f)` for Fisher's F with `d1` and `d2` degrees of freedom: `I_x(d2/2, d1/2)` at
/// `x = d2 / (d2 + d1·f)`.
pub fn f_sf(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() || !(d1 > 0.0 && d2 > 0.0) {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    incomplete_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f))
}

/// The regularised incomplete beta function `I_x(a, b)` (continued fraction, Lentz).
pub fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_fraction(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * beta_fraction(b, a, 1.0 - x) / b
    }
}

fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=500 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, 9 terms: ~1e-15 relative).
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Per-coordinate noise σ (mm) from repeated poses: groups of identical joint readings, pooled
/// within-group scatter. `None` unless at least 3 groups with repeats (and 6 degrees of
/// freedom) exist. Returns `(σ, degrees of freedom)`.
/// Repeats are of one point (several reflectors of one pose are not repeats); the points'
/// scatter is weighted as their residuals are. Without an estimate for orientations, `None`
/// for 6-D data (the floor then comes from the held-out errors).
pub fn repeat_noise<const N: usize>(data: &[Measurement<f64, N>]) -> Option<(f64, usize)> {
    if data.iter().any(|m| m.orientation.is_some()) {
        return None;
    }
    let mut groups: std::collections::HashMap<([u64; N], u8), Vec<usize>> =
        std::collections::HashMap::new();
    for (i, m) in data.iter().enumerate() {
        groups
            .entry((m.q.map(f64::to_bits), m.tool))
            .or_default()
            .push(i);
    }
    let mut ss = 0.0;
    let mut dof = 0usize;
    let mut repeated = 0usize;
    for idx in groups.values().filter(|g| g.len() > 1) {
        repeated += 1;
        let mean = idx
            .iter()
            .map(|&i| data[i].point)
            .sum::<nalgebra::Vector3<f64>>()
            / idx.len() as f64;
        ss += idx
            .iter()
            .map(|&i| {
                let m = &data[i];
                (m.point - mean).component_mul(&m.weight).norm_squared()
            })
            .sum::<f64>();
        dof += 3 * (idx.len() - 1);
    }
    (repeated >= 3 && dof >= 6).then(|| ((ss / dof as f64).sqrt(), dof))
}

/// Per-coordinate noise σ (mm) from cross-validated held-out squared errors (mm², summed over
/// the poses: `sum_squared`) and what the fold fits add to them
/// ([`crate::diagnose::cross_validation::FoldInflation`]): `σ² = Σ|r_i|² / (3n + Σ tr B_f)`, unbiased for
/// the linearised model, and never above the held-out mean squared error per coordinate.
/// Returns `(σ, ν)`, `ν` the Satterthwaite degrees of freedom of the estimate,
/// `(3n + T)² / (3n + 2T + T₂)` (`T = Σ tr B_f`, `T₂ = Σ tr B_f²`; the covariances between folds
/// are left out, which makes `ν` slightly optimistic: the caller may cap it).
pub fn held_out_noise(
    sum_squared: f64,
    inflation: &crate::diagnose::cross_validation::FoldInflation,
) -> (f64, f64) {
    let c = inflation.coordinates as f64;
    let t = if inflation.trace.is_finite() {
        inflation.trace.max(0.0)
    } else {
        0.0
    };
    let t2 = if inflation.trace_squared.is_finite() {
        inflation.trace_squared.max(0.0)
    } else {
        0.0
    };
    if c == 0.0 || !sum_squared.is_finite() {
        return (f64::NAN, 0.0);
    }
    let sigma = (sum_squared.max(0.0) / (c + t)).sqrt();
    let dof = (c + t) * (c + t) / (c + 2.0 * t + t2);
    (sigma, dof)
}

/// The `prob` quantile of the chi-square distribution with `nu` degrees of freedom
/// (Wilson–Hilferty: within ~1 % for `ν ≥ 5`, a few % below).
pub fn chi_square_quantile(prob: f64, nu: f64) -> f64 {
    let z = normal_quantile(prob);
    let a = 2.0 / (9.0 * nu);
    (nu * (1.0 - a + z * a.sqrt()).powi(3)).max(0.0)
}

/// The standard normal quantile (Acklam's rational approximation, ~1e-9 relative).
pub fn normal_quantile(prob: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    if prob.is_nan() || prob <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if prob >= 1.0 {
        return f64::INFINITY;
    }
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if prob < 0.02425 {
        tail((-2.0 * prob.ln()).sqrt())
    } else if prob > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - prob).ln()).sqrt())
    } else {
        let q = prob - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Approximate 95 % interval of a noise floor estimated with `nu` degrees of freedom
/// (`ν σ̂² / σ² ~ χ²_ν`); `[NaN, NaN]` when it cannot be given.
pub fn noise_floor_interval(floor_mm: f64, nu: f64) -> [f64; 2] {
    if !(floor_mm.is_finite() && nu.is_finite() && nu >= 1.0) {
        return [f64::NAN, f64::NAN];
    }
    let hi_q = chi_square_quantile(0.975, nu);
    let lo_q = chi_square_quantile(0.025, nu);
    let lo = floor_mm * (nu / hi_q).sqrt();
    let hi = if lo_q > 0.0 {
        floor_mm * (nu / lo_q).sqrt()
    } else {
        f64::INFINITY
    };
    [lo, hi]
}
