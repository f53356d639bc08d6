//! Models loaded from their binary form (`kc_robot_load`) through the C ABI: the tool frame of
//! `kc_fk_pose` (a model with a tool orientation), the solver's refusal of a model with
//! effects, and the refusal of a joint count the ABI does not hold.

use kinecal::io::model_blob;
use kinecal::model::effects::EffectKind;
use kinecal::{ForwardKinematics, Frame, Joint, Robot};
use kinecal_ffi::*;
use nalgebra::{Matrix3, Vector3};
use std::ffi::CStr;

/// MDH rows (alpha, a, theta, d; degrees and mm) of a 6-joint industrial arm.
const ROWS6: [(f64, f64, f64, f64); 6] = [
    (0.0, 0.0, 0.0, 504.0),
    (-90.0, 170.0, -90.0, 0.0),
    (0.0, 780.0, 0.0, 0.0),
    (-90.0, 140.0, 0.0, 760.0),
    (90.0, 0.0, 0.0, 0.0),
    (-90.0, 0.0, 0.0, 125.0),
];

/// MDH rows of a 7-joint arm (an LBR-like 7R).
const ROWS7: [(f64, f64, f64, f64); 7] = [
    (0.0, 0.0, 0.0, 340.0),
    (-90.0, 0.0, 0.0, 0.0),
    (90.0, 0.0, 0.0, 400.0),
    (90.0, 0.0, 0.0, 0.0),
    (-90.0, 0.0, 0.0, 400.0),
    (-90.0, 0.0, 0.0, 0.0),
    (90.0, 0.0, 0.0, 126.0),
];

/// The tool orientation of the test models (roll, pitch, yaw in rad: 11° to 29°, as a 6-D
/// calibration writes into `[tool] rpy_deg`).
const TOOL_RPY: [f64; 3] = [0.2, -0.35, 0.5];

/// An `f64` model of `rows` with a tilted base, a tool point and the tool orientation
/// [`TOOL_RPY`]; with `effects`, a joint-scale and a joint-cyclic term.
fn model<const N: usize>(
    rows: [(f64, f64, f64, f64); N],
    effects: bool,
) -> Robot<f64, N, kinecal::Inline<8>> {
    let base = Frame::from_xyz_rpy([1200.0, -300.0, 50.0], [0.01, -0.02, 0.4]);
    let joints = rows.map(|(al, a, th, d)| Joint::mdh_deg(al, a, th, d));
    let mut r = Robot::new(base, joints, Vector3::new(40.0, 30.0, 120.0)).expect("robot");
    r.set_tool_axes(Frame::from_xyz_rpy([0.0; 3], TOOL_RPY))
        .expect("tool axes");
    if effects {
        r.effects_mut()
            .push(EffectKind::Scale, 1, N, 1, 0.0, 0.0, &[4e-4])
            .expect("scale");
        r.effects_mut()
            .push(EffectKind::Cyclic, 3, N, 2, 0.0, 0.0, &[3e-4, -2e-4])
            .expect("cyclic");
    }
    r
}

fn blob_of<const N: usize, V: kinecal::ValueStorage>(r: &Robot<f64, N, V>) -> Vec<u8> {
    let mut out = vec![0u8; model_blob::encoded_len(r)];
    let n = model_blob::encode(r, &mut out).expect("encoded");
    out.truncate(n);
    out
}

/// A zeroed (not initialised) handle on the heap.
fn handle<T>() -> Box<T> {
    // SAFETY: every handle type is a byte array: all zeros is a valid value.
    Box::new(unsafe { std::mem::zeroed() })
}

/// The robot handle of a binary model.
fn loaded(blob: &[u8]) -> Box<kc_robot> {
    let mut r = handle::<kc_robot>();
    // SAFETY: `blob.len()` readable bytes, a writable handle.
    let s = unsafe { kc_robot_load(&mut *r, blob.as_ptr(), blob.len()) };
    assert_eq!(s, KC_OK);
    r
}

fn message(s: kc_status) -> String {
    // SAFETY: the messages are static NUL-terminated strings.
    unsafe { CStr::from_ptr(kc_status_message(s as u32)) }
        .to_string_lossy()
        .into_owned()
}

