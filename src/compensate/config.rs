//! Tuning of the Newton iteration and of its safety checks.

use super::finite::finite;
use crate::Real;

/// Tuning of the Newton iteration and of the safety checks.
///
/// The defaults suit an industrial arm with seeds within a degree of the answer: from 0.3° off
/// they converge to ~10 nm in `f64` in 2–3 steps, and to the `f32` rounding floor of the
/// model's point (a few tenths of a micrometre at 3 m from the tracker) in 2–3 steps in `f32`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config<T: Real> {
    /// Most Newton steps per call; each costs one forward kinematics. Default 8.
    pub iterations: u8,
    /// Damping floor λ₀ (mm). Each step solves with λ² = μ·(λ₀² + |r|²): the residual term
    /// (Sugihara's) shortens steps towards far or singular targets and vanishes at convergence,
    /// so the converged answer is not biased. Default 0.1 mm.
    pub damping: T,
    /// Stop early once the residual is below this (mm, orientation scaled). Default 1e-5 mm
    /// (10 nm: far below any robot's repeatability, reached in 2–3 steps from 0.3° off).
    pub tolerance: T,
    /// A residual above this after the iterations is not a success (mm, orientation scaled).
    /// Default 0.01 mm, ten times below a laser tracker's noise.
    pub accept: T,
    /// Per-joint bound on |command − seed| (rad): the largest correction the controller
    /// accepts. Default 2° (0.0349 rad).
    pub max_step: T,
    /// Length scale (mm per rad) that makes orientation error comparable to position error in pose
    /// targets; `None` uses [`Robot::reach`](crate::Robot::reach), the scale identification uses.
    /// Default None.
    pub orientation_scale: Option<T>,
    /// Singular when the scaled Jacobian's conditioning σ_h (see
    /// [`Solution::sigma`](super::Solution::sigma)) falls below `singular · reach` (mm/rad).
    /// Default 0.01: at a 2 m reach, 20 mm/rad, i.e. a 1 mm correction would need ~3° along the
    /// weakest direction. About 1–2° from a wrist singularity for pose targets.
    pub singular: T,
    /// The arm's temperature (°C, from the controller's sensor) for a model with a
    /// thermal-expansion term: the model is evaluated with its lengths expanded to it. `None`:
    /// at the term's reference temperature. Default None.
    pub temperature_c: Option<T>,
}

/// The coldest and warmest arm temperature (°C) a compensation takes: no robot works colder or
/// warmer (the command line refuses such a `temp_c` too).
pub const MIN_TEMP_C: f64 = -40.0;
/// See [`MIN_TEMP_C`].
pub const MAX_TEMP_C: f64 = 150.0;

impl<T: Real> Default for Config<T> {
    fn default() -> Self {
        Self {
            iterations: 8,
            damping: T::of(0.1),
            tolerance: T::of(1e-5),
            accept: T::of(0.01),
            max_step: T::of(2f64.to_radians()),
            orientation_scale: None,
            singular: T::of(0.01),
            temperature_c: None,
        }
    }
}

impl<T: Real> Config<T> {
    /// True when every setting is finite and in range.
    /// Whether every setting is usable: finite, the limits positive, a temperature within
    /// [`MIN_TEMP_C`]..=[`MAX_TEMP_C`] (a sensor reading outside is broken or in another unit,
    /// and the thermal term would move the command by millimetres).
    pub fn is_valid(&self) -> bool {
        let nonneg = |x: T| finite(x) && x >= T::zero();
        let pos = |x: T| finite(x) && x > T::zero();
        nonneg(self.damping)
            && nonneg(self.tolerance)
            && pos(self.accept)
            && pos(self.max_step)
            && nonneg(self.singular)
            && self.orientation_scale.is_none_or(pos)
            && self
                .temperature_c
                .is_none_or(|t| finite(t) && t >= T::of(MIN_TEMP_C) && t <= T::of(MAX_TEMP_C))
    }
}
