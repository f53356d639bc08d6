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
        joints: u32,
        q: *const f32,
        seeds: *const f32,
        targets: *const f32,
        n: usize,
        points: *mut f32,
        commands: *mut f32,
    ) -> i32;
    fn kc_model_cartesian(
        blob: *const u8,
        len: usize,
        nominal_blob: *const u8,
        nominal_len: usize,
        joints: u32,
        seeds: *const f32,
        targets: *const f32,
        n: usize,
        sent: *mut f32,
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
    /// `joints` readings per target (rad).
    pub commands: Vec<f32>,
}

/// Runs the C client on `blob` (a model of `joints` joints) with `q` and `seeds` (`joints`
/// readings per pose) and `targets` (3 coordinates per pose).
pub fn model_test(
    blob: &[u8],
    joints: usize,
    q: &[f32],
    seeds: &[f32],
    targets: &[f32],
) -> ModelRun {
    let n = targets.len() / 3;
    assert!((6..=7).contains(&joints));
    assert!(q.len() >= joints * n.max(1) && seeds.len() >= joints * n);
    let mut points = vec![0.0f32; 3 * n];
    let mut commands = vec![0.0f32; joints * n];
    // SAFETY: the C function reads `len` bytes of `blob`, `joints`·n floats of `q` and `seeds`
    // (at least `joints` of `q`), 3n of `targets`, and writes 3n `points` and `joints`·n
    // `commands`: all within the buffers (asserted above); it uses its own statics (one caller
    // at a time: the tests that call it hold `C_CLIENT`).
    let status = unsafe {
        kc_model_test(
            blob.as_ptr(),
            blob.len(),
            joints as u32,
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

/// The C client's statics are shared: one caller at a time.
pub static C_CLIENT: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Runs the C Cartesian route (`kc_compensate_cartesian`) on the calibrated model `blob` and
/// the nominal robot `nominal` (both of `joints` joints): the point to send for each target
/// (3 coordinates each), or the negative number of the C step that failed.
pub fn model_cartesian(
    blob: &[u8],
    nominal: &[u8],
    joints: usize,
    seeds: &[f32],
    targets: &[f32],
) -> Result<Vec<f32>, i32> {
    let n = targets.len() / 3;
    assert!((6..=7).contains(&joints) && seeds.len() >= joints * n);
    let mut sent = vec![0.0f32; 3 * n];
    // SAFETY: the C function reads the two blobs' bytes, `joints`·n seeds and 3n targets, and
    // writes 3n floats of `sent`: all within the buffers (asserted above); its statics are
    // the callers' to serialise (`C_CLIENT`).
    let status = unsafe {
        kc_model_cartesian(
            blob.as_ptr(),
            blob.len(),
            nominal.as_ptr(),
            nominal.len(),
            joints as u32,
            seeds.as_ptr(),
            targets.as_ptr(),
            n,
            sent.as_mut_ptr(),
        )
    };
    if status == 0 {
        Ok(sent)
    } else {
        Err(status)
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
