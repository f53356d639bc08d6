//! A change of the residuals along the rows' order that the model does not explain: a step (a
//! reflector re-seated or knocked, fixed in the flange frame; a tracker or base bumped, fixed in
//! the measurement frame) or a creep in the flange frame (a reflector loosening in its nest). A
//! fit takes the mean of the parts, and the search takes what is left for noise: 300 rows with
//! the reflector moved 1.1 mm after row 150 calibrated with exit 0, and `diagnose` reported a
//! "noise floor" of 0.56 mm (25 times the tracker's noise) and nothing missing. (A creep in the
//! measurement frame is a drifting tracker: [`super::time_trend`].)
//!
//! [`change`] splits the point residuals between every two rows (not between the reflectors of
//! one row) that leave at least [`MIN_ROWS`] observations on each side, in both frames, and
//! keeps the split whose two means differ most (the between-parts sum of squares
//! `k(n−k)/n·|r̄₁ − r̄₂|²`). Its F test (3 and 3n − 9 − the model's effective parameters degrees
//! of freedom) is multiplied by the number of splits tried (Bonferroni) and by 2 frames. A
//! linear drift also splits best somewhere (the best split of a ramp holds 3/4 of it), and a
//! step is fitted by a line to 3/4 too: where the line explains more, the change is a creep
//! (reported in the flange frame only). A split at the least part's edge may stand for a step
//! before it: the text then names the rows up to it, not one line.

use super::significance::f_sf;
use super::time_trend::TREND_P;
use crate::calibration::pose_error_vectors;
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::Vector3;

/// The fewest observations each side of a split holds.
pub const MIN_ROWS: usize = 10;

/// A step (or a creep from the first row to the last) smaller than this share of the noise
/// floor is not warned about. A step adds to the floor (`floor² ≈ noise² + k(n−k)/n²·step²`),
/// so a step as large as the floor is larger than the noise. The real UR10 series C has a
/// significant step smaller than its floor, near where its rows' temperature starts to climb.
pub const STEP_SHARE: f64 = 1.0;

/// The frame a change is fixed in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepFrame {
    /// The flange's axes: the measured point moved on the arm (the reflector).
    Flange,
    /// The measurement frame: the tracker or the robot's base moved.
    Measurement,
}

/// The strongest change of the residuals along the rows' order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowStep {
    /// The first observation after the step (0-based); `None` for a creep.
    pub at: Option<usize>,
    /// The split sits at the least part's edge: the step may lie before it.
    pub at_edge: bool,
    pub frame: StepFrame,
    /// Mean residual after the step less before it, or the creep from the first observation
    /// to the last, in the frame's axes (mm).
    pub change_mm: Vector3<f64>,
    /// Probability of a change at least this strong in residuals without one.
    pub p: f64,
}

/// One frame's sums: the best split, its between-parts sum of squares, the linear trend's and
/// its slope, the total.
struct Split {
    at: usize,
    between: f64,
    step: Vector3<f64>,
    trend: f64,
    slope: Vector3<f64>,
    total: f64,
}

/// The best split of `r` between observations `k − 1` and `k` where `cut[k]` (a new row), each
/// side at least `min` long; `None` when there is none.
fn best_split(r: &[Vector3<f64>], cut: &[bool], min: usize) -> Option<Split> {
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
    let slope = str / stt;
    let trend = slope.norm_squared() * stt;
    let mut before = Vector3::zeros();
    let mut best: Option<Split> = None;
    for (k, ri) in r.iter().enumerate().take(n - min) {
        before += ri - mean;
        let k1 = k + 1;
        if k1 < min || !cut[k1] {
            continue;
        }
        // Deviations from the overall mean: the first part's sum s, the second's −s.
        let (a, b) = (k1 as f64, (n - k1) as f64);
        let between = before.norm_squared() * (1.0 / a + 1.0 / b);
        if best.as_ref().is_none_or(|s| between > s.between) {
            best = Some(Split {
                at: k1,
                between,
                step: -before * (1.0 / a + 1.0 / b),
                trend,
                slope,
                total,
            });
        }
    }
    best
}

