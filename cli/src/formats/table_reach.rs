//! Joint tables whose knots miss the data's readings.
//!
//! A `joint-table` effect holds values at knots `start + k · step` of the joint's reading; a
//! reading outside the knots gets the end value. A `start_deg` shifted by a turn (360°), or
//! written in another unit, leaves every reading outside: the model then applies one constant
//! where it was fitted to a curve, and `check` or `validate` report only a larger error.

use crate::formats::measurements::Dataset;
use crate::output::numfmt::sig;
use kinecal::model::effects::EffectKind;
use kinecal::Robot;

/// Below this share of a joint's readings within its table's knots a file is warned about.
pub const MIN_SHARE: f64 = 0.5;

/// The warning for the first table of `model` (its file named `model_origin`) whose knots
/// hold fewer than [`MIN_SHARE`] of the readings of its joint in `ds` (named `origin`), or
/// `None`.
pub fn warning<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    model: &Robot<f64, N, V>,
    origin: &str,
    model_origin: &str,
) -> Option<String> {
    if ds.records.is_empty() {
        return None;
    }
    model
        .effects()
        .iter()
        .filter(|e| e.kind == EffectKind::Table && e.len >= 2 && usize::from(e.joint) < N)
        .find_map(|e| {
            let j = usize::from(e.joint);
            let (lo, hi) = (
                e.knot(0).to_degrees(),
                e.knot(usize::from(e.len) - 1).to_degrees(),
            );
            let readings: Vec<f64> = ds.records.iter().map(|r| r.q_deg[j]).collect();
            let inside = readings.iter().filter(|q| **q >= lo && **q <= hi).count();
            if inside as f64 >= MIN_SHARE * readings.len() as f64 {
                return None;
            }
            let (min, max) = readings
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), q| {
                    (a.min(*q), b.max(*q))
                });
            Some(format!(
                "warning: {origin}: joint {}'s table in {model_origin} covers {}° to {}°, but {inside} of {} \
                 readings of joint {} ({}° to {}°) fall in it and the others get its end value: \
                 check its start_deg (degrees of the joint's reading)",
                j + 1,
                sig(lo, 5),
                sig(hi, 5),
                readings.len(),
                j + 1,
                sig(min, 5),
                sig(max, 5)
            ))
        })
}
