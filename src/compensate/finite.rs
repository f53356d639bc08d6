//! Finiteness tests cheap enough for the servo loop, and damping that stays finite.

use crate::Real;

/// `x − x`: 0 for a finite `x`, NaN for ±∞ and NaN.
#[allow(clippy::eq_op)] // the subtraction is the test
#[inline(always)]
pub(super) fn nan_unless_finite<T: Real>(x: T) -> T {
    x - x
}

/// True for a finite `x`, by [`nan_unless_finite`]: two floating-point instructions, where the
/// bit test of [`Real::finite`] takes about a dozen integer ones on a Cortex-M4F (the checks
/// run several times per Newton step).
#[inline(always)]
pub(super) fn finite<T: Real>(x: T) -> bool {
    nan_unless_finite(x) == T::zero()
}

/// True when every value is finite (one non-finite value makes the sum NaN; the sum of
/// zeros cannot overflow).
#[inline(always)]
pub(super) fn all_finite<T: Real>(v: &[T]) -> bool {
    v.iter().fold(T::zero(), |s, x| s + nan_unless_finite(*x)) == T::zero()
}

/// Ten times more damping after a failed step, capped so that it stays finite.
pub(super) fn stiffer<T: Real>(mu: T) -> T {
    if mu < T::of(1e12) {
        mu * T::of(10.0)
    } else {
        mu
    }
}