/// The strongest change of `robot`'s point residuals over `data` in their order (observations
/// on the file's lines `lines`, one row's reflectors on one line), in the flange or the
/// measurement frame, for a model fitted with `fitted` effective parameters; `None` with fewer
/// than `2·MIN_ROWS` observations, residuals that are not finite, or a change that a linear
/// drift of the measurement frame explains better (see the module).
pub fn change<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    (data, lines): (&[Measurement<f64, N>], &[u32]),
    fitted: f64,
) -> Option<RowStep> {
    let n = data.len();
    if n < 2 * MIN_ROWS || lines.len() != n {
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
    let cut: Vec<bool> = (0..n).map(|k| k == 0 || lines[k] != lines[k - 1]).collect();
    let fitted = if fitted.is_finite() {
        fitted.max(0.0)
    } else {
        0.0
    };
    let tries = 2.0
        * cut[MIN_ROWS..=n - MIN_ROWS]
            .iter()
            .filter(|c| **c)
            .count()
            .max(1) as f64;
    let f_p = |ss: f64, rest: f64, df2: f64, times: f64| {
        if rest > 0.0 {
            (f_sf((ss / 3.0) / (rest / df2), 3.0, df2) * times).min(1.0)
        } else {
            0.0
        }
    };
    [
        (StepFrame::Flange, &flange),
        (StepFrame::Measurement, &measured),
    ]
    .into_iter()
    .filter_map(|(frame, r)| {
        let s = best_split(r, &cut, MIN_ROWS)?;
        let df2 = (3.0 * n as f64 - 9.0 - fitted).max(1.0);
        if s.between > s.trend {
            let p = f_p(s.between, s.total - s.between, df2, tries);
            let edge = s.at == MIN_ROWS || s.at == n - MIN_ROWS;
            return Some((
                s.between,
                RowStep {
                    at: Some(s.at),
                    at_edge: edge,
                    frame,
                    change_mm: s.step,
                    p,
                },
            ));
        }
        // A creep. The measurement frame's competes too: when it explains more, the change is
        // a drifting tracker, time_trend's to tell, and none of this module's.
        let p = f_p(s.trend, s.total - s.trend, df2, 2.0);
        Some((
            s.trend,
            RowStep {
                at: None,
                at_edge: false,
                frame,
                change_mm: s.slope * (n - 1) as f64,
                p,
            },
        ))
    })
    .filter(|(_, s)| s.p.is_finite())
    .max_by(|a, b| a.0.total_cmp(&b.0))
    .map(|(_, s)| s)
    .filter(|s| s.at.is_some() || s.frame == StepFrame::Flange)
}

/// A probability as the warnings print it: `p = 0.000123`, or `p < 1e-16`.
pub fn p_text(p: f64) -> String {
    if p < 1e-16 {
        "p < 1e-16".to_string()
    } else {
        format!("p = {}", crate::output::numfmt::sig(p, 3))
    }
}

/// Whether a change of probability `p` and size `size_mm` at the tool is told: significant
/// ([`TREND_P`]) and at least [`STEP_SHARE`] of `floor_mm` (any size when the floor is not a
/// finite number); for this module's steps and [`super::zero_step`]'s.
pub fn worth_telling(p: f64, size_mm: f64, floor_mm: f64) -> bool {
    p < TREND_P && (!floor_mm.is_finite() || size_mm >= STEP_SHARE * floor_mm)
}

/// Why a fit whose residuals step at one row is no calibration, as the rest of a sentence
/// that starts "the fit": a step (not a creep) that [`warning`] tells. The fit took the mean
/// of two set-ups (300 UR10 rows with the reflector moved 1.1 mm after row 150 were calibrated
/// with exit 0 and a warning; host-tests `row_step`).
pub fn refusal<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    at: (&[Measurement<f64, N>], &[u32]),
    fitted: f64,
    floor: (f64, &str),
) -> Option<String> {
    change(robot, at, fitted)?.at?;
    let w = warning(robot, at, fitted, floor)?;
    Some(format!("took the mean of two set-ups: {w}"))
}

/// The warning for a significant change ([`TREND_P`]) at least [`STEP_SHARE`] of `floor_mm`
/// (any size when the floor is not a finite number) in the residuals of `robot` over `data`,
/// whose observations stand on the file's lines `lines`; `None` otherwise. `floor` names the
/// floor in the text (`diagnose`'s noise floor, or `identify`'s RMS).
pub fn warning<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    (data, lines): (&[Measurement<f64, N>], &[u32]),
    fitted: f64,
    (floor_mm, floor): (f64, &str),
) -> Option<String> {
    let s = change(robot, (data, lines), fitted)?;
    let size = s.change_mm.norm();
    if !worth_telling(s.p, size, floor_mm) {
        return None;
    }
    let sig = |x: f64| crate::output::numfmt::sig(x, 3);
    let axes = match s.frame {
        StepFrame::Flange => "the flange's axes",
        StepFrame::Measurement => "the measurement frame",
    };
    let p = p_text(s.p);
    let figures = format!(
        "in {axes}: x {}, y {}, z {} mm; beside {floor} of {} mm, {p}",
        sig(s.change_mm.x),
        sig(s.change_mm.y),
        sig(s.change_mm.z),
        sig(floor_mm),
    );
    let what = match (s.at, s.frame) {
        (None, _) => {
            return Some(format!(
                "the residuals creep along the rows' order by {} mm from the first row to the \
                 last ({figures}), which the model does not explain: the measured point moves on \
                 the arm (a reflector loosening in its nest, a probe's tip wearing). Fix it and \
                 re-measure",
                sig(size)
            ))
        }
        (Some(_), StepFrame::Flange) => {
            "the measured point moved on the arm (a reflector re-seated, knocked or turned in \
             its nest)"
        }
        (Some(_), StepFrame::Measurement) => {
            "the tracker or the robot's base moved (bumped, re-placed), or drifted and then \
             settled"
        }
    };
    let at = s.at?;
    let (before, after) = (*lines.get(at - 1)?, *lines.get(at)?);
    let between = if !s.at_edge {
        format!("between lines {before} and {after}")
    } else if at == MIN_ROWS {
        format!("at line {after} or before it")
    } else {
        format!("at line {before} or after it")
    };
    Some(format!(
        "the residuals step by {} mm {between} ({figures}), which the model does not explain: \
         {what}. Split the file there and calibrate from one part, or re-measure after \
         fixing it",
        sig(size),
    ))
}
