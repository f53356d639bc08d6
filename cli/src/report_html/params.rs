//! The parameter table: every parameter of the identified model with its nominal value, the
//! calibrated one, the change, the 1-σ from the covariance and, for what was not estimated,
//! why; and the strongest correlations of the estimates.
//!
//! The 1-σ, the held parameters and the correlations are those of
//! [`crate::calibration::fit_lm`] run from the identified model on the identification data
//! (its identifiability analysis and covariance `s²(JᵀWJ)⁻¹`, as `identify` reports them).

use crate::calibration::{named_values, Correlation, Fit};
use crate::output::numfmt::sig;
use crate::HostRobot;
use crate::HostValues;
use kinecal::model::param::Param;
use serde::Serialize;

/// Whether a parameter was estimated.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Estimated,
    /// Held at its nominal value: the data cannot determine it (`confounded_with` empty: no
    /// observation moves with it).
    Held {
        confounded_with: Vec<String>,
    },
    /// Not a parameter of the fit (a `[base]` the robot file gives, `--fix`).
    Fixed,
}

/// One row of the table (values in file units: mm, degrees, raw for effect values).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamRow {
    pub name: String,
    pub unit: &'static str,
    pub nominal: f64,
    pub calibrated: f64,
    pub change: f64,
    pub sigma: Option<f64>,
    pub status: Status,
}

impl ParamRow {
    /// The row's cells as the page prints them (the digits of `identify`'s text).
    pub fn cells(&self) -> [String; 4] {
        [
            sig(self.nominal, 7),
            sig(self.calibrated, 7),
            sig(self.change, 3),
            self.sigma.map_or("-".into(), |s| sig(s, 2)),
        ]
    }

    /// Why it was not estimated, in words.
    pub fn reason(&self) -> String {
        match &self.status {
            Status::Estimated => String::new(),
            Status::Held { confounded_with } if confounded_with.is_empty() => {
                "no observation moves with it (unidentifiable)".into()
            }
            Status::Held { confounded_with } => {
                format!("confounded with {}", confounded_with.join(", "))
            }
            Status::Fixed => "not estimated (given by the robot file or held by the caller)".into(),
        }
    }
}

/// The rows of every parameter in `all`, with `fit` (from the model over the identification
/// data) for 1-σ and what was held, `estimated` the parameters the fit was given.
pub fn table<const N: usize>(
    nominal: &HostRobot<N>,
    model: &HostRobot<N>,
    all: &[Param],
    estimated: &[Param],
    fit: &Fit<N, HostValues>,
) -> Vec<ParamRow> {
    let from = named_values(nominal, all);
    let to = named_values(model, all);
    all.iter()
        .filter_map(|p| {
            let name = p.name(model).to_string();
            // An effect the robot file does not carry (added by `identify --effect`) is zero
            // in the nominal robot.
            let a = from
                .get(&name)
                .copied()
                .or(matches!(p, Param::Effect(_)).then_some(0.0))?;
            let b = *to.get(&name)?;
            let status = if let Some(h) = fit.held.iter().find(|h| h.name == name) {
                Status::Held {
                    confounded_with: h.confounded_with.clone(),
                }
            } else if estimated.contains(p) {
                Status::Estimated
            } else {
                Status::Fixed
            };
            Some(ParamRow {
                unit: match p {
                    Param::Effect(_) => "",
                    p if p.is_length() => "mm",
                    _ => "°",
                },
                sigma: fit.sigma.get(&name).copied(),
                nominal: a,
                calibrated: b,
                change: b - a,
                name,
                status,
            })
        })
        .collect()
}

/// The correlations as the page prints them: `(a, b, r)` with r to 3 decimals.
pub fn correlation_cells(c: &[Correlation]) -> Vec<[String; 3]> {
    c.iter()
        .map(|c| [c.a.clone(), c.b.clone(), format!("{:+.3}", c.r)])
        .collect()
}
