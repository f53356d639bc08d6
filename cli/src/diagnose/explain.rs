//! The explanation of a found effect in a technician's words: how large the identified
//! correction is (peak to peak in degrees and in mm at the tool), its period when it has one,
//! which poses and which joint angles it affects most, and how much of the held-out gap to the
//! noise floor it closed. "joint 2's gearbox repeats an error of ±0.012° every 3.6°", not
//! "joint-table on joint 2".
//!
//! Definitions (and why):
//! - **Size in degrees.** The correction `dq_j` of the final model (the diagnosis' `model`,
//!   fitted with every found effect: the one written; the fit right after the effect was added
//!   may give it what a later effect takes back: series A's joint-4 table read 0.65° peak to
//!   peak there, 0.19° in the written model) over the joint range the data cover (a
//!   dense grid plus a table's knots): its peak to peak and half of it (the "±"). A joint-cyclic
//!   term repeats, so it is the sine's own size, `2·√(a² + b²)`, whatever part of the turn the
//!   data saw. Compliance: `k·τ` over the poses' lever arms. Axis-tilt: the tilt angle itself.
//! - **Size at the tool.** Per pose, the tool displacement the correction makes,
//!   `|∂p/∂q_j · dq_j|` (the library's reading column, the direction the plots project
//!   residuals on); axis-tilt: `|p(β) − p(0)|` by the forward kinematics. RMS and maximum over
//!   the poses; the peak to peak of the displacement at the data's longest lever arm of the
//!   joint (`max |∂p/∂q_j| × peak to peak`).
//! - **Period.** Joint-cyclic of order `n`: 360°/n. Joint-table: the correction sampled on a
//!   uniform grid over the covered range, mean and linear trend removed, scanned for the
//!   single sinusoid that explains most of what is left (a periodogram on a fine frequency
//!   grid, so a period need not divide the range); reported only when that harmonic carries at
//!   least 80 % of the variance (an irregular table's best sine carries less, and "repeats
//!   every 70°" sent a technician after a cause that is not there), the range spans at least
//!   two periods and the period is at least two knot steps (a table cannot hold a shorter
//!   one). Otherwise there is no single period.
//! - **Most affected.** The (up to 5) poses with the largest tool displacement, 1-based in the
//!   row order of the data; and the joint-angle intervals where `|dq_j|` is within 80 % of its
//!   largest value (none for compliance and tilt, whose size depends on the pose, not on `q_j`).
//! - **Gap closed.** `(before − after) / (before − floor)` of the held-out RMS, clamped to
//!   [0, 1]; without a finite noise floor (or with no gap to it), the relative reduction
//!   `(before − after) / before`, and the text says so.

use crate::diagnose::candidates::{fmt_deg, fmt_mm, Candidate, CandidateKind};
use crate::diagnose::{distinct_figures, percent, Found};
use crate::output::numfmt::sig;
use crate::HostRobot;
use kinecal::model::param::Param;
use kinecal::{ForwardKinematics, Joint, Measurement};
use serde::Serialize;

/// How many poses [`Explanation::most_affected_poses`] lists.
pub const MOST_AFFECTED_POSES: usize = 5;
/// How many intervals [`Explanation::most_affected_range_deg`] lists.
pub const MOST_AFFECTED_RANGES: usize = 5;
/// An angle belongs to the most affected range when `|dq|` is at least this fraction of its
/// largest value.
pub const RANGE_FRACTION: f64 = 0.8;
/// A table's dominant harmonic must carry at least this fraction of the detrended variance.
pub const PERIOD_VARIANCE_FRACTION: f64 = 0.8;
/// Points of the dense grid over the covered joint range.
const GRID: usize = 2001;
/// A correction that moves the measured point by less than this (mm, a micrometre: below any
/// instrument's resolution) is said to turn the tool frame only: the point lies on the joint's
/// axis and the orientations show the effect.
pub const POINT_UNMOVED_MM: f64 = 1e-3;

/// What [`Explanation::gap_closed`] is a fraction of.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GapBasis {
    /// `(before − after) / (before − noise floor)`.
    NoiseFloor,
    /// `(before − after) / before`: no finite noise floor, or no gap to it.
    HeldOutRms,
}

