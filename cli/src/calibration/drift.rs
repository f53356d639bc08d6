//! The `base-drift` term on the command line and in identification: the base (the robot as
//! the tracker sees it) translates by `v·(t − t0)` at a row's `t_s` (`docs/formats.md#effects`).
//!
//! It is the measuring session's, not the arm's: identification estimates it with the model
//! and reports it, and the model written leaves it out (a model applied to another session,
//! or compensating on the controller, must not move with last month's clock). Its reference
//! time `t0` is the identification data's mean time, so that the drift does not trade with
//! the base position.

use super::EffectRequest;
use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal::{Measurement, Robot};

/// The effect id.
pub const DRIFT: &str = EffectKind::Drift.id();

/// `--effect base-drift` or `base-drift:0`; `None` for any other effect.
pub fn parse_request(s: &str) -> Option<anyhow::Result<EffectRequest>> {
    let rest = s.strip_prefix(DRIFT)?;
    if !(rest.is_empty() || rest.starts_with(':')) {
        return None;
    }
    let r = match rest {
        "" | ":0" => Ok(EffectRequest {
            kind: DRIFT.to_string(),
            joint: 0,
            arg: None,
        }),
        _ => Err(anyhow::anyhow!(
            "--effect {s}: expected base-drift or base-drift:0 (it acts on no joint; its \
             reference time is the data's mean t_s)"
        )),
    };
    Some(r)
}

/// Mean time (s) of `data` when every observation has one and they span a positive time:
/// the reference of a base-drift term.
pub fn mean_time<const N: usize>(data: &[Measurement<f64, N>]) -> Option<f64> {
    crate::calibration::stats::mean_if_spread(data.iter().map(|m| m.time_s), |span| span > 0.0)
}

/// Adds a base-drift term at `v = 0` to `robot`, referred to the mean time of `data`; returns
/// its three parameters. Refused without a time on every row.
pub fn add<const N: usize, V: kinecal::ValueStorage>(
    robot: &mut Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<Vec<Param>> {
    let Some(mean) = mean_time(data) else {
        let without = data.iter().filter(|m| m.time_s.is_none()).count();
        crate::refuse!(
            "--effect base-drift: the data need each row's time in seconds in a t_s column, on \
             every row and not all the same ({without} of {} rows have none: an empty cell, or \
             not a number such as a date, which a --map file's [units] time reads)",
            data.len()
        );
    };
    if robot.effects().drift().is_some() {
        crate::refuse!("--effect base-drift: the model has the term already");
    }
    let first = robot.effects().values().len();
    robot
        .effects_mut()
        .push(EffectKind::Drift, 0, N, 1, mean, 0.0, &[0.0; 3])
        .map_err(|e| anyhow::anyhow!("cannot add base-drift: {e:?}"))?;
    Ok((first..first + 3)
        .map(|k| Param::Effect(k as u16))
        .collect())
}
