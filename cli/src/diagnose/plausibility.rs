//! Whether a finding's size is physically plausible for its kind.
//!
//! A significant gain is not enough: a joint-angle table varying by 17° peak to peak next to a
//! reflector on the joint's axis, or a joint deflecting by 13° per metre of lever arm, fits
//! the noise of a few poses the effect barely moves, and no gearbox or bearing does that. Such
//! a finding is refused with its reason; its family is held back until another effect has been
//! added, and dropped when refused a second time (`diagnose::held_back`). The limits are
//! an order of magnitude above what industrial arms show (gear transmission errors and
//! eccentricities of a few arc minutes, compliances of 1e-4 to 1e-3 rad per metre of the tool
//! weight's lever arm, scale errors of parts per thousand, expansion of steel and aluminium
//! 1.2e-5 and 2.3e-5 per kelvin), so no real effect is refused.

use super::candidates::{fmt_deg, Candidate, CandidateKind};
use crate::output::numfmt::sig;

/// The largest size of each kind of finding that is accepted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Peak to peak of a joint-angle table over its knots (degrees).
    pub table_peak_to_peak_deg: f64,
    /// Amplitude of a cyclic error (degrees).
    pub cyclic_amplitude_deg: f64,
    /// Magnitude of a scale error (dimensionless).
    pub scale: f64,
    /// Compliance (degrees per metre of lever arm).
    pub compliance_deg_per_m: f64,
    /// Tilt of an axis (degrees).
    pub tilt_deg: f64,
    /// Thermal expansion (per kelvin).
    pub expansion_per_k: f64,
    /// Drift of the measuring instrument (mm per hour).
    pub drift_mm_per_h: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            table_peak_to_peak_deg: 5.0,
            cyclic_amplitude_deg: 1.0,
            scale: 0.01,
            compliance_deg_per_m: 1.0,
            tilt_deg: 2.0,
            expansion_per_k: crate::calibration::thermal::MOST_EXPANSION_PER_K,
            drift_mm_per_h: 10.0,
        }
    }
}

/// Why the candidate `c` with fitted `values` (robot-file units) is not plausible; `None`
/// when it is.
pub fn implausible(c: &Candidate, values: &[f64], limits: &Limits) -> Option<String> {
    let j = c.joint + 1;
    let v0 = values.first().copied().unwrap_or(0.0);
    if values.iter().any(|v| !v.is_finite()) {
        return Some(format!("{} has a value that is not a number", c.label()));
    }
    match c.kind {
        CandidateKind::Table { .. } => {
            let (lo, hi) = values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                });
            let ptp = (hi - lo).to_degrees();
            (ptp > limits.table_peak_to_peak_deg).then(|| {
                format!(
                    "joint {j}'s angle error would vary by {} peak to peak, more than the {}° a gearbox can: the table fits poses the joint barely moves",
                    fmt_deg(hi - lo),
                    sig(limits.table_peak_to_peak_deg, 3)
                )
            })
        }
        CandidateKind::Cyclic(_) => {
            let amp = v0.hypot(values.get(1).copied().unwrap_or(0.0)).to_degrees();
            (amp > limits.cyclic_amplitude_deg).then(|| {
                format!(
                    "joint {j}'s cyclic error of ±{}° is beyond the ±{}° of any gear or encoder eccentricity",
                    sig(amp, 3),
                    sig(limits.cyclic_amplitude_deg, 3)
                )
            })
        }
        CandidateKind::Scale => (v0.abs() > limits.scale).then(|| {
            format!(
                "joint {j}'s scale error of {} ppm is beyond the {} ppm of a wrong gear ratio",
                sig(v0 * 1e6, 3),
                sig(limits.scale * 1e6, 3)
            )
        }),
        CandidateKind::Compliance => {
            let per_m = v0.abs().to_degrees();
            (per_m > limits.compliance_deg_per_m).then(|| {
                format!(
                    "joint {j} would deflect by {}° per m of lever arm, beyond the {}° of a compliant joint",
                    sig(per_m, 3),
                    sig(limits.compliance_deg_per_m, 3)
                )
            })
        }
        CandidateKind::Tilt => (v0.abs().to_degrees() > limits.tilt_deg).then(|| {
            format!(
                "joint {j}'s axis would be tilted by {}, beyond the {}° a nominally parallel axis can be off",
                fmt_deg(v0.abs()),
                sig(limits.tilt_deg, 3)
            )
        }),
        CandidateKind::Thermal { .. } if v0 < crate::calibration::thermal::MOST_SHRINK_PER_K => {
            Some(format!(
                "a thermal expansion of {} ppm per kelvin would shrink the links as they warm, \
                 which no arm's do: the temp_c column does not follow the arm's temperature",
                sig(v0 * 1e6, 3)
            ))
        }
        CandidateKind::Thermal { .. } => (v0.abs() > limits.expansion_per_k).then(|| {
            format!(
                "a thermal expansion of {} ppm per kelvin is beyond the {} ppm of any arm's material",
                sig(v0 * 1e6, 3),
                sig(limits.expansion_per_k * 1e6, 3)
            )
        }),
        CandidateKind::Drift { .. } => {
            let per_h = values.iter().map(|v| v * v).sum::<f64>().sqrt() * 3600.0;
            (per_h > limits.drift_mm_per_h).then(|| {
                format!(
                    "a drift of {} mm per hour is beyond the {} mm per hour of a working tracker: the robot or the tracker was moved during the session, or t_s is not in seconds",
                    sig(per_h, 3),
                    sig(limits.drift_mm_per_h, 3)
                )
            })
        }
    }
}
