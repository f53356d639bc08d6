//! The binary model (`.kcm`, docs/formats.md "Binary model (.kcm)"): round trips of every
//! effect kind, couplings, several tool points and a tool orientation on 6 and 7 joints
//! (forward kinematics of the decoded model equal the original's bit for bit), refusals of
//! truncated, corrupted, foreign-version and oversized blobs (the target unchanged), and
//! `kinecal export --format firmware`.

use kinecal::io::model_blob::{self, BlobError, MAX_JOINTS};
use kinecal::io::snapshot::crc32;
use kinecal::model::effects::EffectKind;
use kinecal::{ForwardKinematics, Frame, Robot};
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::HostRobot;
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Effects of every kind (a table over the joint's whole range), appended to a robot file.
pub(super) const EFFECTS: &str = r#"
[[effects]]
kind = "joint-scale"
joint = 1
values = [0.0003]
[[effects]]
kind = "joint-cyclic"
joint = 2
order = 2
values = [0.0004, -0.0002]
[[effects]]
kind = "joint-compliance"
joint = 3
values = [0.0009]
[[effects]]
kind = "joint-table"
joint = 4
step_deg = 7.5
start_deg = -170.0
values = [0.0001, 0.0003, -0.0002, 0.0004, 0.0, -0.0001, 0.0002, 0.0005, -0.0003, 0.0001]
[[effects]]
kind = "joint-cyclic"
joint = 2
values = [0.0001, 0.00015]
[[effects]]
kind = "thermal-expansion"
joint = 0
values = [1.2e-5]
reference_c = 22.5
[[couplings]]
joint = 3
from = 2
ratio = 1.0
"#;

/// The model of a robot file text with [`EFFECTS`] appended (and a tilt on joint 2).
pub(super) fn model<const N: usize>(text: &str) -> HostRobot<N> {
    let file = RobotFile::parse(&format!("{text}{EFFECTS}"), "test").unwrap();
    let mut r = file.to_robot::<N>().unwrap();
    let mut j = r.joints()[1];
    j.beta = 0.2f64.to_radians();
    r.set_joint(1, j).unwrap();
    r
}

/// Random readings within ±170°.
fn poses<const N: usize>(n: usize, seed: u64) -> Vec<[f64; N]> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.random_range(-2.96..2.96)))
        .collect()
}

pub(super) fn blob_of<const N: usize, V: kinecal::ValueStorage>(r: &Robot<f64, N, V>) -> Vec<u8> {
    let mut out = vec![0u8; model_blob::encoded_len(r)];
    let n = model_blob::encode(r, &mut out).unwrap();
    assert_eq!(n, out.len());
    out
}

/// Decodes into a robot that differs from every model here, asserting equality and equal FK.
fn round_trip<const N: usize>(original: &HostRobot<N>) {
    let blob = blob_of(original);
    assert_eq!(model_blob::joint_count(&blob), Ok(N));
    let mut decoded: HostRobot<N> = Robot::new(
        Frame::identity(),
        [kinecal::Joint::mdh(0.0, 1.0, 0.0, 1.0); N],
        Vector3::zeros(),
    )
    .unwrap();
    model_blob::decode(&blob, &mut decoded).unwrap();
    assert_eq!(&decoded, original);
    let (mut fa, mut fb) = (ForwardKinematics::new(), ForwardKinematics::new());
    for (i, q) in poses::<N>(500, 7).into_iter().enumerate() {
        // Half the poses at the reference temperature, half at 10 … 40 °C (thermal expansion).
        let t = (i % 2 == 1).then_some(10.0 + (i % 31) as f64);
        (fa.temp_c, fb.temp_c) = (t, t);
        // A third at a time of a session (a base-drift term), Unix seconds.
        let when = (i % 3 == 1).then_some(1.7e9 + 1.5 * i as f64);
        (fa.time_s, fb.time_s) = (when, when);
        let (a, b) = (fa.compute(original, &q), fb.compute(&decoded, &q));
        assert_eq!(a, b, "FK differs at {q:?}");
        assert_eq!(fa.tool_pose(original), fb.tool_pose(&decoded));
    }
    // Re-encoding gives the same bytes.
    assert_eq!(blob_of(&decoded), blob);
    // Decoded into f32: the model the f32 cast of the original is.
    let mut small: Robot<f32, N, kinecal::Inline<256>> =
        original.cast::<f32>().unwrap().with_capacity().unwrap();
    let want = small.clone();
    small.set_tool(Vector3::new(1.0, 2.0, 3.0)).unwrap();
    model_blob::decode(&blob, &mut small).unwrap();
    assert_eq!(small, want);
}

