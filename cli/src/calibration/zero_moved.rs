//! A joint's zero that moved since a model's calibration: a motor or an encoder swapped, a
//! joint re-mastered, a crash. Every reading of that joint is then off by one angle, and a
//! session judged against the model misses by as much as the angle times the lever arm: a
//! zero 5° off on an ER20 leaves 76 mm, which `validate` read as "the data do not fit the
//! robot file: check the units". The model registered on the session with one joint's zero
//! free as well tells it: when the best joint's leaves at most [`EXPLAINS`] of the model's RMS
//! and [`MIN_GAIN_MM`] less, that joint and its shift are named. Each joint's fit starts from
//! the best of a grid of shifts ([`GRID_DEG`]), so a shift of tens of degrees is found too.
//! What the data cannot tell from a zero is said beside it: a joint that barely moves in the
//! session with its readings' sign flipped (a shift of −2 × their mean, readings that span a
//! fifth of it at most), the base turned about
//! joint 1's axis when nothing is registered, a probe turned about the flange axis when the
//! tool is not registered.

use super::{fit_lm, Residuals};
use crate::output::numfmt::sig;
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
/// Each joint's fit starts from the shift of this grid (degrees, over a whole turn) that
/// leaves the least, registration held.
pub const GRID_DEG: f64 = 10.0;
/// A shift within this share of −2 × the joint's mean reading, on readings that span at most
/// this share of it, may be a flipped sign instead (a joint that barely moves).
const SIGN_SHARE: f64 = 0.2;

/// A joint whose zero moved ([`find`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZeroMoved {
    /// 1-based joint.
    pub joint: usize,
    /// The shift of its zero since the calibration (degrees): the joint stands this much
    /// beyond the angle the model makes of its reading (the MDH θ + q grows by it).
    pub shift_deg: f64,
    /// The model's RMS as registered, and with the zero free too (mm).
    pub rms_mm: f64,
    pub freed_rms_mm: f64,
    /// The joint's mean reading over the session, and the span of its readings (degrees).
    pub mean_reading_deg: f64,
    pub reading_span_deg: f64,
    /// It is the robot's last joint.
    pub last_joint: bool,
}

impl ZeroMoved {
    /// What the verdict says of it; `register` is what the session was registered with
    /// (`none`, `base`, `base+tool`), free beside the zero in the command it suggests, which
    /// reads `model` on `data`.
    pub fn clause(&self, register: &str, model: &str, data: &str) -> String {
        let j = self.joint;
        let free = match register {
            "none" => String::new(),
            r => format!("{},", r.replace('+', ",")),
        };
        let plus = if self.shift_deg > 0.0 { "+" } else { "" };
        let shift = format!("{plus}{}", sig(self.shift_deg, 3));
        let mut alike = Vec::new();
        let share = SIGN_SHARE * self.shift_deg.abs();
        if (self.shift_deg + 2.0 * self.mean_reading_deg).abs() <= share
            && self.reading_span_deg <= share
        {
            alike.push(format!(
                "its readings' sign flipped (they average {}°, the shift is −2 × that): check it \
                 with kinecal check",
                sig(self.mean_reading_deg, 3)
            ));
        }
        if j == 1 && register == "none" {
            alike.push(
                "the base turned about joint 1's axis: validate with --register base".to_string(),
            );
        }
        if self.last_joint && register != "base+tool" {
            alike.push(
                "the probe turned about the flange axis: validate with --register base+tool"
                    .to_string(),
            );
        }
        let alike = if alike.is_empty() {
            String::new()
        } else {
            format!("; the data look the same if {}", alike.join(", or "))
        };
        // identify takes no zero this far from its robot file's as a calibration.
        let most = super::arm_size::MOST_ANGLE_CHANGE_DEG;
        let remedy = if self.shift_deg.abs() > most {
            format!(
                "re-master joint {j} (a zero more than {}° from the model's is no calibration: \
                 identify refuses it)",
                sig(most, 2)
            )
        } else {
            format!(
                "re-master joint {j}, or calibrate its zero again (kinecal identify --robot \
                 {model} --data {data} --only {free}theta{j} --out NEW.toml)"
            )
        };
        format!(
            "joint {j}'s zero moved by {shift}° since the calibration (a motor or an encoder \
             swapped, the joint re-mastered: it stands {shift}° beyond where the model puts its \
             reading): with that zero corrected the model leaves {} mm instead of {} mm; \
             {remedy}{alike}",
            sig(self.freed_rms_mm, 3),
            sig(self.rms_mm, 3)
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
    let sample = super::every_kth(data, SAMPLE);
    let rms_of = |r: &HostRobot<N>| Residuals::of(r, &sample, &[]).identification_rms_mm;
    let rms_mm = rms_of(placed);
    if !rms_mm.is_finite() || rms_mm * (1.0 - EXPLAINS) < MIN_GAIN_MM {
        return None;
    }
    let steps = (360.0 / GRID_DEG).round() as i32;
    let mut best: Option<ZeroMoved> = None;
    for joint in 0..N {
        let zero = Param::Theta(joint as u8);
        if registration.contains(&zero) {
            continue;
        }
        let theta0 = placed.joints()[joint].theta;
        let shifted = |delta_deg: f64| {
            let mut r = placed.clone();
            let mut row = placed.joints()[joint];
            row.theta = theta0 + delta_deg.to_radians();
            r.set_joint(joint, row).ok().map(|_| r)
        };
        // The grid's best start (0 among it), then the LM over the registration and the zero.
        let start = (-steps / 2..=steps / 2)
            .map(|k| f64::from(k) * GRID_DEG)
            .filter_map(|d| Some((d, rms_of(&shifted(d)?))))
            .filter(|(_, rms)| rms.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(0.0, |(d, _)| d);
        let with: Vec<Param> = registration.iter().copied().chain([zero]).collect();
        let Some(from) = shifted(start) else {
            continue;
        };
        let Ok(fit) = fit_lm(&from, &with, &sample, LmConfig::default()) else {
            continue;
        };
        let freed_rms_mm = rms_of(&fit.robot);
        let raw = (fit.robot.joints()[joint].theta - theta0).to_degrees();
        // Within (−180°, 180°].
        let shift_deg = raw - 360.0 * ((raw + 180.0) / 360.0).ceil() + 360.0;
        let explains = freed_rms_mm <= EXPLAINS * rms_mm && rms_mm - freed_rms_mm >= MIN_GAIN_MM;
        if explains && shift_deg.is_finite() && best.is_none_or(|b| freed_rms_mm < b.freed_rms_mm) {
            let readings = data.iter().map(|m| m.q[joint].to_degrees());
            let mean_reading_deg = readings.clone().sum::<f64>() / data.len() as f64;
            let (lo, hi) = readings.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q), hi.max(q))
            });
            best = Some(ZeroMoved {
                joint: joint + 1,
                shift_deg,
                rms_mm,
                freed_rms_mm,
                mean_reading_deg,
                reading_span_deg: hi - lo,
                last_joint: joint + 1 == N,
            });
        }
    }
    best
}
