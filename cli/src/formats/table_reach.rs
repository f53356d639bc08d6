//! Joint tables whose knots miss the data's readings.
//!
//! A `joint-table` effect holds values at knots `start + k · step` of the joint's reading; a
//! reading outside the knots gets the end value. A `start_deg` shifted by a turn (360°) leaves
//! every reading outside: the model then applies one constant where it was fitted to a curve,
//! and `check` or `validate` report only a larger error. A session that moves the joint over
//! other angles than the one the table was fitted on is no mistake, but its readings outside
//! the knots are not corrected by the table either: said as a note.

use crate::formats::measurements::Dataset;
use kinecal::model::effects::EffectKind;
use kinecal::Robot;

/// Below this share of a joint's readings within its table's knots a file is told about.
pub const MIN_SHARE: f64 = 0.5;

/// One line per table of `model` (its file named `model_origin`, if given) whose knots hold
/// fewer than [`MIN_SHARE`] of the readings of its joint in `ds` (named `origin`): a warning
/// naming `start_deg` when the knots a whole number of turns away would hold most of them, a
/// note otherwise.
pub fn lines<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    model: &Robot<f64, N, V>,
    origin: &str,
    model_origin: Option<&str>,
) -> Vec<String> {
    if ds.records.is_empty() {
        return Vec::new();
    }
    let of = model_origin.map_or(String::new(), |m| format!(" in {m}"));
    model
        .effects()
        .iter()
        .filter(|e| e.kind == EffectKind::Table && e.len >= 2 && usize::from(e.joint) < N)
        .filter_map(|e| {
            let j = usize::from(e.joint);
            let (lo, hi) = (
                e.knot(0).to_degrees(),
                e.knot(usize::from(e.len) - 1).to_degrees(),
            );
            let readings: Vec<f64> = ds.records.iter().map(|r| r.q_deg[j]).collect();
            let within = |shift: f64| {
                readings
                    .iter()
                    .filter(|q| **q >= lo + shift && **q <= hi + shift)
                    .count()
            };
            let few = |n: usize| (n as f64) < MIN_SHARE * readings.len() as f64;
            let inside = within(0.0);
            if !few(inside) {
                return None;
            }
            let (min, max) = readings
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), q| {
                    (a.min(*q), b.max(*q))
                });
            let (count, joint) = (readings.len(), j + 1);
            let head = format!(
                "{origin}: joint {joint}'s table{of} covers {lo:.1}° to {hi:.1}°, but {inside} of \
                 {count} readings of joint {joint} ({min:.1}° to {max:.1}°) fall in it"
            );
            // The knots a whole number of turns away that would hold most readings.
            let turned = [-720.0, -360.0, 360.0, 720.0]
                .into_iter()
                .map(|s| (s, within(s)))
                .filter(|(_, n)| !few(*n))
                .max_by_key(|(_, n)| *n);
            Some(match turned {
                Some((shift, n)) => format!(
                    "warning: {head}; {n} would with start_deg {:.1} ({shift:+}°): check its \
                     start_deg",
                    lo + shift
                ),
                None => format!(
                    "note: {head}: the others get its end value (the table was fitted on other \
                     angles of the joint)"
                ),
            })
        })
        .collect()
}