#[test]
fn six_joints_every_effect_kind_coupling_tool_points_and_axes() {
    let mut r = model::<6>(crate::common::ER20_TILTED_PLACED);
    let kinds: Vec<EffectKind> = r.effects().iter().map(|e| e.kind).collect();
    for k in [
        EffectKind::Scale,
        EffectKind::Cyclic,
        EffectKind::Compliance,
        EffectKind::Table,
        EffectKind::Thermal,
    ] {
        assert!(kinds.contains(&k), "{k:?} missing from the test model");
    }
    assert_eq!(r.couplings().len(), 1);
    round_trip(&r);
    r.set_tool_point(1, Vector3::new(40.0, 0.0, 90.0)).unwrap();
    r.set_tool_point(2, Vector3::new(-20.0, 35.0, 95.0))
        .unwrap();
    r.set_tool_axes(Frame::from_xyz_rpy([0.0; 3], [0.1, -0.2, 0.7]))
        .unwrap();
    round_trip(&r);
}

/// A base-drift term (a session's tracker drift) round-trips with its reference time in Unix
/// seconds: the blob keeps it in an f64, and the decoded model moves with the time as the
/// original does.
#[test]
fn a_base_drift_term_round_trips_with_a_unix_reference_time() {
    let mut r = model::<6>(crate::common::ER20_TILTED_PLACED);
    r.effects_mut()
        .push(
            EffectKind::Drift,
            0,
            6,
            1,
            1.7e9 + 0.25,
            0.0,
            &[2e-5, -1e-5, 3e-6],
        )
        .unwrap();
    round_trip(&r);
    let blob = blob_of(&r);
    let mut decoded = r.clone();
    model_blob::decode(&blob, &mut decoded).unwrap();
    assert_eq!(decoded.effects().drift(), r.effects().drift());
    assert_eq!(decoded.effects().drift().unwrap().2, 1.7e9 + 0.25);
}

#[test]
fn seven_joints_every_effect_kind_and_coupling() {
    let r = model::<7>(crate::common::LBR7_TILTED_PLACED);
    assert_eq!(r.effects().len(), 6);
    round_trip(&r);
}

#[test]
fn plain_geometry_is_the_fixed_part_only() {
    let file = RobotFile::parse(crate::common::ER20_PLACED, "test").unwrap();
    let r = file.to_robot::<6>().unwrap();
    // Header 12, base 96, rows 6 × 56, tool 24, CRC 4.
    assert_eq!(model_blob::encoded_len(&r), 12 + 96 + 336 + 24 + 4);
    round_trip(&r);
}

/// `blob` with its checksum recomputed (a well-formed blob of different content).
pub(super) fn resealed(mut blob: Vec<u8>) -> Vec<u8> {
    let n = blob.len() - 4;
    let crc = crc32(&blob[..n]);
    blob[n..].copy_from_slice(&crc.to_le_bytes());
    blob
}

/// Asserts that `blob` is refused with `want` and leaves the target unchanged.
pub(super) fn refused<const N: usize, V: kinecal::ValueStorage>(
    blob: &[u8],
    target: &Robot<f64, N, V>,
    want: BlobError,
) {
    let mut t = target.clone();
    assert_eq!(model_blob::decode(blob, &mut t), Err(want));
    assert_eq!(&t, target);
}

