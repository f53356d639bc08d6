//! The `check` hint for joint columns in another order or with another sign than the robot
//! file's joints: a map or an export that puts `q3` where `q2` belongs, or a controller that
//! counts a joint the other way. Such data look like a robot a metre off everywhere (an ER20
//! with `q2` and `q3` exchanged: 1,080 mm), which `check` reported with no hint. [`detect`]
//! tries every pair of joint columns exchanged and every joint's reading negated, places each
//! like `check` places the nominal model ([`super::coupling_hint::rms_placed`]), and reports
//! the one that explains the data far better than the file as written, by the rule of the
//! coupling hint ([`super::coupling_hint::MAX_FRACTION`], [`super::coupling_hint::MIN_GAIN_MM`]).

use super::coupling_hint::{rms_placed, sample, MAX_FRACTION, MIN_GAIN_MM};
use crate::output::numfmt::sig;
use kinecal::{Measurement, Robot};
use serde::Serialize;

/// What was done to the joint columns.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Change {
    /// Two columns exchanged (1-based joints).
    Exchanged(usize, usize),
    /// A column negated (1-based joint).
    Negated(usize),
}

/// Joint columns read another way that explain the data far better than the file as written.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ColumnHint {
    pub change: Change,
    /// RMS (mm) of the nominal model on the columns so changed, and as written.
    pub rms_mm: f64,
    pub nominal_rms_mm: f64,
}

impl ColumnHint {
    /// The one-line hint `kinecal check` prints for the data file `data`.
    pub fn message(&self, data: &str) -> String {
        let (fits, written) = (sig(self.rms_mm, 3), sig(self.nominal_rms_mm, 3));
        match self.change {
            Change::Exchanged(a, b) => format!(
                "hint: {data}: the data fit the nominal robot to {fits} mm with columns q{a} and \
                 q{b} exchanged ({written} mm as written): the joint columns are in another \
                 order than the robot file's joints; exchange them (or the --map's q{a} and \
                 q{b} entries)"
            ),
            Change::Negated(j) => format!(
                "hint: {data}: the data fit the nominal robot to {fits} mm with q{j} negated \
                 ({written} mm as written): the data count joint {j} the other way round from \
                 the robot file; negate the column (or check the robot file's row {j})"
            ),
        }
    }
}

/// The exchange of two joint columns, or the negation of one, that explains `data` far better
/// than `robot` as written (at most [`MAX_FRACTION`] of its RMS, at least [`MIN_GAIN_MM`]
/// better, and at most [`MOST_RMS_MM`]), the best of them; `fit_base` and `tool_unknown` as for
/// the coupling hint.
pub fn detect<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    fit_base: bool,
    tool_unknown: bool,
) -> Option<ColumnHint> {
    let sample = sample(data)?;
    let nominal = rms_placed(robot, &sample, fit_base, tool_unknown)?;
    let mut changes: Vec<Change> = Vec::new();
    for a in 0..N {
        for b in a + 1..N {
            changes.push(Change::Exchanged(a + 1, b + 1));
        }
    }
    changes.extend((0..N).map(|j| Change::Negated(j + 1)));
    let mut best: Option<ColumnHint> = None;
    for change in changes {
        let changed: Vec<Measurement<f64, N>> = sample
            .iter()
            .map(|m| {
                let mut m = *m;
                match change {
                    Change::Exchanged(a, b) => m.q.swap(a - 1, b - 1),
                    Change::Negated(j) => m.q[j - 1] = -m.q[j - 1],
                }
                m
            })
            .collect();
        let Some(rms) = rms_placed(robot, &changed, fit_base, tool_unknown) else {
            continue;
        };
        if best.as_ref().is_none_or(|b| rms < b.rms_mm) {
            best = Some(ColumnHint {
                change,
                rms_mm: rms,
                nominal_rms_mm: nominal,
            });
        }
    }
    best.filter(|b| {
        b.rms_mm <= MAX_FRACTION * nominal
            && nominal - b.rms_mm >= MIN_GAIN_MM
            && b.rms_mm <= MOST_RMS_MM
    })
}

/// The RMS (mm) the columns so changed must leave at most: what a robot file leaves on its own
/// arm before calibration (the UR10 5.6 mm, an ER20 with geometric errors 3 mm), with room; a
/// change that only brings the data closer (mirrored points with q1 negated: 244 mm) explains
/// nothing.
pub const MOST_RMS_MM: f64 = 25.0;
