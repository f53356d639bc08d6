//! The C functions of a `kc_lm`: thin shells over the solver code shared with `kc_lm_full`.

use super::config::kc_lm_config;
use super::measurement::kc_measurement;
use super::progress::kc_lm_progress;
use super::snapshot::{lm_restore, lm_save, lm_snapshot_size};
use super::solver::{kc_lm, lm_init};
use super::stepping::{lm_progress, lm_robot, lm_step, lm_unidentifiable};
use crate::robot::{kc_param, kc_robot};
use crate::{kc_status, status};

/// Starts an identification in `lm` from the model `start` (copied), estimating the `n`
/// parameters `params` (1 ..= `KC_LM_MAX_PARAMS`, duplicates ignored) with the settings `cfg`
/// (NULL = defaults). The solver is built in place in `lm`.
///
/// Errors: `KC_NULL_POINTER`, `KC_NOT_INITIALIZED` (`start`), `KC_TOO_MANY_PARAMS`,
/// `KC_INVALID_ARGUMENT` (no parameter, an unknown code or joint, invalid settings),
/// `KC_NOT_FINITE` (a setting), `KC_EFFECTS_UNSUPPORTED` (`start` carries effects, e.g. a
/// diagnosed model from `kc_robot_load` with joint tables: the solver identifies geometry only
/// and cannot carry them; start it from the model without them). Checked before `lm` is
/// written: on these errors `lm` is unchanged.
///
/// # Safety
/// Handles NULL or valid (`lm` not otherwise in use); `params` NULL or `n` values; `cfg` NULL or
/// valid.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_init(
    lm: *mut kc_lm,
    start: *const kc_robot,
    params: *const kc_param,
    n: usize,
    cfg: *const kc_lm_config,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_init(lm, start, params, n, cfg) })
}

/// Does at most `budget_poses` poses of work (a solve counts as one and ends the call) over
/// the `n` measurements `data` and reports the progress in `*out`. Pass the same data (same
/// count) on every call of a run. The run is over when `out->stopped` is non-zero.
///
/// Errors: `KC_TOO_FEW_MEASUREMENTS` (fewer than `n_params / 3` poses), `KC_NOT_FINITE` (a
/// measurement holds NaN or infinity; checked on the first call), `KC_DATA_CHANGED` (another
/// count than on the first call). On error the solver is unchanged.
///
/// # Safety
/// `lm` NULL or valid and not otherwise in use; `data` NULL or `n` values not written during
/// the call; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_step(
    lm: *mut kc_lm,
    data: *const kc_measurement,
    n: usize,
    budget_poses: usize,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_step(lm, data, n, budget_poses, out) })
}

/// Where the run stands (as the last [`kc_lm_step`] reported it).
///
/// # Safety
/// `lm` NULL or valid; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_get_progress(
    lm: *const kc_lm,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_progress(lm, out) })
}

/// Copies the current estimate into the robot handle `out` (initialised or not).
///
/// # Safety
/// `lm` NULL or valid; `out` NULL or a writable `kc_robot` not otherwise in use.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_robot(lm: *const kc_lm, out: *mut kc_robot) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_robot(lm, out) })
}

/// The parameters found unidentifiable (held at their start values) into `out[cap]`, their
/// number into `*count` (0 before the first full pass). `KC_BUFFER_TOO_SMALL` (only the count
/// written) when `cap` is smaller; `out` may be NULL when `cap` is 0.
///
/// # Safety
/// `lm` NULL or valid; `out` NULL or `cap` writable values; `count` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_unidentifiable(
    lm: *const kc_lm,
    out: *mut kc_param,
    cap: usize,
    count: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_unidentifiable(lm, out, cap, count) })
}

/// The size in bytes of a snapshot of `lm` now (it depends on the parameter count only).
///
/// # Safety
/// `lm` NULL or valid; `size` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_snapshot_size(lm: *const kc_lm, size: *mut usize) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_snapshot_size(lm, size) })
}

/// Writes a snapshot of the solver's complete state into `buf[cap]` (as to a flash page) and
/// its length into `*written`. `KC_BUFFER_TOO_SMALL` when it does not fit: `*written` is then
/// the size needed and `buf` holds a partial, unusable snapshot.
///
/// # Safety
/// `lm` NULL or valid; `buf` NULL or `cap` writable bytes; `written` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_save(
    lm: *const kc_lm,
    buf: *mut u8,
    cap: usize,
    written: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_save(lm, buf, cap, written) })
}

/// Replaces the solver's state with the snapshot in `buf[len]` (bytes after the snapshot are
/// ignored). The handle must hold a solver of the same parameter count (e.g. a fresh
/// [`kc_lm_init`] with the same robot and parameters); the run then continues exactly as the
/// saved one would have, bit for bit. `KC_SNAPSHOT_INVALID` for a truncated or corrupted
/// snapshot (CRC), one of another solver, scalar or shape; on error `lm` is unchanged.
///
/// # Safety
/// `lm` NULL or valid and not otherwise in use; `buf` NULL or `len` readable bytes.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_restore(lm: *mut kc_lm, buf: *const u8, len: usize) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_restore(lm, buf, len) })
}
