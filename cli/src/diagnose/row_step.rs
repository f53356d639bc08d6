//! A step in the residuals along the rows' order: a reflector re-seated or knocked mid-session
//! (the step is fixed in the flange frame), or a tracker or base bumped (fixed in the
//! measurement frame). A fit takes the mean of the two parts, and the search takes what is left
//! for noise: 300 rows with the reflector moved 1.1 mm after row 150 calibrated with exit 0, and
//! `diagnose` reported a "noise floor" of 0.56 mm (25 times the tracker's noise) and nothing
//! missing.
//!
//! [`step`] splits the point residuals at every observation that leaves at least [`MIN_PART`]
//! of them on each side, in both frames, and keeps the split whose two means differ most (the
//! between-parts sum of squares `k(n−k)/n·|r̄₁ − r̄₂|²`). Its F test (3 and 3n − 9 − the model's
//! effective parameters degrees of freedom) is multiplied by the number of splits tried
//! (Bonferroni) and by 2 frames. A linear drift also splits best somewhere (the best split of
//! a ramp holds 3/4 of it): a step is reported only where it explains more than the linear trend
//! of the same frame ([`super::time_trend`] warns about a trend).

use super::significance::f_sf;
use super::time_trend::TREND_P;
use crate::calibration::pose_error_vectors;
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::Vector3;

/// The least share of the observations each side of a split holds (and at least 10).
pub const MIN_PART: f64 = 0.05;

/// A step smaller than this share of the noise floor (RMS over the observations) is not
/// warned about. A step adds to the floor (`floor² ≈ noise² + step²`): at half of it the step
/// is over half the noise, as a moved reflector's or a bumped tracker's is. The real UR10 series
/// C has a significant step smaller than that, near where its rows' temperature starts to
/// climb.
pub const STEP_SHARE: f64 = 0.5;

/// The frame a step is fixed in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StepFrame {
    /// The flange's axes: the measured point moved on the arm (the reflector).
    Flange,
    /// The measurement frame: the tracker or the robot's base moved.
    Measurement,
}

/// The strongest step of the residuals along the rows' order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowStep {
    /// The first observation after the step (0-based).
    pub at: usize,
    pub frame: StepFrame,
    /// Mean residual after the step less before it, in the frame's axes (mm).
    pub step_mm: Vector3<f64>,
    /// RMS of the step over the observations (mm): what removing it would take from the
    /// residuals' mean square.
    pub rms_mm: f64,
    /// Probability of a step at least this strong anywhere in residuals without one.
    pub p: f64,
}

/// Sums of one frame's residuals: the best split and its between-parts sum of squares, the
/// linear trend's, the total.
struct Split {
    at: usize,
    between: f64,
    trend: f64,
    total: f64,
    step: Vector3<f64>,
}

fn best_split(r: &[Vector3<f64>], min: usize) -> Option<Split> {
    let n = r.len();
    let mean = r.iter().sum::<Vector3<f64>>() / n as f64;
    let mid = (n - 1) as f64 / 2.0;
    let (mut total, mut stt, mut str) = (0.0, 0.0, Vector3::zeros());
    for (i, ri) in r.iter().enumerate() {
        let e = ri - mean;
        let t = i as f64 - mid;
        total += e.norm_squared();
        stt += t * t;
        str += e * t;
    }
    let trend = (str / stt).norm_squared() * stt;
    let mut before = Vector3::zeros();
    let mut best: Option<Split> = None;
    for (k, ri) in r.iter().enumerate().take(n - min) {
        before += ri - mean;
        let k1 = k + 1;
        if k1 < min {
            continue;
        }
        // Deviations from the overall mean: the first part's sum s, the second's −s.
        let (a, b) = (k1 as f64, (n - k1) as f64);
        let between = before.norm_squared() * (1.0 / a + 1.0 / b);
        if best.as_ref().is_none_or(|s| between > s.between) {
            best = Some(Split {
                at: k1,
                between,
                trend,
                total,
                step: -before * (1.0 / a + 1.0 / b),
            });
        }
    }
    best
}

