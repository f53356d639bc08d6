//! # kinecal-ffi: the C ABI of kinecal
//!
//! Scalar `float` (the library's `f32`, as on the Cortex-M4F), robots of 6 or 7 joints (joint
//! arrays are declared with [`KC_MAX_JOINTS`] entries; a 6-joint robot uses the first 6),
//! library units (millimetres, radians). The header is `include/kinecal.h`, generated from
//! this crate by cbindgen (`ffi/cbindgen.toml`; the test `c_header` fails when it is stale).
//!
//! - No allocation: every handle (`kc_robot`, `kc_fk`, `kc_lm`, `kc_lm_full`, `kc_tracker`, `kc_csv`) lives
//!   in memory the caller owns, declared in C as an opaque byte array aligned to 8 bytes whose
//!   size is a `#define`; a compile-time assertion below checks that the real Rust value fits,
//!   on the 64-bit host and on the 32-bit thumb target alike. `*_init` constructs in place.
//! - Every function returns a [`kc_status`] (0 = [`kc_status::KC_OK`]), checks every pointer
//!   for NULL (and handles for alignment and initialisation), every length, every float input
//!   the library would refuse; it never panics and never unwinds. After an error the handles
//!   are unchanged (a failed `*_init` leaves its handle not initialised).
//! - The wrappers are thin: no copy of big state, the library call inlined.

#![no_std]
// The C names: `kc_robot`, `KC_OK`.
#![allow(non_camel_case_types)]
// Every `unsafe` operation in an `unsafe fn` sits in its own block with its own SAFETY note.
#![deny(unsafe_op_in_unsafe_fn)]
#![deny(clippy::undocumented_unsafe_blocks)]
#![warn(missing_docs)]
// `!(x > 0)` is deliberate: a NaN must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// On the host the static library links into programs that bring `std` (and its panic
// runtime); on bare metal the C firmware has no Rust runtime, so this crate brings the
// panic handler (no panic is reachable: every index is checked, nothing unwraps).
#[cfg(not(target_os = "none"))]
extern crate std;

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // The wrappers have no panic paths and the library refuses bad input with errors, so this
    // is a library bug: trap (a permanently undefined instruction raises a UsageFault, escalated
    // to the firmware's HardFault handler), so the controller's fault handling sees it instead
    // of a core spinning silently.
    loop {
        // SAFETY: `udf` only raises the fault; it touches no memory.
        unsafe { core::arch::asm!("udf #0") };
    }
}

// In the header's order (one group each: rustfmt sorts `mod` items within a group).
mod handle;

mod robot;

mod fk;

mod lm;

mod compensate;

mod csv;

pub use compensate::*;
pub use csv::*;
pub use fk::*;
pub use lm::*;
pub use robot::*;

/// Joints of the CSV reader's records and of the default parameter set `kc_params_mdh` (a
/// 6-joint measurement file).
pub const KC_JOINTS: usize = 6;

/// Most joints of a robot of this ABI, and the length of every joint array (readings,
/// commands, rows): a 6-joint robot uses the first 6 entries.
pub const KC_MAX_JOINTS: usize = 7;

/// What a call did: 0 is success, anything else says why nothing (or, for
/// [`kc_status::KC_COMPENSATE_FAILED`], only a best-effort result) was produced.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum kc_status {
    /// Success.
    KC_OK = 0,
    /// CSV: no more records.
    KC_END = 1,
    /// A required pointer is NULL.
    KC_NULL_POINTER = 2,
    /// An argument is out of its range (an index, a code, a length, a setting).
    KC_INVALID_ARGUMENT = 3,
    /// The robot description was refused: a length or angle out of range, joint limits not
    /// `lower < upper`, a base that is not a rotation, a refused joint coupling, or (a binary
    /// model) an effect a robot file refuses.
    KC_INVALID_ROBOT = 4,
    /// A float input is NaN or infinite (inputs are checked by their sum: magnitudes above
    /// ~1e37, which no robot quantity has, count as infinite too).
    KC_NOT_FINITE = 5,
    /// LM: no measurements, or fewer residuals (3 per pose) than parameters.
    KC_TOO_FEW_MEASUREMENTS = 6,
    /// LM: the measurement count changed between calls of one run.
    KC_DATA_CHANGED = 7,
    /// An output buffer is too small (the size needed is reported where the call says so).
    KC_BUFFER_TOO_SMALL = 8,
    /// A snapshot was refused: truncated, corrupted (CRC), of another solver or shape.
    KC_SNAPSHOT_INVALID = 9,
    /// Compensation did not meet the target: the `kc_solution` holds the best safe command
    /// and its `status` says why (singular, unreachable, limited).
    KC_COMPENSATE_FAILED = 10,
    /// CSV: a malformed header or record (see `kc_csv_last_error`).
    KC_CSV_ERROR = 11,
    /// More parameters than the ABI has room for ([`KC_LM_MAX_PARAMS`]).
    KC_TOO_MANY_PARAMS = 12,
    /// The handle was never initialised, or its `*_init` failed.
    KC_NOT_INITIALIZED = 13,
    /// A named item (a CSV extra column) does not exist.
    KC_NOT_FOUND = 14,
    /// A handle is not aligned to 8 bytes.
    KC_MISALIGNED = 15,
    /// A binary model was refused: truncated, corrupted (CRC), of another layout version, of
    /// a joint count this ABI does not hold (6 or 7; the format holds 1 to 7), or larger than
    /// the robot handle holds.
    KC_MODEL_INVALID = 16,
    /// The solver (`kc_lm_init`, `kc_lm_full_init`) cannot carry a model's effects (joint
    /// corrections: joint tables, cyclic, compliance, scale, thermal terms): it identifies
    /// geometry only and has no room for effect values. Start it from the model without them
    /// (the robot file exported without its `[[effects]]`, or `kc_robot_init` with the
    /// model's rows, base and tool and `kc_robot_set_coupling`).
    KC_EFFECTS_UNSUPPORTED = 17,
}

