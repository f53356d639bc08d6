//! One measured pose as the C caller passes it (`kc_measurement`), read by the solver in place.

use crate::{slice_ref, Kc, KC_MAX_JOINTS};
use kinecal::Observation;
use nalgebra::Vector3;

/// One measured pose: joint readings (rad, as the controller reports them) and the point the
/// tracker saw (mm, measurement frame): a plain position observation of the first tool point,
/// read by the solver in place.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_measurement {
    /// Joint readings, rad: the robot's joints first (a 6-joint robot ignores the last).
    pub q: [f32; KC_MAX_JOINTS],
    /// Measured point, mm.
    pub xyz_mm: [f32; 3],
}

impl kc_measurement {
    /// The readings of an `N`-joint robot (`N` <= `KC_MAX_JOINTS`: the only counts used).
    #[inline(always)]
    fn readings<const N: usize>(&self) -> &[f32; N] {
        const { assert!(N <= KC_MAX_JOINTS) };
        // SAFETY: `q` holds KC_MAX_JOINTS >= N floats (asserted at compile time), so its first
        // N form an `[f32; N]` with the same alignment, borrowed as long as `self`.
        unsafe { &*self.q.as_ptr().cast::<[f32; N]>() }
    }
}

impl Observation<f32, 6> for kc_measurement {
    #[inline(always)]
    fn q(&self) -> &[f32; 6] {
        self.readings()
    }
    #[inline(always)]
    fn point(&self) -> Vector3<f32> {
        Vector3::new(self.xyz_mm[0], self.xyz_mm[1], self.xyz_mm[2])
    }
    fn is_valid(&self) -> bool {
        self.readings::<6>()
            .iter()
            .chain(&self.xyz_mm)
            .all(|v| v.is_finite())
    }
}

impl Observation<f32, 7> for kc_measurement {
    #[inline(always)]
    fn q(&self) -> &[f32; 7] {
        self.readings()
    }
    #[inline(always)]
    fn point(&self) -> Vector3<f32> {
        Vector3::new(self.xyz_mm[0], self.xyz_mm[1], self.xyz_mm[2])
    }
    fn is_valid(&self) -> bool {
        self.readings::<7>()
            .iter()
            .chain(&self.xyz_mm)
            .all(|v| v.is_finite())
    }
}

/// The caller's measurements, in place.
///
/// # Safety
/// `data` is NULL or points to `n` readable `kc_measurement` not written during the borrow.
#[inline(always)]
pub(super) unsafe fn measurements<'a>(
    data: *const kc_measurement,
    n: usize,
) -> Kc<&'a [kc_measurement]> {
    // SAFETY: the caller's contract.
    unsafe { slice_ref(data, n) }
}
