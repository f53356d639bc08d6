//! The C ABI from C: runs `ffi/tests/c/host_test.c` (compiled by `build.rs`) against the
//! `kinecal-ffi` symbols (see `kinecal_host::c_abi`), with reference points computed here by
//! the library in `f64`.

use kinecal::{ForwardKinematics, Frame, Joint, Robot};
use nalgebra::Vector3;

/// The nominal arm of the C test (same rows, tool and poses), in f64.
fn expected_points() -> Vec<f64> {
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
        (-90.0, 140.0, 0.0, 760.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 125.0),
    ]
    .map(|(al, a, th, d)| Joint::mdh_deg(al, a, th, d));
    let robot: Robot<f64, 6> =
        Robot::new(Frame::identity(), rows, Vector3::new(40.0, 30.0, 120.0)).expect("nominal");
    let mid = [20.0, -70.0, 20.0, 30.0, 45.0, -30.0];
    let mut fk = ForwardKinematics::new();
    let mut out = Vec::new();
    for k in 0..4 {
        // As the C test: q_j = mid_j + 10 k - 15 j degrees, rounded to float.
        let q: [f64; 6] = core::array::from_fn(|j| {
            let deg: f64 = mid[j] + 10.0 * k as f64 - 15.0 * j as f64;
            (deg * (std::f64::consts::PI / 180.0)) as f32 as f64
        });
        out.extend(fk.compute(&robot, &q).iter());
    }
    out
}

#[test]
fn c_host_test_passes() {
    let want = expected_points();
    let failed = kinecal_host::c_abi::run(&want);
    assert_eq!(
        failed, 0,
        "the C host test failed {failed} checks (see its stderr above)"
    );
}
