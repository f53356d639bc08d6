//! The scalar type: `f32` on a Cortex-M4F, `f64` on the desktop, one code path for both.

use nalgebra::RealField;

/// A floating-point scalar the kinematics can run in.
///
/// Adds to nalgebra's [`RealField`] the two things calibration code needs everywhere:
/// exact conversion from the `f64` constants of file formats, and a joint-angle `sin_cos`
/// that is cheap on an FPU without double precision (see [`crate::num::trig`]).
pub trait Real: RealField + Copy + Default + core::fmt::Debug + 'static {
    /// Converts an `f64` (rounding to nearest for `f32`).
    fn of(x: f64) -> Self;
    /// Widens to `f64` for reporting and cross-checks.
    fn to_f64(self) -> f64;
    /// `(sin x, cos x)` for joint angles; accurate to a few ulp for |x| below ~1e4 rad.
    fn sincos(self) -> (Self, Self);
    /// Machine epsilon.
    const EPS: Self;
    /// True for IEEE finite values (not NaN, not infinite).
    fn finite(self) -> bool;
}

impl Real for f32 {
    #[inline(always)]
    fn of(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn sincos(self) -> (Self, Self) {
        crate::num::trig::sincos_f32(self)
    }
    const EPS: Self = f32::EPSILON;
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Real for f64 {
    #[inline(always)]
    fn of(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sincos(self) -> (Self, Self) {
        crate::num::trig::sincos_f64(self)
    }
    const EPS: Self = f64::EPSILON;
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
}