/// The explanation of one found effect (the `explanation` object of `diagnose --json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Explanation {
    /// Peak to peak of the correction over the covered range (degrees); axis-tilt: the tilt;
    /// none for thermal expansion and a base drift (no joint angle: their size is at the tool).
    pub peak_to_peak_deg: Option<f64>,
    /// Half of it: the "±" (degrees).
    pub amplitude_deg: Option<f64>,
    /// RMS and largest tool displacement the correction makes at the data's poses (mm).
    pub tool_rms_mm: f64,
    pub tool_max_mm: f64,
    /// The peak to peak in mm at the data's longest lever arm of the joint (none for tilt).
    pub tool_peak_to_peak_mm: Option<f64>,
    /// The period (degrees of the joint), when the correction has one.
    pub period_deg: Option<f64>,
    /// The 1-based row numbers of the poses it moves most, largest first.
    pub most_affected_poses: Vec<usize>,
    /// Joint-angle intervals `[lo, hi]` (degrees) where `|dq|` is largest, largest first.
    pub most_affected_range_deg: Vec<[f64; 2]>,
    /// Fraction of the held-out gap this addition closed (see `gap_closed_of`), in [0, 1];
    /// none when the held-out RMS before it is not a positive number.
    pub gap_closed: Option<f64>,
    pub gap_closed_of: GapBasis,
    /// One sentence in a technician's words.
    pub text: String,
    /// Its first clause (what and how large), for plot titles.
    pub short: String,
}

/// One pose as the effect sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseEffect {
    /// The joint reading `q_j` (rad) and lever arm `τ_j` (m).
    pub q: f64,
    pub tau: f64,
    /// The correction at this pose (rad); axis-tilt: `β`.
    pub dq: f64,
    /// `|∂p/∂q_j|` (mm per rad); axis-tilt: `|∂p/∂β|`.
    pub lever_mm: f64,
    /// The tool displacement the correction makes (mm).
    pub tool_mm: f64,
    /// The pose's residual (measured − model) projected on the effect's direction:
    /// `∂p/∂q_j · r / |∂p/∂q_j|²` (rad; axis-tilt along `∂p/∂β`), the joint-angle error that
    /// would explain it.
    pub residual: f64,
}

/// The pose (0-based, among `data`'s poses) of every observation of `data`, which lists
/// observations pose after pose: a pose's further reflectors follow its first with a higher
/// tool index and the same readings. With one reflector, one pose per observation.
pub fn pose_numbers<const N: usize>(data: &[Measurement<f64, N>]) -> Vec<usize> {
    let mut out = Vec::with_capacity(data.len());
    let mut pose = 0;
    for (k, m) in data.iter().enumerate() {
        if k > 0 {
            let prev = &data[k - 1];
            if m.tool <= prev.tool || m.q != prev.q {
                pose += 1;
            }
        }
        out.push(pose);
    }
    out
}

