//! Joint readings a whole turn (360°) from those a model was calibrated on. A joint's scale and
//! its correction table are not periodic in its reading: a controller (or a logger) that wraps
//! readings into ±180°, where the calibration's readings ran beyond (the UR10's joints turn
//! ±360°), puts the same arm pose a turn away, and the model corrects it for the wrong turn.
//! The nominal robot is periodic and does not see it; the model then predicts the session
//! many times worse than it should (a simulated UR10 with a joint-3 scale of 0.001, every
//! reading wrapped: 2.71 mm against 0.035 mm unwrapped, "the model still holds"; host-tests
//! `validate_sessions::readings_a_turn_from_the_calibrations_leave_no_verdict`). [`find`] evaluates each row with each such
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

/// The session's RMS with the rows turned must be at most this share of the model's: chance
/// gains of a small scale on 5 % of the rows move it by a few per cent (UR10, a joint-5 scale
/// on rows of its own session: 0.488 → 0.471 mm), readings wrapped by a turn by half or more
/// (the joint-3 scale above: 2.71 → 0.319 mm).
pub const EXPLAINS: f64 = 0.5;

/// Joints whose readings look a turn away from the model's on many rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Wrapped {
    /// 1-based joint with the most rows a turn away.
    pub joint: usize,
    /// Its effect that is not periodic (`joint-scale`, `joint-table`).
    pub effect: &'static str,
    /// Rows (observations) a turn of that joint brings much closer, and all rows.
    pub rows: usize,
    pub of: usize,
    /// Every joint turned on some row (1-based), the one above first.
    pub joints: Vec<usize>,
    /// The position RMS (mm) of the session with each row's readings turned where that brings
    /// it much closer, and as read.
    pub turned_rms_mm: f64,
    pub rms_mm: f64,
}

/// The joints of `model` (registered on `data`) with a non-periodic effect whose readings are a
/// turn away from the model's: each row has each such joint's reading turned by ±360° (within
/// the joint's limits) where that brings it much closer ([`CLOSER`], [`MIN_GAIN_MM`]), joint
/// after joint; reported when a joint's turns are at least [`MIN_SHARE`] of the rows and the
/// turned session's RMS at most [`EXPLAINS`] of the model's.
pub fn find<const N: usize>(model: &HostRobot<N>, data: &[Measurement<f64, N>]) -> Option<Wrapped> {
    let mut joints: Vec<(usize, &'static str)> = model
        .effects()
        .iter()
        .filter_map(|e| match e.kind {
            EffectKind::Scale | EffectKind::Table => Some((e.joint as usize, e.kind.id())),
            _ => None,
        })
        .collect();
    joints.sort_by_key(|j| j.0);
    joints.dedup_by_key(|j| j.0);
    if joints.is_empty() || data.is_empty() {
        return None;
    }
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut error = |q: &[f64; N], m: &Measurement<f64, N>| -> Option<f64> {
        let p = fk.compute_at(model, q, m.tool as usize, m.conditions())?;
        Some((m.point - p).norm())
    };
    let mut turns = vec![0usize; joints.len()];
    let (mut sq, mut sq_read, mut counted) = (0.0f64, 0.0f64, 0usize);
    for m in data {
        let Some(read) = error(&m.q, m) else { continue };
        let (mut q, mut e) = (m.q, read);
        for (k, &(j, _)) in joints.iter().enumerate() {
            let Some(row) = model.joints().get(j).copied() else {
                continue;
            };
            let best = [TAU, -TAU]
                .iter()
                .filter_map(|turn| {
                    let mut t = q;
                    t[j] += turn;
                    let inside = t[j] >= row.lower && t[j] <= row.upper;
                    inside.then(|| error(&t, m).map(|e| (t, e))).flatten()
                })
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((t, turned)) = best {
                if turned <= CLOSER * e && e - turned >= MIN_GAIN_MM {
                    (q, e) = (t, turned);
                    turns[k] += 1;
                }
            }
        }
        sq += e * e;
        sq_read += read * read;
        counted += 1;
    }
    let (k, &rows) = turns.iter().enumerate().max_by_key(|(_, r)| **r)?;
    let rms = |sq: f64| (sq / counted.max(1) as f64).sqrt();
    let (turned_rms_mm, rms_mm) = (rms(sq), rms(sq_read));
    let enough = rows >= 3 && rows as f64 >= MIN_SHARE * data.len() as f64;
    let mut turned: Vec<usize> = vec![joints[k].0 + 1];
    turned.extend(
        joints
            .iter()
            .zip(&turns)
            .filter(|((j, _), n)| **n > 0 && *j != joints[k].0)
            .map(|((j, _), _)| j + 1),
    );
    (enough && turned_rms_mm <= EXPLAINS * rms_mm).then(|| Wrapped {
        joint: joints[k].0 + 1,
        effect: joints[k].1,
        rows,
        of: data.len(),
        joints: turned,
        turned_rms_mm,
        rms_mm,
    })
}