/// `kc_fk_pose` of a model with a tool orientation is the tool frame (flange rotation × tool
/// axes, the library's `tool_pose` in f64, within f32 rounding), and handed back to
/// `kc_compensate` as a pose target seeded at the same readings it is met there (`KC_OK`, the
/// command equal to the readings). The flange rotation alone is 30° or more away from it.
fn tool_frame_round_trip<const N: usize>(rows: [(f64, f64, f64, f64); N], poses: &[[f64; N]]) {
    let lib = model(rows, true);
    let r = loaded(&blob_of(&lib));
    let mut w = handle::<kc_fk>();
    // SAFETY: a writable handle.
    assert_eq!(unsafe { kc_fk_init(&mut *w) }, KC_OK);
    let mut fk = ForwardKinematics::<f64, N>::new();
    let tool_axes = Frame::<f64>::from_xyz_rpy([0.0; 3], TOOL_RPY).rotation();
    let (mut worst_rot, mut worst_point, mut worst_dq, mut least_flange) =
        (0.0f64, 0.0f64, 0.0f64, f64::INFINITY);
    for q64 in poses {
        // Readings exact in f32, so both sides evaluate the same pose.
        let q32: [f32; N] = q64.map(|v| v as f32);
        let q: [f64; N] = q32.map(f64::from);
        let p = fk.compute(&lib, &q);
        let flange = fk.flange_pose().rotation();
        let want = flange * tool_axes;
        assert!((fk.tool_pose(&lib).rotation() - want).norm() < 1e-12);
        let mut qa = [0.0f32; KC_MAX_JOINTS];
        qa[..N].copy_from_slice(&q32);
        let mut t = kc_target {
            kind: kc_target_kind::KC_TARGET_POSE as u8,
            ..kc_target::default()
        };
        // SAFETY: valid handles, a reading array of KC_MAX_JOINTS, outputs of 3 and 9 floats.
        let s = unsafe {
            kc_fk_pose(
                &mut *w,
                &*r,
                qa.as_ptr(),
                t.xyz_mm.as_mut_ptr(),
                t.rot.as_mut_ptr(),
            )
        };
        assert_eq!(s, KC_OK);
        let got = Matrix3::from_fn(|i, j| f64::from(t.rot[3 * i + j]));
        worst_rot = worst_rot.max((got - want).abs().max());
        least_flange = least_flange.min((got - flange).abs().max());
        let pt = Vector3::from(t.xyz_mm.map(f64::from));
        worst_point = worst_point.max((pt - p).norm());
        let mut sol = kc_solution::default();
        // SAFETY: valid handle and target, readings of KC_MAX_JOINTS, a writable solution.
        let s = unsafe { kc_compensate(&*r, &t, qa.as_ptr(), std::ptr::null(), &mut sol) };
        assert_eq!(
            s,
            KC_OK,
            "{N} joints at {q:?}: {} ({:.2} mm, {:.2}° off)",
            message(s),
            sol.position_error_mm,
            sol.orientation_error_rad.to_degrees()
        );
        for (c, r) in sol.q[..N].iter().zip(&q32) {
            worst_dq = worst_dq.max(f64::from((c - r).abs()));
        }
    }
    println!(
        "{N} joints: kc_fk_pose vs f64 flange × tool axes worst {worst_rot:.1e}, point \
         {worst_point:.1e} mm; the flange rotation at least {least_flange:.2} away; \
         kc_compensate of kc_fk_pose(q) seeded at q: |command − q| worst {worst_dq:.1e} rad"
    );
    assert!(worst_rot < 2e-6, "rotation {worst_rot}");
    assert!(worst_point < 1e-3, "point {worst_point} mm");
    assert!(
        least_flange > 0.1,
        "the tool orientation is not the flange's"
    );
    assert!(worst_dq < 1e-4, "command moved {worst_dq} rad");
}

#[test]
fn fk_pose_is_the_tool_frame_and_a_target_compensate_meets_six_joints() {
    let poses = [
        [0.3, -0.9, 0.6, 0.4, 0.9, -0.5],
        [-0.7, -0.5, 0.9, -1.1, 0.6, 1.2],
        [1.2, -1.0, 0.4, 0.8, 1.3, 0.3],
        [0.0, -0.6, 1.1, -0.3, 0.7, -1.4],
    ];
    tool_frame_round_trip(ROWS6, &poses);
}

#[test]
fn fk_pose_is_the_tool_frame_and_a_target_compensate_meets_seven_joints() {
    let poses = [
        [0.3, -0.4, 0.5, 0.6, -0.7, 0.8, 0.2],
        [-0.6, 0.7, -0.3, 1.1, 0.4, 0.9, -0.8],
        [1.0, -0.8, 0.9, 0.7, -1.2, 1.1, 0.5],
    ];
    tool_frame_round_trip(ROWS7, &poses);
}