/// Every observation of `data` as `c` (with its values in `robot`) sees it.
pub fn per_pose<const N: usize>(
    c: &Candidate,
    robot: &HostRobot<N>,
    data: &[Measurement<f64, N>],
) -> Vec<PoseEffect> {
    let j = c.joint;
    let values = c.values(robot);
    // Axis-tilt: the same robot with the axis untilted, for the exact displacement.
    let untilted = (c.kind == CandidateKind::Tilt)
        .then(|| {
            let mut r = robot.clone();
            let row = *robot.joints().get(j)?;
            r.set_joint(j, Joint { beta: 0.0, ..row }).ok()?;
            Some(r)
        })
        .flatten();
    let mut fk = ForwardKinematics::new();
    let mut fk0 = ForwardKinematics::new();
    data.iter()
        .map(|m| {
            let p = fk
                .compute_at(robot, &m.q, 0, m.conditions())
                .unwrap_or_default();
            let r = m.point - p;
            let tau = fk.lever_arms().get(j).copied().unwrap_or(0.0);
            let q = m.q.get(j).copied().unwrap_or(0.0);
            let dir = match c.kind {
                CandidateKind::Tilt => fk.column(robot, Param::Beta(j as u8)).unwrap_or_default(),
                // Per unit of c: the point's offset from the base times T − T0.
                CandidateKind::Thermal { .. } => robot
                    .effects()
                    .thermal()
                    .and_then(|(k, ..)| fk.column(robot, Param::Effect(k as u16)).ok())
                    .unwrap_or_default(),
                // Per unit of speed along the fitted drift: the time from the reference.
                CandidateKind::Drift { reference } => {
                    let v =
                        nalgebra::Vector3::from_iterator(values.iter().copied().chain([0.0; 3]));
                    let dt = m.time_s.map_or(0.0, |t| t - reference);
                    v.try_normalize(0.0).unwrap_or_default() * dt
                }
                _ => fk.reading_column(robot, j),
            };
            let n2 = dir.norm_squared();
            let residual = if n2 > 0.0 { dir.dot(&r) / n2 } else { 0.0 };
            let (dq, tool_mm) = match (&untilted, c.kind) {
                (Some(r0), CandidateKind::Tilt) => {
                    let beta = values.first().copied().unwrap_or(0.0);
                    (
                        beta,
                        (p - fk0
                            .compute_at(r0, &m.q, 0, m.conditions())
                            .unwrap_or_default())
                        .norm(),
                    )
                }
                (None, CandidateKind::Tilt) => (0.0, 0.0),
                (_, CandidateKind::Thermal { .. }) => {
                    let c = values.first().copied().unwrap_or(0.0);
                    (c, (dir * c).norm())
                }
                (_, CandidateKind::Drift { .. }) => {
                    let speed = values.iter().map(|v| v * v).sum::<f64>().sqrt();
                    (0.0, dir.norm() * speed)
                }
                _ => {
                    let dq = c.correction(&values, q, tau);
                    (dq, (dir * dq).norm())
                }
            };
            PoseEffect {
                q,
                tau,
                dq,
                lever_mm: n2.sqrt(),
                tool_mm,
                residual,
            }
        })
        .collect()
}

/// The joint range the data cover (rad); a single reading gives a zero-width range.
pub fn covered_range<const N: usize>(joint: usize, data: &[Measurement<f64, N>]) -> (f64, f64) {
    data.iter()
        .filter_map(|m| m.q.get(joint).copied())
        .filter(|q| q.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), q| {
            (a.min(q), b.max(q))
        })
}

/// The knots of a table candidate within `[lo, hi]` (rad) with their values:
/// `(q, value)` in rad; empty for the other kinds.
pub fn knots(c: &Candidate, values: &[f64], lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let CandidateKind::Table { start, step, knots } = c.kind else {
        return Vec::new();
    };
    (0..knots.min(values.len()))
        .map(|k| (start + step * k as f64, values[k]))
        .filter(|(q, _)| *q >= lo - 1e-12 && *q <= hi + 1e-12)
        .collect()
}

/// The correction (rad) on a dense uniform grid over `[lo, hi]` (rad) plus a table's knots in
/// it, sorted by angle: `(q, dq)`. Compliance and tilt have no curve in `q` (empty).
pub fn curve(c: &Candidate, values: &[f64], lo: f64, hi: f64) -> Vec<(f64, f64)> {
    if matches!(
        c.kind,
        CandidateKind::Compliance
            | CandidateKind::Tilt
            | CandidateKind::Thermal { .. }
            | CandidateKind::Drift { .. }
    ) || hi.is_nan()
        || lo.is_nan()
        || hi < lo
    {
        return Vec::new();
    }
    let n = if hi > lo { GRID } else { 1 };
    let mut qs: Vec<f64> = (0..n)
        .map(|k| lo + (hi - lo) * k as f64 / (n.max(2) - 1) as f64)
        .collect();
    qs.extend(knots(c, values, lo, hi).into_iter().map(|(q, _)| q));
    qs.sort_by(f64::total_cmp);
    qs.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    qs.into_iter()
        .map(|q| (q, c.correction(values, q, 0.0)))
        .collect()
}