pub use kc_status::*;

/// Result of the internal checks: the error is the status to return.
pub(crate) type Kc<T> = Result<T, kc_status>;

/// The status of a result.
#[inline(always)]
pub(crate) fn status(r: Kc<()>) -> kc_status {
    match r {
        Ok(()) => KC_OK,
        Err(s) => s,
    }
}

/// A static one-line English description of a status code (any value: unknown codes get
/// "unknown status"). Never NULL.
#[no_mangle]
pub extern "C" fn kc_status_message(status: u32) -> *const core::ffi::c_char {
    let s: &'static core::ffi::CStr = match status {
        0 => c"ok",
        1 => c"end of data",
        2 => c"a required pointer is NULL",
        3 => c"an argument is out of range",
        4 => c"the robot description was refused",
        5 => c"a float input is NaN or infinite",
        6 => c"too few measurements for the parameters",
        7 => c"the measurement count changed during the run",
        8 => c"output buffer too small",
        9 => c"snapshot refused (truncated, corrupted or of another solver)",
        10 => c"compensation did not meet the target (see the solution's status)",
        11 => c"malformed CSV (see kc_csv_last_error)",
        12 => c"too many parameters",
        13 => c"handle not initialised",
        14 => c"not found",
        15 => c"handle not aligned to 8 bytes",
        16 => c"binary model refused (truncated, corrupted, another version, too large, or a joint count the C ABI does not hold: 6 or 7)",
        17 => c"the solver cannot carry a model's effects (joint corrections): start it from the model without them",
        _ => c"unknown status",
    };
    s.as_ptr()
}

/// `true` when every value is finite, by the sum: NaN or ±inf anywhere makes `s - s` NaN.
/// Values so large that their sum overflows (|v| ≳ 1e37, no robot quantity) are refused too.
/// About one instruction per value, so checking costs nothing next to the work.
#[inline(always)]
#[allow(clippy::eq_op)] // `s - s` is the point: 0 for finite `s`, NaN otherwise.
pub(crate) fn all_finite(v: &[f32]) -> bool {
    let s: f32 = v.iter().sum();
    s - s == 0.0
}

/// `Err(KC_NOT_FINITE)` unless every value is finite (see [`all_finite`]).
#[inline(always)]
pub(crate) fn finite(v: &[f32]) -> Kc<()> {
    if all_finite(v) {
        Ok(())
    } else {
        Err(KC_NOT_FINITE)
    }
}

/// Reads a `[T; M]` the caller passed by pointer (`Err(KC_NULL_POINTER)` for NULL).
///
/// # Safety
/// `p` is NULL or points to `M` readable, initialised `T`.
#[inline(always)]
pub(crate) unsafe fn array_ref<'a, T, const M: usize>(p: *const T) -> Kc<&'a [T; M]> {
    // SAFETY: non-NULL per the check; the caller's contract gives M valid values, and every
    // bit pattern of the plain-data types used here (f32, f64, u8) is valid.
    unsafe { p.cast::<[T; M]>().as_ref() }.ok_or(KC_NULL_POINTER)
}

/// A `&mut [T; M]` over the caller's output array (`Err(KC_NULL_POINTER)` for NULL).
///
/// # Safety
/// `p` is NULL or points to `M` writable `T` that nothing else references during the call.
#[inline(always)]
pub(crate) unsafe fn array_mut<'a, T, const M: usize>(p: *mut T) -> Kc<&'a mut [T; M]> {
    // SAFETY: non-NULL per the check; the caller's contract gives M writable, unaliased
    // values of a plain-data type (any bits valid).
    unsafe { p.cast::<[T; M]>().as_mut() }.ok_or(KC_NULL_POINTER)
}