#[test]
fn truncated_corrupted_and_foreign_blobs_are_refused_leaving_the_robot_unchanged() {
    let r = model::<6>(crate::common::ER20_TILTED_PLACED);
    let blob = blob_of(&r);
    let target = {
        let f = RobotFile::parse(crate::common::ER20_PLACED, "test").unwrap();
        f.to_robot::<6>().unwrap()
    };
    for len in 0..blob.len() {
        refused(&blob[..len], &target, BlobError::Truncated);
    }
    let mut longer = blob.clone();
    longer.push(0);
    refused(&longer, &target, BlobError::NotAModel);
    // Every single flipped bit past the magic and version is caught (by the length check or
    // the CRC); in the magic or the version it is another file or version.
    for i in 0..blob.len() {
        for bit in 0..8 {
            let mut b = blob.clone();
            b[i] ^= 1 << bit;
            let mut t = target.clone();
            let e = model_blob::decode(&b, &mut t).unwrap_err();
            assert_eq!(t, target);
            match i {
                0..=3 => assert_eq!(e, BlobError::NotAModel),
                4..=5 => assert!(matches!(e, BlobError::Version(_))),
                8..=11 => assert!(matches!(e, BlobError::Truncated | BlobError::NotAModel)),
                _ => assert_eq!(e, BlobError::Checksum, "byte {i} bit {bit}"),
            }
        }
    }
    // Another version, even with a valid checksum.
    let mut v2 = blob.clone();
    v2[4] = 2;
    refused(&resealed(v2), &target, BlobError::Version(2));
    // A joint count the robot does not have, or beyond the format's.
    let mut b = blob.clone();
    b[6] = 8;
    refused(&resealed(b), &target, BlobError::Joints(8));
    let seven = blob_of(&model::<7>(crate::common::LBR7_TILTED_PLACED));
    refused(&seven, &target, BlobError::Joints(7));
    assert_eq!(MAX_JOINTS, 7);
    // A NaN in the base and in a table value, checksum valid.
    let mut b = blob.clone();
    b[12..20].copy_from_slice(&f64::NAN.to_le_bytes());
    refused(&resealed(b), &target, BlobError::NotFinite);
    let mut b = blob.clone();
    let last = b.len() - 12;
    b[last..last + 8].copy_from_slice(&f64::INFINITY.to_le_bytes());
    refused(&resealed(b), &target, BlobError::NotFinite);
    // More effect values than the robot has room for.
    let small: Robot<f64, 6, kinecal::Inline<8>> = target.with_capacity().unwrap();
    refused(&blob, &small, BlobError::Capacity);
    let plain: Robot<f64, 6, kinecal::Inline<0>> = target.with_capacity().unwrap();
    refused(&blob, &plain, BlobError::Capacity);
}

#[test]
fn encoding_into_a_short_buffer_is_refused() {
    let r = model::<6>(crate::common::ER20_TILTED_PLACED);
    let need = model_blob::encoded_len(&r);
    let mut out = vec![0u8; need - 1];
    assert_eq!(
        model_blob::encode(&r, &mut out),
        Err(BlobError::BufferTooSmall { needed: need })
    );
}

/// A diagnosed model's corrections (joint tables on joints 1–3 as `diagnose` names them on the
/// UR10, a cyclic term on joint 5, compliance on joint 2) and a FANUC coupling.
const DIAGNOSED: &str = r#"
[[effects]]
kind = "joint-table"
joint = 1
step_deg = 20.0
start_deg = -180.0
values = [1e-4, 2e-4, -1e-4, 0.0, 3e-4, 1e-4, -2e-4, 0.0, 1e-4, 2e-4, -1e-4, 0.0, 3e-4, 1e-4, -2e-4, 0.0, 1e-4, 2e-4, -1e-4]
[[effects]]
kind = "joint-table"
joint = 2
step_deg = 10.0
start_deg = -180.0
values = [2e-4, 1e-4, 0.0, -1e-4, -2e-4, -1e-4, 0.0, 1e-4, 2e-4, 1e-4, 0.0, -1e-4, -2e-4, -1e-4, 0.0, 1e-4, 2e-4, 1e-4, 0.0, -1e-4, -2e-4, -1e-4, 0.0, 1e-4, 2e-4, 1e-4, 0.0, -1e-4, -2e-4, -1e-4, 0.0, 1e-4, 2e-4, 1e-4, 0.0, -1e-4, -2e-4]
[[effects]]
kind = "joint-table"
joint = 3
step_deg = 30.0
start_deg = -180.0
values = [-1e-4, 1e-4, 2e-4, 0.0, -2e-4, 1e-4, 3e-4, 0.0, -1e-4, 1e-4, 2e-4, 0.0, -2e-4]
[[effects]]
kind = "joint-cyclic"
joint = 5
values = [2e-4, -1e-4]
[[effects]]
kind = "joint-compliance"
joint = 2
values = [4e-4]
[[couplings]]
joint = 3
from = 2
ratio = 1.0
"#;