/// The period (same unit as `lo`, `hi`) of the single sinusoid that explains the largest
/// share of `f` sampled on a uniform grid over `[lo, hi]` once its mean and linear trend are
/// removed, searched from `min_period` to half the range, and that share; `None` when the
/// range holds fewer than two periods of `min_period`, or `f` is a straight line there.
pub fn dominant_period(
    f: impl Fn(f64) -> f64,
    lo: f64,
    hi: f64,
    min_period: f64,
) -> Option<(f64, f64)> {
    let len = hi - lo;
    let max_period = len / 2.0;
    if !(len > 0.0 && min_period > 0.0 && min_period <= max_period) {
        return None;
    }
    // At least 8 samples per shortest period.
    let m = ((8.0 * len / min_period).ceil() as usize).clamp(1024, 16384);
    let x: Vec<f64> = (0..m)
        .map(|k| lo + len * k as f64 / (m - 1) as f64)
        .collect();
    let y: Vec<f64> = x.iter().map(|&x| f(x)).collect();
    if y.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // Orthonormal basis of {1, x}: u0 = 1/√m, u1 = (x − x̄)/‖x − x̄‖.
    let xm = x.iter().sum::<f64>() / m as f64;
    let xn = x.iter().map(|x| (x - xm).powi(2)).sum::<f64>().sqrt();
    let u0 = 1.0 / (m as f64).sqrt();
    let u1: Vec<f64> = x.iter().map(|x| (x - xm) / xn).collect();
    let proj = |v: &[f64]| -> (f64, f64) {
        (
            v.iter().sum::<f64>() * u0,
            v.iter().zip(&u1).map(|(a, b)| a * b).sum::<f64>(),
        )
    };
    let (a0, a1) = proj(&y);
    let r: Vec<f64> = y
        .iter()
        .zip(&u1)
        .map(|(y, u)| y - a0 * u0 - a1 * u)
        .collect();
    let var = r.iter().map(|v| v * v).sum::<f64>();
    let total = y.iter().map(|v| v * v).sum::<f64>();
    if var.is_nan() || var <= 1e-18 * total {
        return None;
    }
    // Share of `r` explained by a·sin + b·cos at frequency `nu` (cycles per unit), after the
    // sinusoid's own mean and trend are taken out (r is orthogonal to them already).
    let share = |nu: f64| -> f64 {
        let w = std::f64::consts::TAU * nu;
        let (mut ss, mut cc, mut sc, mut sr, mut cr) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut s0, mut c0, mut s1, mut c1) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..m {
            let (s, c) = (w * (x[k] - lo)).sin_cos();
            ss += s * s;
            cc += c * c;
            sc += s * c;
            sr += s * r[k];
            cr += c * r[k];
            s0 += s;
            c0 += c;
            s1 += s * u1[k];
            c1 += c * u1[k];
        }
        let (s0, c0) = (s0 * u0, c0 * u0);
        let g11 = ss - s0 * s0 - s1 * s1;
        let g22 = cc - c0 * c0 - c1 * c1;
        let g12 = sc - s0 * c0 - s1 * c1;
        let det = g11 * g22 - g12 * g12;
        if det.is_nan() || det <= 1e-12 * (g11 * g22).max(1e-300) {
            return 0.0;
        }
        let explained = (g22 * sr * sr - 2.0 * g12 * sr * cr + g11 * cr * cr) / det;
        (explained / var).clamp(0.0, 1.0)
    };
    let (nu_lo, nu_hi) = (1.0 / max_period, 1.0 / min_period);
    // 16 frequencies per 1/len, the width of a spectral peak.
    let dnu = 1.0 / (16.0 * len);
    let steps = (((nu_hi - nu_lo) / dnu).ceil() as usize).max(1);
    let (mut best_nu, mut best) = (nu_lo, share(nu_lo));
    for k in 1..=steps {
        let nu = (nu_lo + dnu * k as f64).min(nu_hi);
        let s = share(nu);
        if s > best {
            (best_nu, best) = (nu, s);
        }
    }
    // Golden-section refinement within one grid step either side.
    let (mut a, mut b) = ((best_nu - dnu).max(nu_lo), (best_nu + dnu).min(nu_hi));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..40 {
        let (c1, c2) = (b - g * (b - a), a + g * (b - a));
        if share(c1) >= share(c2) {
            b = c2;
        } else {
            a = c1;
        }
    }
    let nu = 0.5 * (a + b);
    let s = share(nu);
    if s > best {
        (best_nu, best) = (nu, s);
    }
    Some((1.0 / best_nu, best))
}

