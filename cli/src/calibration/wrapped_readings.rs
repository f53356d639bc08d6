//! Joint readings a whole turn (360°) from those a model was calibrated on. A joint's scale and
//! its correction table are not periodic in its reading: a controller (or a logger) that wraps
//! readings into ±180°, where the calibration's readings ran beyond (the UR10's joints turn
//! ±360°), puts the same arm pose a turn away, and the model corrects it for the wrong turn.
//! The nominal robot is periodic and does not see it; the model then predicts the session
//! several times worse than it should (UR10 series B with every reading wrapped: 0.382 mm
//! against 0.095 mm, "the model still holds"). [`find`] evaluates each row with each such
//! joint's reading moved by a turn either way (within the joint's limits) and counts the rows
//! that the turn brings much closer.

use crate::HostRobot;
use kinecal::model::effects::EffectKind;
use kinecal::{ForwardKinematics, Measurement};
use std::f64::consts::TAU;

/// A row counts as a turn away when the turn leaves it at most this share of its error...
pub const CLOSER: f64 = 0.5;
/// ... and brings it closer by at least this much (mm): a turn that moves the point by
/// micrometres says nothing.
pub const MIN_GAIN_MM: f64 = 0.02;
/// The rows a turn away must be at least this share of the session (and at least 3) to be
/// reported: a few rows near a table's end may gain by chance.
pub const MIN_SHARE: f64 = 0.05;

/// A joint whose readings look a turn away from the model's on many rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Wrapped {
    /// 1-based joint.
    pub joint: usize,
    /// The effect that is not periodic (`joint-scale`, `joint-table`).
    pub effect: &'static str,
    /// Rows (observations) a turn brings much closer, and all rows.
    pub rows: usize,
    pub of: usize,
    /// The position RMS (mm) of the session with each such row's reading turned.
    pub turned_rms_mm: f64,
}

/// The joint of `model` (registered on `data`) with a non-periodic effect whose readings are a
/// turn away from the model's on the most rows, when they are at least [`MIN_SHARE`] of them.
pub fn find<const N: usize>(model: &HostRobot<N>, data: &[Measurement<f64, N>]) -> Option<Wrapped> {
    let joints: Vec<(usize, &'static str)> = model
        .effects()
        .iter()
        .filter_map(|e| match e.kind {
            EffectKind::Scale | EffectKind::Table => Some((e.joint as usize, e.kind.id())),
            _ => None,
        })
        .collect();
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut error = |q: &[f64; N], m: &Measurement<f64, N>| -> Option<f64> {
        let p = fk.compute_at(model, q, m.tool as usize, m.conditions())?;
        Some((m.point - p).norm())
    };
    let errors: Vec<Option<f64>> = data.iter().map(|m| error(&m.q, m)).collect();
    let mut best: Option<Wrapped> = None;
    for &(j, effect) in &joints {
        let Some(row) = model.joints().get(j).copied() else {
            continue;
        };
        let (mut rows, mut sq) = (0usize, 0.0f64);
        for (m, e) in data.iter().zip(&errors) {
            let Some(e) = *e else { continue };
            let turned = [TAU, -TAU]
                .iter()
                .filter_map(|turn| {
                    let mut q = m.q;
                    q[j] += turn;
                    (q[j] >= row.lower && q[j] <= row.upper)
                        .then(|| error(&q, m))
                        .flatten()
                })
                .fold(f64::INFINITY, f64::min);
            let closer = turned <= CLOSER * e && e - turned >= MIN_GAIN_MM;
            rows += usize::from(closer);
            let kept = if closer { turned } else { e };
            sq += kept * kept;
        }
        let enough = rows >= 3 && rows as f64 >= MIN_SHARE * data.len() as f64;
        if enough && best.as_ref().is_none_or(|b| rows > b.rows) {
            best = Some(Wrapped {
                joint: j + 1,
                effect,
                rows,
                of: data.len(),
                turned_rms_mm: (sq / data.len().max(1) as f64).sqrt(),
            });
        }
    }
    best
}