/// `kc_lm_init` from a loaded model with effects: `KC_EFFECTS_UNSUPPORTED` (a status of its
/// own whose message says why), the solver handle left not initialised; the same model
/// without its effects starts.
#[test]
fn lm_init_refuses_a_model_with_effects_with_its_own_status() {
    let with = loaded(&blob_of(&model(ROWS6, true)));
    let without = loaded(&blob_of(&model(ROWS6, false)));
    let mut params = [kc_param::default(); 24];
    let mut lm = handle::<kc_lm>();
    let mut p = kc_lm_progress::default();
    // SAFETY: valid pointers of the documented sizes (here and below).
    unsafe {
        assert_eq!(kc_params_mdh(params.as_mut_ptr()), KC_OK);
        let s = kc_lm_init(&mut *lm, &*with, params.as_ptr(), 24, std::ptr::null());
        assert_eq!(s, KC_EFFECTS_UNSUPPORTED);
        assert_eq!(kc_lm_get_progress(&*lm, &mut p), KC_NOT_INITIALIZED);
        assert_eq!(
            kc_lm_init(&mut *lm, &*without, params.as_ptr(), 24, std::ptr::null()),
            KC_OK
        );
        assert_eq!(kc_lm_get_progress(&*lm, &mut p), KC_OK);
        // Refused again: a refused init leaves the handle as it was (here: initialised).
        let s = kc_lm_init(&mut *lm, &*with, params.as_ptr(), 24, std::ptr::null());
        assert_eq!(s, KC_EFFECTS_UNSUPPORTED);
        assert_eq!(kc_lm_get_progress(&*lm, &mut p), KC_OK);
    }
    let m = message(KC_EFFECTS_UNSUPPORTED);
    assert!(m.contains("effects") && m.contains("without them"), "{m}");
    assert_eq!(KC_EFFECTS_UNSUPPORTED as u32, 17);
}

/// A valid binary model of 3 or 5 joints (the format holds 1 to 7, the ABI 6 or 7) is refused
/// with `KC_MODEL_INVALID`, whose message names the joint count; the handle keeps its model.
#[test]
fn a_joint_count_the_abi_does_not_hold_is_refused_and_named() {
    fn blob_of_joints<const N: usize>() -> Vec<u8> {
        let rows: [(f64, f64, f64, f64); N] = core::array::from_fn(|k| ROWS6[k]);
        blob_of(&model(rows, false))
    }
    let mut r = loaded(&blob_of(&model(ROWS6, false)));
    for blob in [blob_of_joints::<3>(), blob_of_joints::<5>()] {
        assert!(model_blob::joint_count(&blob).is_ok(), "a valid model");
        // SAFETY: `blob.len()` readable bytes, a valid handle.
        let s = unsafe { kc_robot_load(&mut *r, blob.as_ptr(), blob.len()) };
        assert_eq!(s, KC_MODEL_INVALID);
        let mut n = 0u32;
        // SAFETY: a valid handle, a writable count.
        assert_eq!(unsafe { kc_robot_joints(&*r, &mut n) }, KC_OK);
        assert_eq!(n, 6);
    }
    let m = message(KC_MODEL_INVALID);
    assert!(m.contains("joint count") && m.contains("6 or 7"), "{m}");
}

/// A binary model holding the same effect twice (a crafted blob, CRC valid: a robot file
/// refuses it, and it would be applied twice) is refused with `KC_INVALID_ROBOT`, the handle
/// keeping its model.
#[test]
fn a_model_with_an_effect_twice_is_refused() {
    let good = blob_of(&model(ROWS6, true));
    // The joint-scale on joint 2 (0-based 1) once more, before the checksum.
    let mut b = good[..good.len() - 4].to_vec();
    b.extend_from_slice(&model_blob::tag::JOINT_SCALE.to_le_bytes());
    b.extend_from_slice(&32u32.to_le_bytes());
    b.extend_from_slice(&[1, 0]);
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&1u32.to_le_bytes());
    b.extend_from_slice(
        &[
            0.0f64.to_le_bytes(),
            0.0f64.to_le_bytes(),
            4e-4f64.to_le_bytes(),
        ]
        .concat(),
    );
    let len = (b.len() + 4) as u32;
    b[8..12].copy_from_slice(&len.to_le_bytes());
    let crc = kinecal::io::snapshot::crc32(&b);
    b.extend_from_slice(&crc.to_le_bytes());
    let mut r = loaded(&good);
    let mut w = handle::<kc_fk>();
    let q = [0.3f32, -0.9, 0.6, 0.4, 0.9, -0.5, 0.0];
    let (mut before, mut after) = ([0.0f32; 3], [0.0f32; 3]);
    // SAFETY: valid handles and arrays of the documented sizes.
    unsafe {
        assert_eq!(kc_fk_init(&mut *w), KC_OK);
        assert_eq!(
            kc_fk_point(&mut *w, &*r, q.as_ptr(), before.as_mut_ptr()),
            KC_OK
        );
        assert_eq!(
            kc_robot_load(&mut *r, b.as_ptr(), b.len()),
            KC_INVALID_ROBOT
        );
        assert_eq!(
            kc_fk_point(&mut *w, &*r, q.as_ptr(), after.as_mut_ptr()),
            KC_OK
        );
    }
    assert_eq!(before, after);
}