/// A `&T` from the caller's pointer (`Err(KC_NULL_POINTER)` for NULL).
///
/// # Safety
/// `p` is NULL or points to a valid, initialised `T` (a `#[repr(C)]` plain-data struct).
#[inline(always)]
pub(crate) unsafe fn obj_ref<'a, T>(p: *const T) -> Kc<&'a T> {
    // SAFETY: the caller's contract; NULL is checked.
    unsafe { p.as_ref() }.ok_or(KC_NULL_POINTER)
}

/// A `&mut T` for the caller's output struct (`Err(KC_NULL_POINTER)` for NULL).
///
/// # Safety
/// `p` is NULL or points to a writable `T` (plain data) that nothing else references.
#[inline(always)]
pub(crate) unsafe fn obj_mut<'a, T>(p: *mut T) -> Kc<&'a mut T> {
    // SAFETY: the caller's contract; NULL is checked.
    unsafe { p.as_mut() }.ok_or(KC_NULL_POINTER)
}

/// A slice over the caller's `n` values: NULL is allowed only for `n == 0`; `n` whose byte
/// size would not fit an `isize` is `KC_INVALID_ARGUMENT`.
///
/// # Safety
/// `p` is NULL or points to `n` readable, initialised `T` that nothing writes during the call.
#[inline(always)]
pub(crate) unsafe fn slice_ref<'a, T>(p: *const T, n: usize) -> Kc<&'a [T]> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(KC_NULL_POINTER);
    }
    if n > isize::MAX as usize / core::mem::size_of::<T>().max(1) {
        return Err(KC_INVALID_ARGUMENT);
    }
    if (p as usize) % core::mem::align_of::<T>() != 0 {
        return Err(KC_MISALIGNED);
    }
    // SAFETY: non-NULL, aligned, the size fits an isize, and the caller's contract gives n
    // initialised values of a plain-data type not written during the call.
    Ok(unsafe { core::slice::from_raw_parts(p, n) })
}

/// As [`slice_ref`], writable.
///
/// # Safety
/// `p` is NULL or points to `n` writable `T` (plain data) that nothing else references.
#[inline(always)]
pub(crate) unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Kc<&'a mut [T]> {
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(KC_NULL_POINTER);
    }
    if n > isize::MAX as usize / core::mem::size_of::<T>().max(1) {
        return Err(KC_INVALID_ARGUMENT);
    }
    if (p as usize) % core::mem::align_of::<T>() != 0 {
        return Err(KC_MISALIGNED);
    }
    // SAFETY: non-NULL, aligned, the size fits an isize, and the caller's contract gives n
    // writable values of a plain-data type that nothing else references during the call.
    Ok(unsafe { core::slice::from_raw_parts_mut(p, n) })
}

#[cfg(test)]
mod tests {
    use crate::handle::{Handle, Slot};
    use core::mem::size_of;

    /// The size of a handle's value rounded up to the handle alignment.
    fn needed<H: Handle>() -> usize {
        size_of::<Slot<H::Inner>>().div_ceil(8) * 8
    }

    /// The `KC_*_SIZE` defines are the 64-bit host's sizes (the largest of the supported
    /// targets) with no slack: a library change that shrinks a type shows here, one that grows
    /// it fails the build (the assertions of `handle!`).
    #[test]
    #[cfg(target_pointer_width = "64")]
    fn handle_sizes_are_exact_on_the_64_bit_host() {
        use crate::*;
        assert_eq!(needed::<kc_robot>(), KC_ROBOT_SIZE);
        assert_eq!(needed::<kc_fk>(), KC_FK_SIZE);
        assert_eq!(needed::<kc_param_set>(), KC_PARAM_SET_SIZE);
        assert_eq!(needed::<kc_lm>(), KC_LM_SIZE);
        #[cfg(feature = "lm-full")]
        assert_eq!(needed::<kc_lm_full>(), KC_LM_FULL_SIZE);
        assert_eq!(needed::<kc_tracker>(), KC_TRACKER_SIZE);
        assert_eq!(needed::<kc_csv>(), KC_CSV_SIZE);
    }

    #[test]
    fn finite_check() {
        assert!(crate::all_finite(&[0.0, -1.0, 1e30, f32::MIN_POSITIVE]));
        assert!(!crate::all_finite(&[0.0, f32::NAN]));
        assert!(!crate::all_finite(&[f32::INFINITY, 1.0]));
        assert!(!crate::all_finite(&[f32::NEG_INFINITY]));
        assert!(crate::all_finite(&[]));
    }
}