/// The strongest step of `robot`'s point residuals over `data` in their order, in the flange
/// or the measurement frame, for a model fitted with `fitted` effective parameters; `None` with
/// fewer than 20 observations, residuals that are not finite, or no step that explains more
/// than a linear trend.
pub fn step<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    fitted: f64,
) -> Option<RowStep> {
    let n = data.len();
    let min = ((MIN_PART * n as f64).ceil() as usize).max(10);
    if n < 2 * min {
        return None;
    }
    let measured = pose_error_vectors(robot, data);
    if measured.iter().any(|r| !r.iter().all(|x| x.is_finite())) {
        return None;
    }
    let mut fk = ForwardKinematics::new();
    let flange: Vec<Vector3<f64>> = data
        .iter()
        .zip(&measured)
        .map(|(m, r)| {
            fk.compute_at(robot, &m.q, m.tool as usize, m.conditions());
            let f = fk.flange_pose();
            Vector3::new(f.x.dot(r), f.y.dot(r), f.z.dot(r))
        })
        .collect();
    let fitted = if fitted.is_finite() {
        fitted.max(0.0)
    } else {
        0.0
    };
    let df2 = (3.0 * n as f64 - 9.0 - fitted).max(1.0);
    let tries = 2.0 * (n + 1 - 2 * min) as f64;
    [
        (StepFrame::Flange, &flange),
        (StepFrame::Measurement, &measured),
    ]
    .into_iter()
    .filter_map(|(frame, r)| {
        let s = best_split(r, min)?;
        let rest = (s.total - s.between).max(0.0);
        let p = if rest > 0.0 {
            (f_sf((s.between / 3.0) / (rest / df2), 3.0, df2) * tries).min(1.0)
        } else {
            0.0
        };
        (s.between > s.trend && p.is_finite()).then_some(RowStep {
            at: s.at,
            frame,
            step_mm: s.step,
            rms_mm: (s.between / n as f64).sqrt(),
            p,
        })
    })
    .max_by(|a, b| a.rms_mm.total_cmp(&b.rms_mm))
}

/// The warning for a significant step ([`TREND_P`]) of at least [`STEP_SHARE`] of
/// `noise_floor_mm` (any size when the floor is not a finite number) in the residuals of
/// `robot` over `data`, whose observations stand on the file's lines `lines`; `None` otherwise.
/// `floor` names the floor in the text (`diagnose`'s noise floor, or `identify`'s RMS).
pub fn warning<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    (data, lines): (&[Measurement<f64, N>], &[u32]),
    fitted: f64,
    (noise_floor_mm, floor): (f64, &str),
) -> Option<String> {
    let s = step(robot, data, fitted)?;
    let large = !noise_floor_mm.is_finite() || s.rms_mm >= STEP_SHARE * noise_floor_mm;
    if !(s.p < TREND_P && large) {
        return None;
    }
    let (before, after) = (lines.get(s.at - 1)?, lines.get(s.at)?);
    let sig = |x: f64| crate::output::numfmt::sig(x, 3);
    let (what, axes) = match s.frame {
        StepFrame::Flange => (
            "the measured point moved on the arm (a reflector re-seated, knocked or turned in \
             its nest)",
            "the flange's axes",
        ),
        StepFrame::Measurement => (
            "the tracker or the robot's base moved (bumped, re-placed)",
            "the measurement frame",
        ),
    };
    let p = if s.p < 1e-16 {
        "p < 1e-16".to_string()
    } else {
        format!("p = {}", sig(s.p))
    };
    Some(format!(
        "the residuals step by {} mm between lines {before} and {after} (in {axes}: x {}, y {}, \
         z {} mm; {} mm RMS beside {floor} of {} mm, {p}), which the model does not \
         explain: {what} between those rows. Split the file there and calibrate from one part, \
         or re-measure after fixing it",
        sig(s.step_mm.norm()),
        sig(s.step_mm.x),
        sig(s.step_mm.y),
        sig(s.step_mm.z),
        sig(s.rms_mm),
        sig(noise_floor_mm),
    ))
}