/// Intervals of the grid `(q, dq)` (q sorted) where `|dq| ≥ RANGE_FRACTION · max |dq|`, as
/// `[lo, hi]` with their largest `|dq|`, largest first.
pub fn largest_ranges(grid: &[(f64, f64)]) -> Vec<([f64; 2], f64)> {
    let peak = grid.iter().fold(0.0f64, |a, p| a.max(p.1.abs()));
    if peak <= 0.0 {
        return Vec::new();
    }
    let mut out: Vec<([f64; 2], f64)> = Vec::new();
    let mut open: Option<([f64; 2], f64)> = None;
    for &(q, dq) in grid {
        if dq.abs() >= RANGE_FRACTION * peak {
            open = Some(match open {
                Some(([a, _], m)) => ([a, q], m.max(dq.abs())),
                None => ([q, q], dq.abs()),
            });
        } else if let Some(iv) = open.take() {
            out.push(iv);
        }
    }
    out.extend(open);
    out.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0[0].total_cmp(&b.0[0])));
    out
}

/// The fraction of the held-out gap closed, and of what.
pub fn gap_closed(before_mm: f64, after_mm: f64, floor_mm: f64) -> (Option<f64>, GapBasis) {
    let gain = before_mm - after_mm;
    if floor_mm.is_finite() && before_mm - floor_mm > 0.0 && gain.is_finite() {
        return (
            Some((gain / (before_mm - floor_mm)).clamp(0.0, 1.0)),
            GapBasis::NoiseFloor,
        );
    }
    let g = gain / before_mm;
    (
        (before_mm > 0.0 && g.is_finite()).then(|| g.clamp(0.0, 1.0)),
        GapBasis::HeldOutRms,
    )
}

/// An interval of degrees with as many decimals as its width needs.
fn fmt_interval(a: f64, b: f64) -> String {
    let w = (b - a).abs();
    let d = if w >= 10.0 {
        0
    } else if w >= 1.0 {
        1
    } else {
        2
    };
    if format!("{a:.d$}") == format!("{b:.d$}") {
        format!("{a:.d$}°")
    } else {
        format!("{a:.d$}…{b:.d$}°")
    }
}

/// The effect's name in words with its size: the first clause of the explanation.
fn short_text(
    c: &Candidate,
    values: &[f64],
    e: &Explanation,
    covered_deg: f64,
    tau_max: f64,
) -> String {
    let j = c.joint + 1;
    let deg = |d: Option<f64>| d.map_or_else(String::new, |d| fmt_deg(d.to_radians()));
    let (amp, ptp) = (deg(e.amplitude_deg), deg(e.peak_to_peak_deg));
    let v0 = values.first().copied().unwrap_or(0.0);
    match c.kind {
        CandidateKind::Cyclic(1) => format!(
            "joint {j}'s gear or encoder is eccentric: an angle error of ±{amp} that repeats once per turn"
        ),
        CandidateKind::Cyclic(n) => {
            let times = if n == 2 { "twice".to_string() } else { format!("{n} times") };
            format!(
                "joint {j} repeats an angle error of ±{amp} every {}° ({times} per turn)",
                sig(360.0 / f64::from(n), 3)
            )
        }
        CandidateKind::Table { .. } => match e.period_deg {
            Some(p) => format!("joint {j}'s gearbox repeats an error of ±{amp} every {}°", sig(p, 3)),
            None => format!(
                "joint {j}'s angle error varies by {ptp} peak to peak over its travel (gear transmission error)"
            ),
        },
        CandidateKind::Scale => format!(
            "joint {j} turns {} ppm {} than its reading says (gear ratio or encoder resolution slightly off: {ptp} over the {}° of travel the data cover)",
            sig(v0.abs() * 1e6, 3),
            if v0 >= 0.0 { "further" } else { "less far" },
            sig(covered_deg, 3)
        ),
        CandidateKind::Compliance => format!(
            "joint {j} deflects under load by up to {} at its longest lever arm, {} m ({} per m)",
            fmt_deg((v0 * tau_max).abs()),
            sig(tau_max, 3),
            fmt_deg(v0.abs())
        ),
        CandidateKind::Thermal { reference } => format!(
            "the arm expands with its temperature by {} ppm per kelvin from {} °C (steel ≈ 12): up to {} mm at the poses measured",
            sig(v0 * 1e6, 3),
            sig(reference, 4),
            sig(e.tool_max_mm, 3)
        ),
        CandidateKind::Tilt => {
            let parent = if c.joint == 0 {
                "the base's vertical".to_string()
            } else {
                format!("joint {}'s axis", c.joint)
            };
            format!(
                "joint {j}'s axis is tilted by {} out of parallel with {parent}",
                fmt_deg(v0.abs())
            )
        }
        CandidateKind::Drift { .. } => format!(
            "the tracker drifted against the robot by {} mm per hour, up to {} mm from its mean position at the poses measured (not the arm's: not written to the model)",
            sig(values.iter().map(|v| v * v).sum::<f64>().sqrt() * 3600.0, 3),
            sig(e.tool_max_mm, 3)
        ),
    }
}

