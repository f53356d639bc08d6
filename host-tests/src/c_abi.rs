//! The C host test of the C ABI (`ffi/tests/c/host_test.c`), compiled by `build.rs` into this
//! crate, linked with `kinecal-ffi` for the `kc_*` symbols it calls.

// The crate that defines the `kc_*` symbols: linked after this one, so the C object's
// references to them resolve.
extern crate kinecal_ffi;

extern "C" {
    fn kc_host_test_main(fk_expected: *const f64, n_expected: usize) -> i32;
    fn kc_model_test(
        blob: *const u8,
        len: usize,
        q: *const f32,
        seeds: *const f32,
        targets: *const f32,
        n: usize,
        points: *mut f32,
        commands: *mut f32,
    ) -> i32;
}

/// What the C client of a binary model (`ffi/tests/c/model_test.c`) computed: the model's
/// point at each pose and the compensated command towards each target.
#[derive(Debug)]
pub struct ModelRun {
    /// 0, or the negative number of the C step that failed.
    pub status: i32,
    /// Three coordinates per pose (mm).
    pub points: Vec<f32>,
    /// Six readings per target (rad).
    pub commands: Vec<f32>,
}

/// Runs the C client on `blob` with `q` and `seeds` (6 readings per pose) and `targets`
/// (3 coordinates per pose).
pub fn model_test(blob: &[u8], q: &[f32], seeds: &[f32], targets: &[f32]) -> ModelRun {
    let n = targets.len() / 3;
    assert!(q.len() >= 6 * n.max(1) && seeds.len() >= 6 * n);
    let mut points = vec![0.0f32; 3 * n];
    let mut commands = vec![0.0f32; 6 * n];
    // SAFETY: the C function reads `len` bytes of `blob`, 6n floats of `q` and `seeds` (at
    // least 6 of `q`), 3n of `targets`, and writes 3n `points` and 6n `commands`: all within
    // the buffers (asserted above); it uses its own statics (one caller at a time: the test).
    let status = unsafe {
        kc_model_test(
            blob.as_ptr(),
            blob.len(),
            q.as_ptr(),
            seeds.as_ptr(),
            targets.as_ptr(),
            n,
            points.as_mut_ptr(),
            commands.as_mut_ptr(),
        )
    };
    ModelRun {
        status,
        points,
        commands,
    }
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
