//! Where a [`crate::identify::lm::Levenberg`] run stands and why it stopped or refused a call:
//! the types its callers (and its passes) share.

use super::penalty::PenaltyError;
use crate::model::param::ParamError;
use crate::Real;

/// Why the solver refused a call.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LmError {
    /// The settings cannot run ([`LmConfig::is_valid`](crate::identify::lm::LmConfig::is_valid)):
    /// a damping that is not above zero, a non-finite number, a tolerance out of range.
    Config,
    /// No measurements, or fewer residuals than active parameters.
    TooFewMeasurements,
    /// The measurement slice changed length between calls.
    DataChanged,
    /// A measurement holds NaN or infinity (or a negative weight, or an orientation that is
    /// no rotation).
    NonFiniteMeasurement,
    /// A measurement names a tool point the robot does not have.
    UnknownToolPoint,
    /// The parameter set does not fit the robot or the capacity.
    Params(ParamError),
    /// Parts handed to [`Levenberg::complete_pass`](crate::identify::lm::Levenberg::complete_pass) are not of the pending pass, do not cover
    /// the data once, or hold other parameters; or no pass is pending.
    PassMismatch,
    /// The penalty does not fit the parameters, or holds a negative or non-finite number.
    Penalty(PenaltyError),
    /// [`Levenberg::hold`](crate::identify::lm::Levenberg::hold) after the run started.
    Started,
    /// A constraint group is outside the rows, or its size or numbers do not suit its kind
    /// ([`crate::io::constraint::ConstraintGroup::is_valid`]).
    BadGroup,
}

/// Why the solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LmStop {
    /// The cost stopped decreasing (relative change below tolerance).
    Converged,
    /// The step became negligibly small.
    SmallStep,
    /// The iteration limit was reached.
    MaxIterations,
    /// No step could lower the cost even with very strong damping.
    NoProgress,
}

/// Where a run stands after a [`Levenberg::step`](crate::identify::lm::Levenberg::step) call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmProgress<T: Real> {
    /// Accepted and rejected steps so far.
    pub iteration: u32,
    /// Full passes over all poses so far (model evaluations of all poses).
    pub evaluations: u32,
    /// Sum of squared residuals (mm²) at the current estimate (after the first pass).
    pub cost: T,
    /// `Some` once the run has finished.
    pub stopped: Option<LmStop>,
}