/// Runs the C client (`ffi/tests/c/model_test.c`) on the binary model of `model` at `n` poses
/// drawn from `ranges` (rad; bent arm, no singularity), and checks its forward kinematics and
/// compensated commands against the library in f64 (the client itself checks that each pose's
/// `kc_fk_pose`, handed back to `kc_compensate` as a pose target, is met at its readings).
fn c_client_matches_f64<const N: usize, V: kinecal::ValueStorage>(
    model: &Robot<f64, N, V>,
    ranges: [(f64, f64); N],
    n: usize,
    rng_seed: u64,
) {
    let blob = blob_of(model);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(rng_seed);
    let (mut q, mut seeds, mut targets) = (Vec::new(), Vec::new(), Vec::new());
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut truth = Vec::new();
    for _ in 0..n {
        // Readings exact in f32.
        let qt: [f64; N] =
            std::array::from_fn(|j| rng.random_range(ranges[j].0..ranges[j].1) as f32 as f64);
        let p = fk.compute(model, &qt);
        targets.extend(p.iter().map(|x| *x as f32));
        q.extend(qt.iter().map(|x| *x as f32));
        seeds.extend(
            qt.iter()
                .map(|x| (x + rng.random_range(-0.005..0.005)) as f32),
        );
        truth.push(p);
    }
    let run = {
        let _one = kinecal_host::c_abi::C_CLIENT
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        kinecal_host::c_abi::model_test(&blob, N, &q, &seeds, &targets)
    };
    assert_eq!(run.status, 0, "C client failed at step {}", -run.status);
    let (mut worst_fk, mut worst_comp, mut worst_dq) = (0.0f64, 0.0f64, 0.0f64);
    let cfg = kinecal::compensate::Config::<f64>::default();
    for (i, p) in truth.iter().enumerate() {
        let c = Vector3::new(
            run.points[3 * i] as f64,
            run.points[3 * i + 1] as f64,
            run.points[3 * i + 2] as f64,
        );
        worst_fk = worst_fk.max((c - p).norm());
        let cmd: [f64; N] = std::array::from_fn(|j| run.commands[N * i + j] as f64);
        let target = Vector3::new(
            targets[3 * i] as f64,
            targets[3 * i + 1] as f64,
            targets[3 * i + 2] as f64,
        );
        worst_comp = worst_comp.max((fk.compute(model, &cmd) - target).norm());
        let seed: [f64; N] = std::array::from_fn(|j| seeds[N * i + j] as f64);
        let lib = kinecal::compensate::compensate(
            model,
            &kinecal::compensate::Target::Point(target),
            &seed,
            &cfg,
        )
        .expect("f64 compensation");
        for (l, c) in lib.q.iter().zip(&cmd) {
            worst_dq = worst_dq.max((l - c).abs());
        }
    }
    println!(
        "C client, {N} joints, {} effects ({} bytes): FK vs f64 worst {worst_fk:.2e} mm; C command \
         on the f64 model worst {worst_comp:.2e} mm from the target; |C − f64 command| worst \
         {worst_dq:.2e} rad",
        model.effects().len(),
        blob.len()
    );
    assert!(worst_fk < 2e-3, "FK {worst_fk} mm");
    assert!(worst_comp < 5e-3, "compensation {worst_comp} mm");
    assert!(worst_dq < 1e-4, "command {worst_dq} rad");
}

#[test]
fn c_client_of_a_diagnosed_model_matches_the_library_in_f64() {
    let file = RobotFile::parse(
        &format!("{}{DIAGNOSED}", crate::common::ER20_TILTED_PLACED),
        "t",
    )
    .unwrap();
    let mut model = file.to_robot::<6>().unwrap();
    assert_eq!(model.effects().len(), 5);
    // A tool orientation, as a 6-D calibration writes one (`[tool] rpy_deg`): the C client's
    // kc_fk_pose must give the tool frame that kc_compensate meets, not the flange's.
    model
        .set_tool_axes(Frame::from_xyz_rpy([0.0; 3], [0.2, -0.35, 0.5]))
        .unwrap();
    let ranges = [
        (-1.5, 1.5),
        (-1.2, -0.2),
        (0.3, 1.2),
        (-1.5, 1.5),
        (0.4, 1.4),
        (-1.5, 1.5),
    ];
    c_client_matches_f64(&model, ranges, 60, 32);
}

