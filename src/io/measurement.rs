//! One measured pose: joint readings and the point the tracker saw.

use crate::Real;
use nalgebra::Vector3;

/// Joint readings `q` (rad) and the measured point (mm, measurement frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement<T: Real, const N: usize> {
    /// Joint readings, rad (as the controller reports them, before couplings).
    pub q: [T; N],
    /// Measured point, mm, in the measurement frame.
    pub point: Vector3<T>,
}

impl<T: Real, const N: usize> Default for Measurement<T, N> {
    fn default() -> Self {
        Self {
            q: [T::zero(); N],
            point: Vector3::zeros(),
        }
    }
}

impl<T: Real, const N: usize> Measurement<T, N> {
    /// From file units: joint readings in degrees, point in millimetres.
    pub fn from_deg(q_deg: &[f64; N], xyz: &[f64; 3]) -> Self {
        Self {
            q: q_deg.map(|d| T::of(d.to_radians())),
            point: Vector3::new(T::of(xyz[0]), T::of(xyz[1]), T::of(xyz[2])),
        }
    }

    /// True when every number is finite.
    pub fn is_finite(&self) -> bool {
        self.q.iter().all(|v| v.finite()) && self.point.iter().all(|v| v.finite())
    }
}
