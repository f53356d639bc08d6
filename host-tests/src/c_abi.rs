//! The C host test of the C ABI (`ffi/tests/c/host_test.c`), compiled by `build.rs` into this
//! crate, linked with `kinecal-ffi` for the `kc_*` symbols it calls.

// The crate that defines the `kc_*` symbols: linked after this one, so the C object's
// references to them resolve.
extern crate kinecal_ffi;

extern "C" {
    fn kc_host_test_main(fk_expected: *const f64, n_expected: usize) -> i32;
}

/// Runs every check of the C host test and returns how many failed (each failure is printed
/// to stderr). `fk_expected` holds the reference points of the C test's forward-kinematics
/// poses, three coordinates per pose.
pub fn run(fk_expected: &[f64]) -> i32 {
    // SAFETY: the C function reads `fk_expected.len() / 3` points (3 doubles each), all within
    // the slice, and otherwise touches only its own statics (callers do not run it twice at
    // once: the one test that calls it).
    unsafe { kc_host_test_main(fk_expected.as_ptr(), fk_expected.len() / 3) }
}