/// A 7-joint model with a joint table (and a cyclic term, a coupling) through the C ABI.
#[test]
fn c_client_of_a_seven_joint_model_with_an_effect_matches_the_library_in_f64() {
    let text = format!(
        "{}{}",
        crate::common::LBR7_TILTED_PLACED,
        r#"
[[effects]]
kind = "joint-table"
joint = 4
step_deg = 10.0
start_deg = -170.0
values = [0.0002, -0.0004, 0.0003, 0.0005, -0.0001, 0.0002, -0.0003, 0.0004, 0.0001, -0.0002]
[[effects]]
kind = "joint-cyclic"
joint = 2
values = [0.0003, -0.0002]
[[couplings]]
joint = 3
from = 2
ratio = 0.5
"#
    );
    let mut model = RobotFile::parse(&text, "7")
        .unwrap()
        .to_robot::<7>()
        .unwrap();
    assert_eq!(model.effects().len(), 2);
    model
        .set_tool_axes(Frame::from_xyz_rpy([0.0; 3], [-0.3, 0.25, -0.6]))
        .unwrap();
    // Elbow (joint 4) and wrist (joint 6) bent: away from the 7R's singularities.
    let ranges = [
        (-1.5, 1.5),
        (-1.0, 1.0),
        (-1.5, 1.5),
        (0.5, 1.6),
        (-1.5, 1.5),
        (0.5, 1.5),
        (-1.5, 1.5),
    ];
    c_client_matches_f64(&model, ranges, 60, 33);
}

/// Corrected targets for a controller that keeps its nominal kinematics: the pose the nominal
/// robot (placed at the model's base) reaches at the compensated command, fed to the nominal
/// robot's inverse kinematics (the library's compensation on the nominal robot), brings the
/// calibrated robot to the original target.
#[test]
fn nominal_targets_bring_the_calibrated_robot_to_the_target() {
    use kinecal::compensate::{compensate, nominal_target, Config, Target};
    let file = RobotFile::parse(
        &format!("{}{DIAGNOSED}", crate::common::ER20_TILTED_PLACED),
        "t",
    )
    .unwrap();
    let model = file.to_robot::<6>().unwrap();
    // The nominal robot: no tilt, no effects, no coupling, at its own (identity) base.
    let mut nominal_file = RobotFile::parse(crate::common::ER20_PLACED, "n").unwrap();
    nominal_file.base = None;
    let nominal = nominal_file.to_robot::<6>().unwrap();
    let mut placed = nominal.clone();
    placed.set_base(*model.base()).unwrap();
    let cfg = Config::<f64> {
        iterations: 20,
        ..Config::default()
    };
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let (mut worst, mut worst_point, mut moved) = (0.0f64, 0.0f64, 0.0f64);
    let (mut tested, mut skipped) = (0, 0);
    while tested < 100 {
        let qt: [f64; 6] = std::array::from_fn(|j| {
            let range = [
                (-1.5, 1.5),
                (-1.2, -0.2),
                (0.3, 1.2),
                (-1.5, 1.5),
                (0.4, 1.4),
                (-1.5, 1.5),
            ][j];
            rng.random_range(range.0..range.1)
        });
        // Poses where the controller's nominal IK or the model's compensation is singular are no
        // test of the route: both robots' poses at the sampled readings must solve as
        // well-conditioned targets.
        fk.compute(&placed, &qt);
        let own = Target::Pose(fk.tool_pose(&placed));
        fk.compute(&model, &qt);
        let modelled = Target::Pose(fk.tool_pose(&model));
        if compensate(&placed, &own, &qt, &cfg).is_err()
            || compensate(&model, &modelled, &qt, &cfg).is_err()
        {
            skipped += 1;
            assert!(skipped <= 10, "too many singular samples");
            continue;
        }
        tested += 1;
        fk.compute(&model, &qt);
        let goal = fk.tool_pose(&model);
        let seed: [f64; 6] = std::array::from_fn(|j| qt[j] + rng.random_range(-0.005..0.005));
        let (sent, _) = nominal_target(&model, &nominal, &Target::Pose(goal), &seed, &cfg)
            .expect("compensation");
        moved = moved.max((sent.point() - goal.o).norm());
        // The controller: its nominal inverse kinematics of the sent pose.
        let q_nominal = compensate(&placed, &sent, &seed, &cfg).expect("nominal IK");
        fk.compute(&model, &q_nominal.q);
        let reached = fk.tool_pose(&model);
        worst = worst.max((reached.o - goal.o).norm());
        let pe = kinecal::model::frame::orientation_error(&reached, &goal).norm();
        worst_point = worst_point.max(pe);
    }
    println!(
        "nominal targets: moved up to {moved:.3} mm from the targets; the calibrated robot at the \
         nominal IK of the sent pose: worst {worst:.2e} mm, {worst_point:.2e} rad ({skipped} \
         singular samples skipped)"
    );
    assert!(moved > 0.1, "the corrections are real ({moved} mm)");
    assert!(worst < 0.01, "{worst} mm");
    assert!(worst_point < 1e-5, "{worst_point} rad");
}

