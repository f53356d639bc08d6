//! A joint whose zero changed at one row: a robot re-mastered, or an encoder that slipped,
//! in the middle of a session. Its residuals step along the rows' order, but not by one
//! vector in either frame ([`super::row_step`] sees those): by the joint's column times the
//! change, different at every pose. A fit takes the mean of the two zeros: 150 UR10 rows, joint
//! 2 re-mastered by 0.5°, 150 more, calibrated to 3.66 mm RMS at 0.02 mm noise with exit 0
//! (host-tests `row_step::a_joint_re_mastered_mid_file_is_named_at_its_row`). An arm still
//! warming up looks alike in part: the real UR10 series A's first 74 rows differ from the rest
//! as joint 2's zero 0.033° off would, not significantly against the scatter below.
//!
//! [`change`] regresses each pose's residual on its joint's column `c` (∂p/∂q, the reading's),
//! a change `δ` from row `k` on, kept apart from a change of the whole file (the model's own
//! zero): with `s_i = c_i·r_i`, `w_i = |c_i|²` and the sums `S, A` over all observations and
//! `S_k, A_k` from `k` on, `δ = (S_k − A_k S/A) / (A_k − A_k²/A)` and the squared error it
//! explains `(S_k − A_k S/A)² / (A_k − A_k²/A)`. The numerator `S_k − A_k S/A = Σ d_i s_i`
//! (`d_i = 1 − A_k/A` from `k` on, `−A_k/A` before) is judged against its variance from the
//! `s_i` themselves, less the zero `μ` and its change `δ` fitted to them (`e_i = s_i − w_i μ`
//! before `k`, `s_i − w_i (μ + δ)` from `k` on): `V = (1 − A_k/A)² Σ_{≥k} e_i² + (A_k/A)²
//! Σ_{<k} e_i²`, from running sums of `s_i², s_i w_i, w_i²` (a sandwich estimate, scaled by
//! `3n / (3n − p − 2)` for the fit's parameters `p`): what the model still misses is structured
//! along the joints' columns
//! (an unmodelled cyclic error of joint 1 moves the tool along joint 1's column), so `s_i`
//! scatters far more than `σ²|c_i|²` with σ from all three coordinates says, and an F test
//! on that σ called a split of random poses a re-mastering (p = 7e-8 on a KR16 of 150 random
//! poses); with the raw `s_i²` the step itself inflated `V`, and 40 rows could name no step at
//! all. `t² = (Σ d_i s_i)² / V` has the degrees of freedom of the fewer side's rows less one
//! (`V` rests on them: ten rows at a file's end that agree by chance were significant against
//! `n − 2`); the best joint and row by its normal equivalent (every row boundary leaving
//! [`super::row_step::MIN_ROWS`] observations each side) is F-tested (1 and those degrees of
//! freedom), Bonferroni-corrected for the joints and rows tried.

use super::row_step::MIN_ROWS;
use super::significance::f_sf;
use kinecal::{ForwardKinematics, Measurement, Robot};

/// The strongest change of one joint's zero along the rows' order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZeroStep {
    /// The joint (0-based).
    pub joint: usize,
    /// The first observation after the change (0-based).
    pub at: usize,
    /// The change (rad, after less before).
    pub change: f64,
    /// RMS (mm) of the change at the tool over the observations after it.
    pub tool_rms_mm: f64,
    /// Probability of a change at least this strong in residuals without one.
    pub p: f64,
}

