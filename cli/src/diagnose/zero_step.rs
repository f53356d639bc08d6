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
//! `s_i` themselves, `V = (1 − A_k/A)² Q_k + (A_k/A)² (Q − Q_k)` with `Q` the sums of `s_i²`
//! (a sandwich estimate): what the model still misses is structured along the joints' columns
//! (an unmodelled cyclic error of joint 1 moves the tool along joint 1's column), so `s_i`
//! scatters far more than `σ²|c_i|²` with σ from all three coordinates says, and an F test
//! on that σ called a split of random poses a re-mastering (p = 7e-8 on a KR16 of 150 random
//! poses). The best joint and row by `(Σ d_i s_i)² / V` (every row boundary leaving
//! [`super::row_step::MIN_ROWS`] observations each side) is F-tested (1 and `n − 1 −` the
//! model's effective parameters degrees of freedom), Bonferroni-corrected for the joints and
//! rows tried.

use super::row_step::{MIN_ROWS, STEP_SHARE};
use super::significance::f_sf;
use super::time_trend::TREND_P;
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
    let (mut s_all, mut a_all, mut q_all) = ([0.0f64; N], [0.0f64; N], [0.0f64; N]);
    for m in data {
        each(m, &mut |j, s, w| {
            s_all[j] += s;
            a_all[j] += w;
            q_all[j] += s * s;
        })?;
    }
    let cut: Vec<bool> = (0..n).map(|k| k == 0 || lines[k] != lines[k - 1]).collect();
    let splits = cut[MIN_ROWS..=n - MIN_ROWS].iter().filter(|c| **c).count();
    let tries = (splits.max(1) * N) as f64;
    let mut best: Option<(f64, ZeroStep)> = None;
    // Sums of the observations before k; those from k on are the totals less them.
    let (mut s_before, mut a_before, mut q_before) = ([0.0f64; N], [0.0f64; N], [0.0f64; N]);
    for (k, m) in data.iter().enumerate() {
        if k >= MIN_ROWS && n - k >= MIN_ROWS && cut[k] {
            for j in 0..N {
                let (s_k, a_k) = (s_all[j] - s_before[j], a_all[j] - a_before[j]);
                let den = a_k - a_k * a_k / a_all[j];
                if a_all[j].is_nan() || a_all[j] <= 0.0 || den.is_nan() || den <= 0.0 {
                    continue;
                }
                let num = s_k - a_k * s_all[j] / a_all[j];
                let share = a_k / a_all[j];
                let v =
                    (1.0 - share).powi(2) * (q_all[j] - q_before[j]) + share * share * q_before[j];
                if v.is_nan() || v <= 0.0 {
                    continue;
                }
                let statistic = num * num / v;
                if best.as_ref().is_none_or(|(e, _)| statistic > *e) {
                    let change = num / den;
                    best = Some((
                        statistic,
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
        each(m, &mut |j, s, w| {
            s_before[j] += s;
            a_before[j] += w;
            q_before[j] += s * s;
        })?;
    }
    let (statistic, mut step) = best?;
    let fitted = if fitted.is_finite() {
        fitted.max(0.0)
    } else {
        0.0
    };
    let df2 = (n as f64 - 1.0 - fitted).max(1.0);
    step.p = (f_sf(statistic, 1.0, df2) * tries).min(1.0);
    step.p.is_finite().then_some(step)
}

/// The warning for a significant change of a joint's zero ([`TREND_P`]) whose size at the
/// tool is at least [`STEP_SHARE`] of `floor_mm` (any size when the floor is not a finite
/// number), or `None`; as [`super::row_step::warning`].
pub fn warning<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    (data, lines): (&[Measurement<f64, N>], &[u32]),
    fitted: f64,
    (floor_mm, floor): (f64, &str),
) -> Option<String> {
    let z = change(robot, (data, lines), fitted)?;
    let large = !floor_mm.is_finite() || z.tool_rms_mm >= STEP_SHARE * floor_mm;
    if !(z.p < TREND_P && large) {
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
