//! A calibrated model whose angle-valued effect values were written in degrees.
//!
//! A robot file holds `joint-table` knots and `joint-cyclic` amplitudes in radians
//! (docs/formats.md#effects). Written in degrees they are 57.3 times too large: a gear's
//! arc-minute error becomes degrees, the model misses a session by tens of millimetres, and
//! `validate` would only say "recalibrate". Each such effect alone (one whose largest value
//! reads [`SUSPECT_DEG`] or more), and all of them together, is read as degrees (its values × π/180) and the model judged again: a slip makes the model
//! many times better (the UR10's tables written in degrees: 29.6 → 0.705 mm), where an effect
//! that is wrong another way (its sign flipped, four times too large) gains a few times at
//! most, as removing it would.

use crate::HostRobot;
use kinecal::model::effects::{Effect, EffectKind};
use kinecal::Param;

/// Read as degrees, the model's RMS must fall to at most this share of its RMS as written.
pub const GAIN: f64 = 0.1;

/// An effect is suspected only when its largest value reads this many degrees or more: gear
/// transmission errors and eccentricities are arc minutes, while 0.0017 meant as degrees
/// reads as 0.1°.
pub const SUSPECT_DEG: f64 = 0.1;

/// The effects that look written in degrees and the model's position RMS (mm) with them read
/// so.
#[derive(Clone, Debug, PartialEq)]
pub struct InDegrees {
    /// Each effect named as in the reports: `joint 2's joint-table`.
    pub effects: Vec<String>,
    pub rms_mm: f64,
}

/// The effects of `model` whose values read as degrees make it best (`judge`: the position
/// RMS of a variant, `None` when the variant is not acceptable for another reason), when that
/// is at most [`GAIN`] of `model_rms_mm`; `None` otherwise or without suspects.
pub fn best<const N: usize>(
    model: &HostRobot<N>,
    model_rms_mm: f64,
    judge: impl Fn(&HostRobot<N>) -> Option<f64>,
) -> Option<InDegrees> {
    let angles: Vec<&Effect<f64>> = model
        .effects()
        .iter()
        .filter(|e| matches!(e.kind, EffectKind::Table | EffectKind::Cyclic))
        .collect();
    let suspect = |e: &&&Effect<f64>| {
        let values = model.effects().values().get(e.range()).unwrap_or(&[]);
        values.iter().any(|v| v.abs().to_degrees() >= SUSPECT_DEG)
    };
    let mut sets: Vec<Vec<&Effect<f64>>> =
        angles.iter().filter(suspect).map(|e| vec![*e]).collect();
    // A slip of the whole file: every angle-valued effect, the smaller ones too (read as
    // degrees they are a few hundredths of a degree: their values meant as degrees shrink them,
    // right ones would be lost and the set predict worse than a single suspect).
    if !sets.is_empty() && angles.len() > 1 {
        sets.push(angles.clone());
    }
    sets.into_iter()
        .filter_map(|set| {
            let rms = judge(&read_as_degrees(model, &set)?)?;
            (rms <= GAIN * model_rms_mm).then_some((set, rms))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(set, rms_mm)| InDegrees {
            effects: set.iter().map(|e| label(e)).collect(),
            rms_mm,
        })
}

/// `model` with the values of `effects` multiplied by π/180.
fn read_as_degrees<const N: usize>(
    model: &HostRobot<N>,
    effects: &[&Effect<f64>],
) -> Option<HostRobot<N>> {
    let params: Vec<Param> = effects
        .iter()
        .flat_map(|e| e.range())
        .filter_map(|k| u16::try_from(k).ok().map(Param::Effect))
        .collect();
    let delta: Vec<f64> = params
        .iter()
        .map(|p| {
            kinecal::model::param::value(model, *p).unwrap_or(0.0) * (1.0_f64.to_radians() - 1.0)
        })
        .collect();
    let mut m = model.clone();
    kinecal::model::param::apply_delta(&mut m, &params, &delta).ok()?;
    Some(m)
}

/// `joint 2's joint-table`, `joint 3's joint-cyclic of order 2`.
fn label(e: &Effect<f64>) -> String {
    let order = if e.kind == EffectKind::Cyclic && e.order != 1 {
        format!(" of order {}", e.order)
    } else {
        String::new()
    };
    format!("joint {}'s {}{order}", e.joint + 1, e.kind.id())
}