/// The strongest change of a joint's zero in `robot`'s residuals over `data` in their order
/// (observations on the file's lines `lines`), for a model fitted with `fitted` effective
/// parameters; `None` with fewer than `2·MIN_ROWS` observations or residuals that are not
/// finite.
pub fn change<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    (data, lines): (&[Measurement<f64, N>], &[u32]),
    fitted: f64,
) -> Option<ZeroStep> {
    let n = data.len();
    if n < 2 * MIN_ROWS || lines.len() != n || N == 0 {
        return None;
    }
    // Two passes over the observations, the forward kinematics computed in each: the totals,
    // then every split from the running sums (no per-observation storage: a million poses).
    let mut fk = ForwardKinematics::new();
    let mut each = |m: &Measurement<f64, N>, f: &mut dyn FnMut(usize, f64, f64)| -> Option<f64> {
        let p = fk.compute_at(robot, &m.q, m.tool as usize, m.conditions())?;
        let r = m.point - p;
        if !r.iter().all(|x| x.is_finite()) {
            return None;
        }
        for j in 0..N {
            let c = fk.reading_column(robot, j);
            f(j, c.dot(&r), c.norm_squared());
        }
        Some(r.norm_squared())
    };
    // Per joint the sums of s, w, s², s·w and w² over all observations.
    let add = |sums: &mut [[f64; 5]; N], j: usize, s: f64, w: f64| {
        for (t, v) in sums[j].iter_mut().zip([s, w, s * s, s * w, w * w]) {
            *t += v;
        }
    };
    let mut all = [[0.0f64; 5]; N];
    for m in data {
        each(m, &mut |j, s, w| add(&mut all, j, s, w))?;
    }
    let cut: Vec<bool> = (0..n).map(|k| k == 0 || lines[k] != lines[k - 1]).collect();
    let splits = cut[MIN_ROWS..=n - MIN_ROWS].iter().filter(|c| **c).count();
    let tries = (splits.max(1) * N) as f64;
    let fitted = if fitted.is_finite() {
        fitted.max(0.0)
    } else {
        0.0
    };
    // The residuals come from a fit of `fitted` parameters (and the zero and its change here)
    // to 3n coordinates: their squares understate the scatter by that share.
    let coordinates = 3.0 * n as f64;
    let dof_scale = coordinates / (coordinates - fitted - 2.0).max(1.0);
    let mut best: Option<((f64, f64, f64), ZeroStep)> = None;
    // Sums of the observations before k; those from k on are the totals less them.
    let mut before = [[0.0f64; 5]; N];
    for (k, m) in data.iter().enumerate() {
        if k >= MIN_ROWS && n - k >= MIN_ROWS && cut[k] {
            for j in 0..N {
                let [s, a, q, p, r] = all[j];
                let [s_b, a_b, q_b, p_b, r_b] = before[j];
                let (s_k, a_k, q_k, p_k, r_k) = (s - s_b, a - a_b, q - q_b, p - p_b, r - r_b);
                let den = a_k - a_k * a_k / a;
                if a.is_nan() || a <= 0.0 || den.is_nan() || den <= 0.0 {
                    continue;
                }
                let num = s_k - a_k * s / a;
                // The zero μ of the whole file and its change δ from row k on, and what each
                // side's projections leave of them.
                let change = num / den;
                let zero = (s - change * a_k) / a;
                let after_zero = zero + change;
                let v_after =
                    (q_k - 2.0 * after_zero * p_k + after_zero * after_zero * r_k).max(0.0);
                let v_before = (q_b - 2.0 * zero * p_b + zero * zero * r_b).max(0.0);
                let share = a_k / a;
                let v = ((1.0 - share).powi(2) * v_after + share * share * v_before) * dof_scale;
                if v.is_nan() || v <= 0.0 {
                    continue;
                }
                // The variance rests on the fewer side's rows: t with that many degrees of
                // freedom, ranked by its normal equivalent (a few rows at the file's end
                // agree by chance far more often than F(1, n − 2) says).
                let statistic = num * num / v;
                let dof = (k.min(n - k) as f64 - 1.0).max(1.0);
                let z =
                    statistic.sqrt() * (1.0 - 0.25 / dof) / (1.0 + statistic / (2.0 * dof)).sqrt();
                if best.as_ref().is_none_or(|(e, _)| z > e.0) {
                    best = Some((
                        (z, statistic, dof),
                        ZeroStep {
                            joint: j,
                            at: k,
                            change,
                            tool_rms_mm: change.abs() * (a_k / (n - k) as f64).sqrt(),
                            p: 1.0,
                        },
                    ));
                }
            }
        }
        each(m, &mut |j, s, w| add(&mut before, j, s, w))?;
    }
    let ((_, statistic, dof), mut step) = best?;
    step.p = (f_sf(statistic, 1.0, dof) * tries).min(1.0);
    step.p.is_finite().then_some(step)
}

/// The warning for a change of a joint's zero worth telling
/// ([`super::row_step::worth_telling`]), or `None`; as [`super::row_step::warning`].
pub fn warning<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    (data, lines): (&[Measurement<f64, N>], &[u32]),
    fitted: f64,
    (floor_mm, floor): (f64, &str),
) -> Option<String> {
    let z = change(robot, (data, lines), fitted)?;
    if !super::row_step::worth_telling(z.p, z.tool_rms_mm, floor_mm) {
        return None;
    }
    let sig = |x: f64| crate::output::numfmt::sig(x, 3);
    let (before, after) = (*lines.get(z.at - 1)?, *lines.get(z.at)?);
    let p = super::row_step::p_text(z.p);
    Some(format!(
        "the residuals change between lines {before} and {after} as joint {}'s zero changing \
         by {}° would ({} mm RMS at the tool, beside {floor} of {} mm; {p}), which the model \
         does not explain: the robot was re-mastered, an encoder slipped, or the arm was still \
         warming up before it. Split the file there and calibrate from one part",
        z.joint + 1,
        sig(z.change.to_degrees()),
        sig(z.tool_rms_mm),
        sig(floor_mm),
    ))
}