/// The C route (`kc_compensate_cartesian`, float): for a diagnosed model loaded from its binary
/// model and the nominal robot from its own, the sent points fed to the nominal robot's inverse
/// kinematics (the library's compensation on the nominal robot at the model's base, in f64)
/// bring the calibrated robot to the targets within 0.01 mm.
#[test]
fn c_cartesian_route_brings_the_calibrated_robot_to_the_targets() {
    use kinecal::compensate::{compensate, Config, Target};
    let file = RobotFile::parse(
        &format!("{}{DIAGNOSED}", crate::common::ER20_TILTED_PLACED),
        "t",
    )
    .unwrap();
    let model = file.to_robot::<6>().unwrap();
    // The controller's nominal model reads joint 3 as the model does (the coupling is the
    // controller's convention, not a calibration result).
    let nominal_text = format!(
        "{}\n[[couplings]]\njoint = 3\nfrom = 2\nratio = 1.0\n",
        crate::common::ER20_PLACED
    );
    let mut nominal_file = RobotFile::parse(&nominal_text, "n").unwrap();
    nominal_file.base = None;
    let nominal = nominal_file.to_robot::<6>().unwrap();
    let mut placed = nominal.clone();
    placed.set_base(*model.base()).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(35);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let (mut seeds, mut targets, mut goals) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..40 {
        let qt: [f64; 6] = std::array::from_fn(|j| {
            let r = [
                (-1.5, 1.5),
                (-1.2, -0.2),
                (0.3, 1.2),
                (-1.5, 1.5),
                (0.5, 1.4),
                (-1.5, 1.5),
            ][j];
            rng.random_range(r.0..r.1)
        });
        let p = fk.compute(&model, &qt).map(|v| v as f32 as f64);
        targets.extend(p.iter().map(|v| *v as f32));
        let seed: [f32; 6] =
            std::array::from_fn(|j| (qt[j] + rng.random_range(-0.005..0.005)) as f32);
        seeds.extend(seed);
        goals.push((seed.map(f64::from), p));
    }
    let sent = {
        let _one = kinecal_host::c_abi::C_CLIENT
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        kinecal_host::c_abi::model_cartesian(
            &blob_of(&model),
            &blob_of(&nominal),
            6,
            &seeds,
            &targets,
        )
    }
    .unwrap_or_else(|s| panic!("C route failed at step {}", -s));
    let cfg = Config::<f64> {
        iterations: 30,
        ..Config::default()
    };
    let (mut worst, mut moved) = (0.0f64, 0.0f64);
    for (i, (seed, goal)) in goals.iter().enumerate() {
        let p = Vector3::new(
            sent[3 * i] as f64,
            sent[3 * i + 1] as f64,
            sent[3 * i + 2] as f64,
        );
        moved = moved.max((p - goal).norm());
        let q = compensate(&placed, &Target::Point(p), seed, &cfg)
            .expect("nominal IK")
            .q;
        worst = worst.max((fk.compute(&model, &q) - goal).norm());
    }
    println!(
        "C Cartesian route: sent points up to {moved:.3} mm from the targets; the calibrated robot \
         at the nominal IK of the sent points: worst {worst:.2e} mm"
    );
    assert!(moved > 0.1, "the corrections are real ({moved} mm)");
    assert!(worst < 0.01, "{worst} mm");
}
