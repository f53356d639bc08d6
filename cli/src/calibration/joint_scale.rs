//! A fit whose data read one joint on another scale than the robot file's: a gear ratio or an
//! encoder's resolution set anew, readings exported in another unit for one axis. No geometric
//! parameter takes such an error up: an ER20 whose joint 4 reads 1 % off, at 0.02 mm noise,
//! was fitted to 3.1 mm, "predicted better than by the starting model", exit 0. The same fit
//! with a scale on one joint's readings tells it, on at most [`SAMPLE`] observations: when the
//! best joint's leaves at most [`EXPLAINS`] of the fit's RMS and [`MIN_GAIN_MM`] less, the
//! joint and its scale are named: as no calibration when the scale is the readings'
//! ([`READINGS_SCALE`]), else as a warning.

use crate::calibration::{add_effect, EffectRequest, Residuals};
use crate::output::numfmt::sig;
use crate::HostRobot;
use kinecal::identify::lm::LmConfig;
use kinecal::{EffectKind, Measurement, Param};

/// The fit with the scale leaves at most this share of the fit's RMS...
pub const EXPLAINS: f64 = 1.0 / 3.0;
/// ... and at least this much less (mm).
pub const MIN_GAIN_MM: f64 = 0.05;
/// The comparison is made on at most this many observations (every k-th).
pub const SAMPLE: usize = 2000;
/// A scale at least this large is the readings' (a gear ratio or a resolution set anew, 1 %
/// off): no calibration (exit 3). Gearboxes' own scale errors are parts per thousand, and a
/// smaller scale that explains the fit may stand in for a joint's cyclic error or table (an
/// ER20 with a 0.064° once-per-turn error on joint 2: 671 ppm): a warning that points to
/// `kinecal diagnose`.
pub const READINGS_SCALE: f64 = 0.005;

/// A fit a scale on one joint's readings explains ([`check`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaled {
    /// 0-based joint.
    pub joint: usize,
    /// The fit's RMS, refitted (mm), and with the scale (mm).
    pub rms_mm: f64,
    pub scaled_rms_mm: f64,
    /// The scale `s` (the model angle is `reading + s · reading`).
    pub scale: f64,
    /// The fit held the joint's zero and both refits freed it (`--only` without `thetaJ`).
    pub zero_freed: bool,
}

impl Scaled {
    /// Whether the scale is the readings' ([`READINGS_SCALE`]): the fit is no calibration.
    pub fn readings(&self) -> bool {
        self.scale.abs() >= READINGS_SCALE
    }

    fn figures(&self) -> String {
        let j = self.joint + 1;
        let zero = if self.zero_freed {
            format!(" with joint {j}'s zero free (theta{j}, held by --only)")
        } else {
            String::new()
        };
        format!(
            "leaves {} mm{zero}; with a scale on joint {j}'s readings too it leaves {} mm (joint \
             {j} turns {} ppm {} than its readings say)",
            sig(self.rms_mm, 4),
            sig(self.scaled_rms_mm, 4),
            sig(self.scale.abs() * 1e6, 3),
            if self.scale > 0.0 { "more" } else { "less" }
        )
    }

    /// Why the fit is no calibration, as the rest of a sentence that starts "the fit".
    pub fn reason(&self) -> String {
        format!(
            "{}: its readings are on another scale than the robot file's (a gear ratio or an \
             encoder's resolution set anew, an axis exported in another unit), which no \
             geometry takes up: correct the readings, or identify with --effect joint-scale:{}{}",
            self.figures(),
            self.joint + 1,
            if self.zero_freed {
                format!(" and theta{} among --only", self.joint + 1)
            } else {
                String::new()
            }
        )
    }

    /// The warning (without its `warning:`) when the scale is no more than a gearbox's.
    pub fn warning(&self) -> String {
        format!(
            "the fit {}: the geometry misses what joint {}'s readings carry (a scale, \
             a cyclic error or a table): kinecal diagnose names it",
            self.figures(),
            self.joint + 1
        )
    }
}

/// The joint whose readings' scale best explains what a fit of `params` (converged at
/// `fitted`) leaves on `data`, when it leaves at most [`EXPLAINS`] of it and [`MIN_GAIN_MM`]
/// less; `None` otherwise. Both fits are continued from `fitted` by the LM over `params` and
/// the joint's zero (a fit stopped short, a stochastic search's, gains from the continuation
/// alone; a zero error is no scale).
pub fn check<const N: usize>(
    fitted: &HostRobot<N>,
    params: &[Param],
    data: &[Measurement<f64, N>],
) -> Option<Scaled> {
    if data.is_empty() || params.is_empty() {
        return None;
    }
    let sample = super::every_kth(data, SAMPLE);
    // No scale can gain enough: not worth the fits.
    let first = Residuals::of(fitted, &sample, &[]).identification_rms_mm;
    if first.is_nan() || first * (1.0 - EXPLAINS) < MIN_GAIN_MM {
        return None;
    }
    let refit = super::fit_lm(fitted, params, &sample, LmConfig::default()).ok()?;
    let rms_of = |r: &HostRobot<N>| Residuals::of(r, &sample, &[]).identification_rms_mm;
    let rms_mm = rms_of(&refit.robot);
    if rms_mm.is_nan() || rms_mm * (1.0 - EXPLAINS) < MIN_GAIN_MM {
        return None;
    }
    let scaled: Vec<usize> = fitted
        .effects()
        .iter()
        .filter(|e| e.kind == EffectKind::Scale)
        .map(|e| e.joint as usize)
        .collect();
    let mut best: Option<Scaled> = None;
    for joint in (0..N).filter(|j| !scaled.contains(j)) {
        // The joint's zero is free in both fits: a fit that holds it (`--only`) would read a
        // zero error as a scale.
        let zero = Param::Theta(joint as u8);
        let (base, rms_mm) = if params.contains(&zero) {
            (refit.robot.clone(), rms_mm)
        } else {
            let with_zero: Vec<Param> = params.iter().copied().chain([zero]).collect();
            let Ok(f) = super::fit_lm(&refit.robot, &with_zero, &sample, LmConfig::default())
            else {
                continue;
            };
            let r = rms_of(&f.robot);
            (f.robot, r)
        };
        let mut start = base;
        let req = EffectRequest {
            kind: "joint-scale".into(),
            joint,
            arg: None,
        };
        let Ok(extra) = add_effect(&mut start, &req, (0.0, 0.0)) else {
            continue;
        };
        let Some(Param::Effect(k)) = extra.first().copied() else {
            continue;
        };
        let with: Vec<Param> = params
            .iter()
            .copied()
            .chain((!params.contains(&zero)).then_some(zero))
            .chain(extra)
            .collect();
        let Ok(fit) = super::fit_lm(&start, &with, &sample, LmConfig::default()) else {
            continue;
        };
        let scaled_rms_mm = rms_of(&fit.robot);
        let value = fit.robot.effects().values().get(usize::from(k)).copied();
        // Only a scale that explains enough of its own fit's RMS counts (each joint's fit
        // differs when its zero was freed); the best leaves the least share of it.
        let explains = scaled_rms_mm <= EXPLAINS * rms_mm && rms_mm - scaled_rms_mm >= MIN_GAIN_MM;
        if let Some(scale) = value.filter(|v| v.is_finite() && explains) {
            if best.is_none_or(|b| scaled_rms_mm / rms_mm < b.scaled_rms_mm / b.rms_mm) {
                best = Some(Scaled {
                    joint,
                    rms_mm,
                    scaled_rms_mm,
                    scale,
                    zero_freed: !params.contains(&zero),
                });
            }
        }
    }
    best
}