/// The explanation of `f` as the final `model` holds it, on the `data` the search ran on, with
/// the diagnosis' noise floor (mm, held-out RMS sense; not finite when none was estimated).
pub fn explain<const N: usize>(
    f: &Found<N>,
    model: &HostRobot<N>,
    data: &[Measurement<f64, N>],
    noise_floor_mm: f64,
) -> Explanation {
    let c = &f.candidate;
    let j = c.joint;
    let values = c.values(model);
    let poses = per_pose(c, model, data);
    let (lo, hi) = covered_range(j, data);
    let grid = if lo.is_finite() && hi.is_finite() {
        curve(c, &values, lo, hi)
    } else {
        Vec::new()
    };
    let spread = |v: &mut dyn Iterator<Item = f64>| -> f64 {
        let (a, b) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
        if b >= a {
            b - a
        } else {
            0.0
        }
    };
    let v0 = values.first().copied().unwrap_or(0.0);
    let ptp_rad = match c.kind {
        CandidateKind::Cyclic(_) => 2.0 * v0.hypot(values.get(1).copied().unwrap_or(0.0)),
        CandidateKind::Table { .. } | CandidateKind::Scale => spread(&mut grid.iter().map(|p| p.1)),
        CandidateKind::Compliance => spread(&mut poses.iter().map(|p| p.dq)),
        CandidateKind::Tilt => v0.abs(),
        // No joint angle: no size in degrees (JSON null); the size is at the tool.
        CandidateKind::Thermal { .. } | CandidateKind::Drift { .. } => f64::NAN,
    };
    // A non-finite size of a joint's correction stays visible (the report guard names it).
    let turns_a_joint = !matches!(
        c.kind,
        CandidateKind::Thermal { .. } | CandidateKind::Drift { .. }
    );
    let n = poses.len().max(1) as f64;
    let tool_rms_mm = (poses.iter().map(|p| p.tool_mm * p.tool_mm).sum::<f64>() / n).sqrt();
    let tool_max_mm = poses.iter().fold(0.0f64, |a, p| a.max(p.tool_mm));
    let tool_peak_to_peak_mm = (ptp_rad.is_finite() && c.kind != CandidateKind::Tilt)
        .then(|| poses.iter().fold(0.0f64, |a, p| a.max(p.lever_mm)) * ptp_rad);
    let period_deg = match c.kind {
        CandidateKind::Cyclic(n) => Some(360.0 / f64::from(n.max(1))),
        CandidateKind::Table { step, .. } if hi > lo => dominant_period(
            |x| c.correction(&values, x.to_radians(), 0.0),
            lo.to_degrees(),
            hi.to_degrees(),
            2.0 * step.to_degrees(),
        )
        .filter(|(_, share)| *share >= PERIOD_VARIANCE_FRACTION)
        .map(|(p, _)| p),
        _ => None,
    };
    // Observations of one pose (several reflectors) count once, as their pose, at the largest
    // displacement of its points.
    let pose = pose_numbers(data);
    let mut largest = vec![0.0f64; pose.last().map_or(0, |p| p + 1)];
    for (k, e) in poses.iter().enumerate() {
        if let Some(l) = pose.get(k).and_then(|&p| largest.get_mut(p)) {
            *l = l.max(e.tool_mm);
        }
    }
    let mut order: Vec<usize> = (0..largest.len()).filter(|&i| largest[i] > 0.0).collect();
    order.sort_by(|&a, &b| largest[b].total_cmp(&largest[a]).then(a.cmp(&b)));
    let most_affected_poses: Vec<usize> = order
        .into_iter()
        .take(MOST_AFFECTED_POSES)
        .map(|i| i + 1)
        .collect();
    let ranges = largest_ranges(&grid);
    let most_affected_range_deg: Vec<[f64; 2]> = ranges
        .iter()
        .take(MOST_AFFECTED_RANGES)
        .map(|(iv, _)| iv.map(f64::to_degrees))
        .collect();
    let (gap, gap_basis) = gap_closed(f.before_rms_mm, f.validation_rms_mm, noise_floor_mm);
    let mut e = Explanation {
        peak_to_peak_deg: turns_a_joint.then(|| ptp_rad.to_degrees()),
        amplitude_deg: turns_a_joint.then(|| ptp_rad.to_degrees() / 2.0),
        tool_rms_mm,
        tool_max_mm,
        tool_peak_to_peak_mm,
        period_deg,
        most_affected_poses,
        most_affected_range_deg,
        gap_closed: gap,
        gap_closed_of: gap_basis,
        text: String::new(),
        short: String::new(),
    };
    let tau_max = poses.iter().fold(0.0f64, |a, p| a.max(p.tau.abs()));
    let covered_deg = if hi > lo { (hi - lo).to_degrees() } else { 0.0 };
    e.short = short_text(c, &values, &e, covered_deg, tau_max);
    // Where: the angle interval (for effects of q_j) and the poses.
    let [rms, max] = distinct_figures([e.tool_rms_mm, e.tool_max_mm]);
    let mut details = vec![if e.tool_max_mm < POINT_UNMOVED_MM {
        format!(
            "it turns the tool frame only (the measured point moves by under {} mm: it lies on \
             the joint's axis), as the orientations show",
            sig(POINT_UNMOVED_MM, 1)
        )
    } else {
        format!("{rms} mm RMS at the tool, up to {max} mm")
    }];
    if let Some(t) = e.tool_peak_to_peak_mm.filter(|_| {
        matches!(c.kind, CandidateKind::Table { .. } | CandidateKind::Scale)
            && !ranges.is_empty()
            && e.tool_max_mm >= POINT_UNMOVED_MM
    }) {
        details.push(format!(
            "{} mm peak to peak at the longest lever arm",
            fmt_mm(t)
        ));
    }
    let mut where_ = Vec::new();
    if let Some([a, b]) = e.most_affected_range_deg.first() {
        let more = ranges.len() - 1;
        where_.push(format!(
            "largest near q{} = {}{}",
            j + 1,
            fmt_interval(*a, *b),
            match (more, e.period_deg) {
                (0, _) => String::new(),
                // |dq| of a periodic error peaks twice per period.
                (_, Some(p)) => format!(" and every {}° from there", sig(p / 2.0, 3)),
                (1, None) => " and one more range".to_string(),
                (k, None) => format!(" and {k} more ranges"),
            }
        ));
    } else if c.kind == CandidateKind::Compliance {
        where_.push("largest at the longest lever arms".to_string());
    }
    if !e.most_affected_poses.is_empty() {
        let list: Vec<String> = e
            .most_affected_poses
            .iter()
            .map(|p| p.to_string())
            .collect();
        where_.push(format!(
            "pose{} {}",
            if list.len() == 1 { "" } else { "s" },
            list.join(", ")
        ));
    }
    if !where_.is_empty() {
        details.push(where_.join(", "));
    }
    let gap_text = match (e.gap_closed, e.gap_closed_of) {
        (Some(g), GapBasis::NoiseFloor) => format!(
            "it closes {} % of the held-out gap to the noise floor",
            percent(g)
        ),
        (Some(g), GapBasis::HeldOutRms) => format!(
            "it cuts the held-out RMS by {} % ({})",
            percent(g),
            if noise_floor_mm.is_finite() {
                "the held-out RMS was at the noise floor already"
            } else {
                "no noise floor was estimated to measure the gap against"
            }
        ),
        (None, _) => "its share of the held-out gap is unknown".to_string(),
    };
    e.text = format!("{} ({}); {gap_text}", e.short, details.join("; "));
    e
}
