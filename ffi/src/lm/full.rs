//! The larger solver handle `kc_lm_full` (feature `lm-full`): every geometric parameter.
#![cfg(feature = "lm-full")]

use super::config::kc_lm_config;
use super::measurement::kc_measurement;
use super::progress::kc_lm_progress;
use super::snapshot::{lm_restore, lm_save, lm_snapshot_size};
use super::solver::{lm_init, Solvers};
use super::stepping::{lm_progress, lm_robot, lm_step, lm_unidentifiable};
use crate::handle::handle;
use crate::robot::{kc_param, kc_robot};
use crate::{kc_status, status};

// For the documentation's links only.
#[cfg(doc)]
use super::abi::{
    kc_lm_get_progress, kc_lm_init, kc_lm_restore, kc_lm_robot, kc_lm_save, kc_lm_snapshot_size,
    kc_lm_step, kc_lm_unidentifiable,
};
#[cfg(doc)]
use super::solver::kc_lm;

/// Room for identified parameters in a `kc_lm_full`: every geometric parameter of a 7-joint
/// arm (`KC_PARAMS_ALL`: 6 base, 5 × 7 row, 3 tool; 39 of a 6-joint arm), for a firmware that also fits the base
/// pose and the tool point (`kc_params_full`).
#[cfg(feature = "lm-full")]
pub const KC_LM_FULL_MAX_PARAMS: usize = 44;

/// Bytes of a [`kc_lm_full`] (see `KC_ROBOT_SIZE`).
#[cfg(feature = "lm-full")]
pub const KC_LM_FULL_SIZE: usize = 21528;

/// As [`kc_lm`] with room for `KC_LM_FULL_MAX_PARAMS` parameters (twice the memory; the
/// `kc_lm_full_*` functions are those of `kc_lm`). Only in a static library built with the
/// cargo feature `lm-full` (and C code compiled with `-DKC_LM_FULL`): a second solver in the
/// library changes how LLVM inlines the shared solver code, and on the M4F a plain `kc_lm`
/// then spends ~12 % more instructions per pose (7,967 against 7,097).
#[cfg(feature = "lm-full")]
#[repr(C, align(8))]
pub struct kc_lm_full {
    _opaque: [u8; KC_LM_FULL_SIZE],
}

#[cfg(feature = "lm-full")]
handle!(
    kc_lm_full,
    KC_LM_FULL_SIZE,
    Solvers<KC_LM_FULL_MAX_PARAMS>,
    0x4c4d_4c46
);

/// [`kc_lm_init`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_init`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_init(
    lm: *mut kc_lm_full,
    start: *const kc_robot,
    params: *const kc_param,
    n: usize,
    cfg: *const kc_lm_config,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_init(lm, start, params, n, cfg) })
}

/// [`kc_lm_step`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_step`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_step(
    lm: *mut kc_lm_full,
    data: *const kc_measurement,
    n: usize,
    budget_poses: usize,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_step(lm, data, n, budget_poses, out) })
}

/// [`kc_lm_get_progress`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_get_progress`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_get_progress(
    lm: *const kc_lm_full,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_progress(lm, out) })
}

/// [`kc_lm_robot`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_robot`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_robot(lm: *const kc_lm_full, out: *mut kc_robot) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_robot(lm, out) })
}

/// [`kc_lm_unidentifiable`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_unidentifiable`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_unidentifiable(
    lm: *const kc_lm_full,
    out: *mut kc_param,
    cap: usize,
    count: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_unidentifiable(lm, out, cap, count) })
}

/// [`kc_lm_snapshot_size`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_snapshot_size`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_snapshot_size(
    lm: *const kc_lm_full,
    size: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_snapshot_size(lm, size) })
}

/// [`kc_lm_save`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_save`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_save(
    lm: *const kc_lm_full,
    buf: *mut u8,
    cap: usize,
    written: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_save(lm, buf, cap, written) })
}

/// [`kc_lm_restore`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_restore`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_restore(
    lm: *mut kc_lm_full,
    buf: *const u8,
    len: usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_restore(lm, buf, len) })
}
