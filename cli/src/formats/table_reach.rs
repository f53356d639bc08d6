//! Joint tables whose knots miss the data's readings.
//!
//! A `joint-table` effect holds values at knots `start + k · step` of the joint's reading; a
//! reading outside the knots gets the end value. A `start_deg` shifted by a turn (360°) leaves
//! every reading outside: the model then applies one constant where it was fitted to a curve,
//! and `check` or `validate` report only a larger error. A session that moves the joint over
//! other angles than the one the table was fitted on is no mistake, but its readings outside
//! the knots are not corrected by the table either: said as a note, with no cause claimed.

use crate::formats::measurements::Dataset;
use kinecal::model::effects::{Effect, EffectKind};
use kinecal::Robot;

/// Below this share of a joint's readings within its table's knots a file is told about.
pub const MIN_SHARE: f64 = 0.5;

/// One line per table of `model` (its file named `model_origin`, if given) whose knots hold
/// fewer than [`MIN_SHARE`] of the readings of its joint in `ds` (named `origin`): a warning
/// naming `start_deg` when the knots of a slipped `start_deg` (one or two turns off, the sign
/// lost, radians) would hold at least half of them, a note otherwise.
pub fn lines<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    model: &Robot<f64, N, V>,
    origin: &str,
    model_origin: Option<&str>,
) -> Vec<String> {
    lines_except(ds, model, (origin, model_origin), |_| false)
}

/// Whether `nominal` (the robot file, whose tables the loader told about) has a table with the
/// same knots as `e`: the filter of [`lines_except`] for a calibrated model read beside it.
pub fn in_robot_file<const N: usize, V: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
) -> impl Fn(&Effect<f64>) -> bool + '_ {
    move |e| {
        nominal.effects().iter().any(|n| {
            (n.kind, n.joint, n.start, n.step, n.len) == (e.kind, e.joint, e.start, e.step, e.len)
        })
    }
}

/// [`lines`] for the tables of `model` that `told` does not pass over (those with the same
/// knots as a table already told about, in the robot file read beside a calibrated model).
pub fn lines_except<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    model: &Robot<f64, N, V>,
    (origin, model_origin): (&str, Option<&str>),
    told: impl Fn(&Effect<f64>) -> bool,
) -> Vec<String> {
    if ds.records.is_empty() {
        return Vec::new();
    }
    let of = model_origin.map_or(String::new(), |m| format!(" in {m}"));
    let ranges = ds.joint_ranges_deg();
    model
        .effects()
        .iter()
        .filter(|e| e.kind == EffectKind::Table && e.len >= 2 && usize::from(e.joint) < N)
        .filter(|e| !told(e))
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
            let (min, max) = ranges[j];
            let (count, joint) = (readings.len(), j + 1);
            let head = format!(
                "{origin}: joint {joint}'s table{of} covers {lo:.1}° to {hi:.1}°, but {inside} of \
                 {count} readings of joint {joint} ({min:.1}° to {max:.1}°) fall in it"
            );
            // The start_deg a slip would have written instead of the one meant: a whole number
            // of turns off, its sign lost, or the value in radians. The one that holds the most
            // readings, if at least half.
            let slips = [
                (lo - 720.0, "two turns lower"),
                (lo - 360.0, "a turn lower"),
                (lo + 360.0, "a turn higher"),
                (lo + 720.0, "two turns higher"),
                (-lo, "with the other sign"),
                (lo.to_degrees(), "read as radians"),
            ];
            let meant = slips
                .into_iter()
                .filter(|(start, _)| start.is_finite())
                .map(|(start, how)| (start, how, within(start - lo)))
                .filter(|(_, _, n)| !few(*n))
                .max_by_key(|(_, _, n)| *n);
            Some(match meant {
                Some((start, how, n)) => format!(
                    "warning: {head}; {n} would with start_deg {start:.1} ({how}): check its \
                     start_deg"
                ),
                None => format!("note: {head}: the others get its end value"),
            })
        })
        .collect()
}
