//! A joint's zero that moved since a model's calibration: a motor or an encoder swapped, a
//! joint re-mastered, a crash. Every reading of that joint is then off by one angle, and a
//! session judged against the model misses by as much as the angle times the lever arm: a
//! zero 5° off on a UR10 leaves tens of millimetres, which `validate` read as "the data do not
//! fit the robot file: check the units". The model registered on the session with one joint's
//! zero free as well tells it: when the best joint's leaves at most [`EXPLAINS`] of the
//! model's RMS and [`MIN_GAIN_MM`] less, that joint and its shift are named.

use super::{fit_lm, Residuals};
use crate::HostRobot;
use kinecal::identify::lm::LmConfig;
use kinecal::{Measurement, Param};
use serde::{Deserialize, Serialize};

/// The model with the joint's zero free leaves at most this share of its RMS...
pub const EXPLAINS: f64 = 0.2;
/// ... and at least this much less (mm).
pub const MIN_GAIN_MM: f64 = 0.05;
/// The fits are made on at most this many observations (every k-th).
pub const SAMPLE: usize = 2000;

/// A joint whose zero moved ([`find`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZeroMoved {
    /// 1-based joint.
    pub joint: usize,
    /// The shift of its zero since the calibration (degrees; the model angle is the reading
    /// plus the model's offset plus this).
    pub shift_deg: f64,
    /// The model's RMS as registered, and with the zero free too (mm).
    pub rms_mm: f64,
    pub freed_rms_mm: f64,
}

impl ZeroMoved {
    /// What the verdict says of it; `register` is what the session was registered with
    /// (`none`, `base`, `base+tool`), free beside the zero in the command it suggests.
    pub fn clause(&self, register: &str) -> String {
        let j = self.joint;
        let free = match register {
            "none" => String::new(),
            r => format!("{},", r.replace('+', ",")),
        };
        format!(
            "joint {j}'s zero moved by {}° since the calibration (a motor or an encoder swapped, \
             the joint re-mastered): with that zero corrected the model leaves {} mm instead of \
             {} mm; re-master joint {j}, or calibrate its zero again (kinecal identify --robot \
             M.toml --data SESSION.csv --only {free}theta{j})",
            crate::output::numfmt::sig(self.shift_deg, 3),
            crate::output::numfmt::sig(self.freed_rms_mm, 3),
            crate::output::numfmt::sig(self.rms_mm, 3)
        )
    }
}

/// The joint whose zero, freed beside `registration` (the parameters `placed`, the model, was
/// registered on `data` with), best explains what the model leaves, when it leaves at most
/// [`EXPLAINS`] of it and [`MIN_GAIN_MM`] less; `None` otherwise.
pub fn find<const N: usize>(
    placed: &HostRobot<N>,
    registration: &[Param],
    data: &[Measurement<f64, N>],
) -> Option<ZeroMoved> {
    if data.is_empty() {
        return None;
    }
    let every = data.len().div_ceil(SAMPLE);
    let sample: Vec<Measurement<f64, N>> = data.iter().step_by(every).copied().collect();
    let rms_of = |r: &HostRobot<N>| Residuals::of(r, &sample, &[]).identification_rms_mm;
    let rms_mm = rms_of(placed);
    if !rms_mm.is_finite() || rms_mm * (1.0 - EXPLAINS) < MIN_GAIN_MM {
        return None;
    }
    let mut best: Option<ZeroMoved> = None;
    for joint in 0..N {
        let zero = Param::Theta(joint as u8);
        if registration.contains(&zero) {
            continue;
        }
        let with: Vec<Param> = registration.iter().copied().chain([zero]).collect();
        let Ok(fit) = fit_lm(placed, &with, &sample, LmConfig::default()) else {
            continue;
        };
        let freed_rms_mm = rms_of(&fit.robot);
        let shift = fit
            .robot
            .joints()
            .get(joint)
            .map(|j| j.theta)
            .zip(placed.joints().get(joint).map(|j| j.theta))
            .map(|(a, b)| (a - b).to_degrees());
        let explains = freed_rms_mm <= EXPLAINS * rms_mm && rms_mm - freed_rms_mm >= MIN_GAIN_MM;
        if let Some(shift_deg) = shift.filter(|s| s.is_finite() && explains) {
            if best.is_none_or(|b| freed_rms_mm < b.freed_rms_mm) {
                best = Some(ZeroMoved {
                    joint: joint + 1,
                    shift_deg,
                    rms_mm,
                    freed_rms_mm,
                });
            }
        }
    }
    best
}
