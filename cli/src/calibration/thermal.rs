//! The `thermal-expansion` term on the command line and in identification: every length of
//! the model scales by `1 + c·(T − T0)` at a row's `temp_c` (`docs/formats.md#effects`).
//!
//! Its reference temperature `T0` is the identification data's mean temperature unless given
//! (`--effect thermal-expansion:0:T0`, or `reference_c` in the robot file): at the mean, `c`
//! and the lengths hardly trade with each other, and the identified lengths are the arm's at
//! the temperature it usually works at.

use super::EffectRequest;
use crate::formats::robot_file::{RobotFile, THERMAL};
use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal::{Measurement, Robot};

/// `--effect thermal-expansion`, `thermal-expansion:0` or `thermal-expansion:0:T0` (°C);
/// `None` for any other effect.
pub fn parse_request(s: &str) -> Option<anyhow::Result<EffectRequest>> {
    let rest = s.strip_prefix(THERMAL)?;
    if !(rest.is_empty() || rest.starts_with(':')) {
        return None;
    }
    let parts: Vec<&str> = rest.split(':').skip(1).collect();
    let bad = || {
        anyhow::anyhow!(
            "--effect {s}: expected thermal-expansion, thermal-expansion:0 or thermal-expansion:0:T0 \
             (it acts on no joint: joint 0; T0 the reference temperature in °C, default the data's mean)"
        )
    };
    let r = match parts.as_slice() {
        [] => Ok(None),
        ["0"] => Ok(None),
        ["0", t] => match t.parse::<f64>() {
            Ok(t) if t.is_finite() && t.abs() <= 1e3 => Ok(Some(t)),
            _ => Err(bad()),
        },
        _ => Err(bad()),
    };
    Some(r.map(|arg| EffectRequest {
        kind: THERMAL.to_string(),
        joint: 0,
        arg,
    }))
}

/// Mean temperature (°C) of `data` when every observation has one.
pub fn mean_temperature<const N: usize>(data: &[Measurement<f64, N>]) -> Option<f64> {
    let t: Vec<f64> = data.iter().map(|m| m.temp_c).collect::<Option<_>>()?;
    (!t.is_empty()).then(|| t.iter().sum::<f64>() / t.len() as f64)
}

/// Adds a thermal-expansion term at `c = 0` to `robot`, its reference `req.arg` or the mean
/// temperature of `data`; returns its parameter. Refused without a temperature on every row.
pub fn add<const N: usize, V: kinecal::ValueStorage>(
    robot: &mut Robot<f64, N, V>,
    req: &EffectRequest,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<Vec<Param>> {
    let Some(mean) = mean_temperature(data) else {
        crate::refuse!(
            "--effect thermal-expansion: the data need a temp_c column with the arm's \
             temperature (°C) on every row"
        );
    };
    if robot.effects().thermal().is_some() {
        crate::refuse!("--effect thermal-expansion: the robot file has the term already");
    }
    let reference = req.arg.unwrap_or(mean);
    let first = robot.effects().values().len();
    robot
        .effects_mut()
        .push(EffectKind::Thermal, 0, N, 1, reference, 0.0, &[0.0])
        .map_err(|e| anyhow::anyhow!("cannot add thermal-expansion: {e:?}"))?;
    Ok(vec![Param::Effect(first as u16)])
}

impl RobotFile {
    /// Gives a thermal-expansion term without `reference_c` the reference `mean` (°C, the
    /// identification data's mean temperature); true when it did (the model must be rebuilt).
    pub fn with_thermal_reference(&mut self, mean: Option<f64>) -> bool {
        let Some(mean) = mean else {
            return false;
        };
        let mut changed = false;
        for e in self.effects.iter_mut() {
            if e.kind == THERMAL && e.reference_c.is_none() {
                e.reference_c = Some(mean);
                changed = true;
            }
        }
        changed
    }
}
