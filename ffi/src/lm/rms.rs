//! The RMS position error of a model over measurements (`kc_rms_error`).

use super::measurement::{kc_measurement, measurements};
use crate::handle;
use crate::robot::{each_robot, kc_robot, Arm};
use crate::{kc_status, obj_mut, status, Kc, KC_NOT_FINITE, KC_TOO_FEW_MEASUREMENTS};
use kinecal::identify::lm::rms_error;
use kinecal::Observation;

/// Root-mean-square position error (mm, 3-D distance per pose) of `r` over the `n`
/// measurements `data` into `*rms_mm`. Errors: `KC_TOO_FEW_MEASUREMENTS` (`n` = 0),
/// `KC_NOT_FINITE` (a measurement holds NaN or infinity).
///
/// # Safety
/// `r` NULL or valid; `data` NULL or `n` values; `rms_mm` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_rms_error(
    r: *const kc_robot,
    data: *const kc_measurement,
    n: usize,
    rms_mm: *mut f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        let data = unsafe { measurements(data, n) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(rms_mm) }?;
        if data.is_empty() {
            return Err(KC_TOO_FEW_MEASUREMENTS);
        }
        *out = each_robot!(robot, m => rms(m, data))?;
        Ok(())
    })())
}

/// The RMS error of `robot` over the measurements (`KC_NOT_FINITE` for a NaN in them).
fn rms<const N: usize>(robot: &Arm<N>, data: &[kc_measurement]) -> Kc<f32>
where
    kc_measurement: Observation<f32, N>,
{
    if !data.iter().all(|d| d.is_valid()) {
        return Err(KC_NOT_FINITE);
    }
    Ok(rms_error(robot, data))
}
