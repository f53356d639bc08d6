//! What a compensation returns: the command and how well it meets the target, its status
//! class, and the typed errors that still carry the best safe command.

use crate::Real;

/// A joint command and how well it meets the target on the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution<T: Real, const N: usize> {
    /// The joint command (rad): within `max_step` of the seed (to the rounding of seed ±
    /// max_step) and inside the joint limits, except that a seed beyond a limit by more than
    /// `max_step` is moved exactly `max_step` towards it (reported as `Limited`).
    pub q: [T; N],
    /// |target point − model point at `q`| (mm).
    pub position_error: T,
    /// Angle between target and model tool orientation at `q` (rad); 0 for point targets.
    pub orientation_error: T,
    /// Conditioning of the scaled Jacobian at `q` (mm/rad): σ_h = (Σ 1/σ_i²)^(-1/2), a cheap
    /// bound on the smallest singular value, σ_h ≤ σ_min ≤ √m·σ_h (m = 3 or 6 equations).
    pub sigma: T,
    /// Newton steps tried.
    pub iterations: u8,
}

/// Outcome class of one compensation, for logs and the `status` column of `kinecal compensate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// The target is met within [`Config::accept`](super::Config::accept) at a well-conditioned
    /// pose.
    Ok,
    /// [`CompensateError::Singular`].
    Singular,
    /// [`CompensateError::Unreachable`].
    Unreachable,
    /// [`CompensateError::Limited`].
    Limited,
    /// [`CompensateError::InvalidInput`].
    Invalid,
}

impl Status {
    /// Lower-case name: `ok`, `singular`, `unreachable`, `limited`, `invalid`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Singular => "singular",
            Status::Unreachable => "unreachable",
            Status::Limited => "limited",
            Status::Invalid => "invalid",
        }
    }

    /// The class of a compensation result.
    pub fn of<T: Real, const N: usize>(r: &Result<Solution<T, N>, CompensateError<T, N>>) -> Self {
        match r {
            Ok(_) => Status::Ok,
            Err(e) => e.status(),
        }
    }
}

/// Why no command meets the target; all but `InvalidInput` carry the best safe command, which
/// is finite and inside the step box around the seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CompensateError<T: Real, const N: usize> {
    /// A target, seed or configuration value is NaN, infinite or out of range, the target is more
    /// than [`FAR`](super::FAR) × reach from the base (a unit or frame mistake, not a target), a
    /// pose target was given to a robot with fewer than six joints, or
    /// [`Tracker::follow`](super::Tracker::follow) has no previous command. Nothing was computed:
    /// hold the previous command.
    InvalidInput,
    /// The Jacobian at the answer is (nearly) rank-deficient (σ_h below the threshold): a
    /// wrist, shoulder or elbow singularity, or the edge of the workspace. The target may even
    /// be met, but neighbouring targets would need large joint motion.
    Singular(Solution<T, N>),
    /// The residual did not converge and nothing else explains it, or the target lies beyond
    /// the arm's reach (farther from the base than Σ(|a|+|d|) + |tool|).
    Unreachable(Solution<T, N>),
    /// The residual did not converge because a joint limit or the step bound stops the joints
    /// that would reduce it (or the seed lies beyond a joint limit by more than `max_step`).
    /// When the Jacobian is also singular there, `Singular` is reported instead: the
    /// singularity is the cause, the bound only what stopped the resulting large step.
    Limited(Solution<T, N>),
}

impl<T: Real, const N: usize> CompensateError<T, N> {
    /// The best safe command found, if any was computed.
    pub fn best(&self) -> Option<&Solution<T, N>> {
        match self {
            CompensateError::InvalidInput => None,
            CompensateError::Singular(s)
            | CompensateError::Unreachable(s)
            | CompensateError::Limited(s) => Some(s),
        }
    }

    /// The status class of this error.
    pub fn status(&self) -> Status {
        match self {
            CompensateError::InvalidInput => Status::Invalid,
            CompensateError::Singular(_) => Status::Singular,
            CompensateError::Unreachable(_) => Status::Unreachable,
            CompensateError::Limited(_) => Status::Limited,
        }
    }
}
