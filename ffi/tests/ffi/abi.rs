//! The wrappers against the library they wrap: the same numbers bit for bit (forward
//! kinematics, Jacobian, an LM run step by step, compensation, CSV), and the checks a C caller
//! relies on (NULL, alignment, initialisation).

use kinecal::compensate::{compensate, Config, Target, Tracker};
use kinecal::identify::lm::{FixedLm, Levenberg, LmConfig};
use kinecal::io::csv::CsvReader;
use kinecal::model::param::ParamSet;
use kinecal::{ForwardKinematics, Frame, Joint, Measurement, Robot};
use kinecal_ffi::*;
use nalgebra::Vector3;
use std::ffi::c_void;

const ROWS: [(f64, f64, f64, f64); 6] = [
    (0.0, 0.0, 0.0, 504.0),
    (-90.0, 170.0, -90.0, 0.0),
    (0.0, 780.0, 0.0, 0.0),
    (-90.0, 140.0, 0.0, 760.0),
    (90.0, 0.0, 0.0, 0.0),
    (-90.0, 0.0, 0.0, 125.0),
];
const TOOL: [f32; 3] = [40.0, 30.0, 120.0];

fn joints(perturb: f32) -> [Joint<f32>; 6] {
    let mut k = 0.0f32;
    ROWS.map(|(al, a, th, d)| {
        k += 1.0;
        let mut j = Joint::mdh_deg(al, a, th, d);
        j.a += perturb * (0.3 - 0.1 * k);
        j.theta += perturb * 1e-3 * k;
        j
    })
}

fn lib_robot(perturb: f32) -> Robot<f32, 6> {
    Robot::new(Frame::identity(), joints(perturb), Vector3::from(TOOL)).expect("robot")
}

fn rows_of(j: &[Joint<f32>; 6]) -> [kc_joint_row; 6] {
    j.map(|j| kc_joint_row {
        alpha_rad: j.alpha,
        a_mm: j.a,
        theta_rad: j.theta,
        d_mm: j.d,
        beta_rad: j.beta,
        lower_rad: j.lower,
        upper_rad: j.upper,
    })
}

/// A zeroed (not initialised) handle on the heap.
fn handle<T>() -> Box<T> {
    // SAFETY: every handle type is a byte array: all zeros is a valid value.
    Box::new(unsafe { std::mem::zeroed() })
}

fn abi_robot(perturb: f32) -> Box<kc_robot> {
    let mut r = handle::<kc_robot>();
    let rows = rows_of(&joints(perturb));
    // SAFETY: valid pointers of the documented sizes.
    let s = unsafe { kc_robot_init(&mut *r, 6, rows.as_ptr(), std::ptr::null(), TOOL.as_ptr()) };
    assert_eq!(s, KC_OK);
    r
}

/// Deterministic joint readings around a mid pose.
fn poses(n: usize, seed: u32) -> Vec<[f32; 6]> {
    let mut x = seed;
    (0..n)
        .map(|_| {
            core::array::from_fn(|j| {
                x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let u = (x >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0;
                ([20.0f32, -70.0, 20.0, 30.0, 45.0, -30.0][j] + 40.0 * u).to_radians()
            })
        })
        .collect()
}

#[test]
fn forward_kinematics_and_jacobian_are_the_library_s_bit_for_bit() {
    let robot = lib_robot(0.0);
    let r = abi_robot(0.0);
    let mut w = handle::<kc_fk>();
    let mut fk = ForwardKinematics::<f32, 6>::new();
    let set = ParamSet::<24>::mdh(6).expect("set");
    let mut codes = [kc_param::default(); 24];
    let mut pset = handle::<kc_param_set>();
    // SAFETY: valid pointers of the documented sizes (here and below).
    unsafe {
        assert_eq!(kc_fk_init(&mut *w), KC_OK);
        assert_eq!(kc_params_mdh(codes.as_mut_ptr()), KC_OK);
        assert_eq!(kc_param_set_init(&mut *pset, codes.as_ptr(), 24), KC_OK);
    }
    for q in poses(20, 1) {
        let want = fk.compute(&robot, &q);
        let pose = fk.flange_pose();
        let mut cols = [Vector3::zeros(); 24];
        fk.identification_jacobian(&robot, set.as_slice(), &mut cols)
            .expect("jacobian");
        let (mut p, mut p2, mut rot) = ([0.0f32; 3], [0.0f32; 3], [0.0f32; 9]);
        let (mut jac, mut jac2) = ([0.0f32; 72], [0.0f32; 72]);
        // SAFETY: as above.
        unsafe {
            assert_eq!(kc_fk_point(&mut *w, &*r, q.as_ptr(), p.as_mut_ptr()), KC_OK);
            assert_eq!(
                kc_fk_jacobian(&*w, &*r, codes.as_ptr(), 24, jac.as_mut_ptr(), 72),
                KC_OK
            );
            assert_eq!(
                kc_fk_jacobian_set(&*w, &*r, &*pset, jac2.as_mut_ptr(), 72),
                KC_OK
            );
            assert_eq!(
                kc_fk_pose(&mut *w, &*r, q.as_ptr(), p2.as_mut_ptr(), rot.as_mut_ptr()),
                KC_OK
            );
        }
        assert_eq!(
            p.map(f32::to_bits),
            [want.x, want.y, want.z].map(f32::to_bits)
        );
        assert_eq!(p2.map(f32::to_bits), p.map(f32::to_bits));
        let r3 = pose.rotation();
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(rot[3 * i + j].to_bits(), r3[(i, j)].to_bits());
            }
        }
        for (k, c) in cols.iter().enumerate() {
            for a in 0..3 {
                assert_eq!(jac[3 * k + a].to_bits(), c[a].to_bits());
                assert_eq!(jac2[3 * k + a].to_bits(), c[a].to_bits());
            }
        }
    }
}

#[test]
fn an_lm_run_is_the_library_s_step_by_step() {
    let truth = lib_robot(1.0);
    let mut fk = ForwardKinematics::<f32, 6>::new();
    let data: Vec<Measurement<f32, 6>> = poses(40, 7)
        .into_iter()
        .map(|q| Measurement {
            q,
            point: fk.compute(&truth, &q),
            ..Default::default()
        })
        .collect();
    let c_data: Vec<kc_measurement> = data
        .iter()
        .map(|m| kc_measurement {
            q: std::array::from_fn(|j| m.q.get(j).copied().unwrap_or(0.0)),
            xyz_mm: [m.point.x, m.point.y, m.point.z],
        })
        .collect();
    let set = ParamSet::<24>::mdh(6).expect("set");
    let mut lib = Levenberg::new(
        lib_robot(0.0),
        FixedLm::<f32, 24>::new(set),
        LmConfig::default(),
    )
    .expect("solver");
    let start = abi_robot(0.0);
    let mut lm = handle::<kc_lm>();
    let mut codes = [kc_param::default(); 24];
    let mut out = handle::<kc_robot>();
    // SAFETY: valid pointers of the documented sizes (here and below).
    unsafe {
        assert_eq!(kc_params_mdh(codes.as_mut_ptr()), KC_OK);
        assert_eq!(
            kc_lm_init(&mut *lm, &*start, codes.as_ptr(), 24, std::ptr::null()),
            KC_OK
        );
    }
    for _ in 0..10_000 {
        let want = lib.step(&data, 3).expect("step");
        let mut got = kc_lm_progress::default();
        // SAFETY: as above.
        let s = unsafe { kc_lm_step(&mut *lm, c_data.as_ptr(), c_data.len(), 3, &mut got) };
        assert_eq!(s, KC_OK);
        assert_eq!(got.iteration, want.iteration);
        assert_eq!(got.evaluations, want.evaluations);
        assert_eq!(got.cost.to_bits(), want.cost.to_bits());
        assert_eq!(got.stopped != 0, want.stopped.is_some());
        if want.stopped.is_some() {
            break;
        }
    }
    assert!(lib.progress().stopped.is_some());
    let mut rows = [kc_joint_row::default(); 6];
    // SAFETY: as above.
    unsafe {
        assert_eq!(kc_lm_robot(&*lm, &mut *out), KC_OK);
        assert_eq!(
            kc_robot_rows(
                &*out,
                rows.as_mut_ptr(),
                std::ptr::null_mut(),
                std::ptr::null_mut()
            ),
            KC_OK
        );
    }
    assert_eq!(rows, rows_of(lib.robot().joints()));
}

#[test]
fn compensation_and_tracking_are_the_library_s_bit_for_bit() {
    let model = lib_robot(1.0);
    let nominal = lib_robot(0.0);
    let r = abi_robot(1.0);
    let mut fk = ForwardKinematics::<f32, 6>::new();
    let mut tracker = Tracker::new(Config::default());
    let mut t = handle::<kc_tracker>();
    // SAFETY: valid pointers (here and below).
    assert_eq!(unsafe { kc_tracker_init(&mut *t, std::ptr::null()) }, KC_OK);
    for (k, q) in poses(10, 3).into_iter().enumerate() {
        fk.compute(&nominal, &q);
        let pose = fk.flange_pose();
        let target = if k % 2 == 0 {
            Target::Pose(pose)
        } else {
            Target::Point(pose.o)
        };
        let r3 = pose.rotation();
        let c_target = kc_target {
            kind: if k % 2 == 0 { 1 } else { 0 }, // pose, point
            xyz_mm: [pose.o.x, pose.o.y, pose.o.z],
            rot: core::array::from_fn(|i| r3[(i / 3, i % 3)]),
        };
        let want = compensate(&model, &target, &q, &Config::default());
        let want_t = tracker.next(&model, &target, &q);
        let (mut got, mut got_t) = (kc_solution::default(), kc_solution::default());
        // SAFETY: as above.
        let (s, s_t) = unsafe {
            (
                kc_compensate(&*r, &c_target, q.as_ptr(), std::ptr::null(), &mut got),
                kc_tracker_next(&mut *t, &*r, &c_target, q.as_ptr(), &mut got_t),
            )
        };
        for (w, g, s) in [(want, got, s), (want_t, got_t, s_t)] {
            let (want_status, w) = match &w {
                Ok(w) => (KC_OK, *w),
                Err(e) => (
                    KC_COMPENSATE_FAILED,
                    *e.best().expect("a command was computed"),
                ),
            };
            assert_eq!(s, want_status);
            let bits: Vec<u32> = g.q[..6].iter().map(|v| v.to_bits()).collect();
            assert_eq!(bits, w.q.map(f32::to_bits));
            assert_eq!(g.q[6], 0.0);
            assert_eq!(g.position_error_mm.to_bits(), w.position_error.to_bits());
            assert_eq!(g.iterations, u32::from(w.iterations));
        }
    }
}

struct Mem<'a> {
    data: &'a [u8],
}

unsafe extern "C" fn mem_read(ctx: *mut c_void, buf: *mut u8, len: usize) -> usize {
    // SAFETY: `ctx` is the `Mem` passed to kc_csv_init, alive for the reader's use.
    let m = unsafe { &mut *ctx.cast::<Mem>() };
    let n = len.min(m.data.len()).min(5);
    // SAFETY: the reader hands `len` >= n writable bytes.
    unsafe { std::ptr::copy_nonoverlapping(m.data.as_ptr(), buf, n) };
    m.data = &m.data[n..];
    n
}

#[test]
fn csv_records_are_the_library_s() {
    let text = b"q1,q2,q3,q4,q5,q6,x,y,z,t\n1,2,3,4,5,6,7.25,8,9,20\n\
                 0.1,-0.2,0.3,-0.4,0.5,-0.6,1e3,-2e2,3.5,\n1,2,3\n9,8,7,6,5,4,3,2,1,0\n";
    let mut lib = CsvReader::<&[u8], 6, 256, 8>::new(&text[..]).expect("header");
    let mut mem = Mem { data: &text[..] };
    let mut c = handle::<kc_csv>();
    // SAFETY: `mem` outlives the reader's use; pointers valid (here and below).
    assert_eq!(
        unsafe { kc_csv_init(&mut *c, Some(mem_read), (&raw mut mem).cast()) },
        KC_OK
    );
    loop {
        let want = lib.next_record();
        let mut m = kc_measurement::default();
        let mut extra = [0.0f64; 1];
        let mut line = 0u32;
        // SAFETY: as above.
        let s = unsafe { kc_csv_next(&mut *c, &mut m, extra.as_mut_ptr(), 1, &mut line) };
        match want {
            None => {
                assert_eq!(s, KC_END);
                break;
            }
            Some(Err(e)) => {
                assert_eq!((s, line), (KC_CSV_ERROR, e.line));
            }
            Some(Ok(r)) => {
                let w: Measurement<f32, 6> = r.measurement();
                assert_eq!(s, KC_OK);
                let bits: Vec<u32> = m.q[..6].iter().map(|v| v.to_bits()).collect();
                assert_eq!(bits, w.q.map(f32::to_bits));
                assert_eq!(m.q[6], 0.0);
                assert_eq!(m.xyz_mm, [w.point.x, w.point.y, w.point.z]);
                assert_eq!(extra[0].to_bits(), r.extra[0].to_bits());
                assert_eq!(line, r.line);
            }
        }
    }
}

#[test]
fn handles_are_checked_for_null_alignment_and_initialisation() {
    let r = abi_robot(0.0);
    let never = handle::<kc_robot>();
    let q = [0.0f32; 6];
    let mut p = [0.0f32; 3];
    let mut w = handle::<kc_fk>();
    // A handle 4 bytes off its alignment (inside a larger buffer; never dereferenced).
    let mut buf = vec![0u64; KC_FK_SIZE / 8 + 2];
    let misaligned = buf
        .as_mut_ptr()
        .cast::<u8>()
        .wrapping_add(4)
        .cast::<kc_fk>();
    // SAFETY: the wrappers check every pointer before use (that is what is tested).
    unsafe {
        assert_eq!(kc_fk_init(&mut *w), KC_OK);
        assert_eq!(kc_fk_init(misaligned), KC_MISALIGNED);
        assert_eq!(kc_fk_init(std::ptr::null_mut()), KC_NULL_POINTER);
        assert_eq!(
            kc_fk_point(misaligned, &*r, q.as_ptr(), p.as_mut_ptr()),
            KC_MISALIGNED
        );
        assert_eq!(
            kc_fk_point(&mut *w, &*never, q.as_ptr(), p.as_mut_ptr()),
            KC_NOT_INITIALIZED
        );
        assert_eq!(
            kc_fk_point(&mut *w, std::ptr::null(), q.as_ptr(), p.as_mut_ptr()),
            KC_NULL_POINTER
        );
        let misaligned_q = buf
            .as_ptr()
            .cast::<u8>()
            .wrapping_add(2)
            .cast::<kc_measurement>();
        let mut rms = 0.0f32;
        assert_eq!(kc_rms_error(&*r, misaligned_q, 3, &mut rms), KC_MISALIGNED);
        assert_eq!(
            kc_rms_error(&*r, std::ptr::null(), usize::MAX, &mut rms),
            KC_NULL_POINTER
        );
        let huge = [kc_measurement::default(); 1];
        assert_eq!(
            kc_rms_error(&*r, huge.as_ptr(), usize::MAX / 8, &mut rms),
            KC_INVALID_ARGUMENT
        );
    }
    // Every status has a message.
    for s in 0..=17 {
        // SAFETY: the messages are static NUL-terminated strings.
        let m = unsafe { std::ffi::CStr::from_ptr(kc_status_message(s)) };
        assert!(!m.to_bytes().is_empty() && m.to_bytes() != b"unknown status");
    }
}

/// A model with a thermal-expansion term, loaded from its binary form, compensated at the
/// temperature the configuration gives (`at_temperature`, `temperature_c`): the library's
/// command at that temperature bit for bit, and at 35 °C not the command at the reference.
/// A default configuration compensates at the reference; a flag other than 0 or 1 and a
/// non-finite temperature are refused.
#[test]
fn compensation_at_a_temperature_is_the_library_s() {
    use kinecal::io::model_blob;
    use kinecal::model::effects::EffectKind;
    let mut model: Robot<f32, 6, kinecal::Inline<KC_MAX_EFFECT_VALUES>> =
        lib_robot(1.0).with_capacity().expect("capacity");
    // Steel, referred to 20 °C.
    model
        .effects_mut()
        .push(EffectKind::Thermal, 0, 6, 0, 20.0, 0.0, &[1.2e-5])
        .expect("thermal term");
    let mut blob = vec![0u8; model_blob::encoded_len(&model)];
    model_blob::encode(&model, &mut blob).expect("encoded");
    let mut r = handle::<kc_robot>();
    // SAFETY: valid pointers (here and below).
    assert_eq!(
        unsafe { kc_robot_load(&mut *r, blob.as_ptr(), blob.len()) },
        KC_OK
    );
    let nominal = lib_robot(0.0);
    let mut fk = ForwardKinematics::<f32, 6>::new();
    let mut c_cfg = kc_compensate_config::from(Config::<f32>::default());
    assert_eq!((c_cfg.at_temperature, c_cfg.temperature_c), (0, 0.0));
    c_cfg.at_temperature = 1;
    c_cfg.temperature_c = 35.0;
    let warm = Config {
        temperature_c: Some(35.0),
        ..Config::default()
    };
    let mut moved = 0.0f32;
    for q in poses(8, 5) {
        fk.compute(&nominal, &q);
        let p = fk.flange_pose().o;
        let target = Target::Point(p);
        let c_target = kc_target {
            kind: 0,
            xyz_mm: [p.x, p.y, p.z],
            rot: [0.0; 9],
        };
        let want = compensate(&model, &target, &q, &warm).expect("compensated");
        let at_reference = compensate(&model, &target, &q, &Config::default()).expect("ok");
        let (mut got, mut got_ref) = (kc_solution::default(), kc_solution::default());
        // SAFETY: as above.
        let (s, s_ref) = unsafe {
            (
                kc_compensate(&*r, &c_target, q.as_ptr(), &c_cfg, &mut got),
                kc_compensate(&*r, &c_target, q.as_ptr(), std::ptr::null(), &mut got_ref),
            )
        };
        assert_eq!((s, s_ref), (KC_OK, KC_OK));
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got.q[..6]), bits(&want.q));
        assert_eq!(bits(&got_ref.q[..6]), bits(&at_reference.q));
        moved = moved.max(
            want.q
                .iter()
                .zip(&at_reference.q)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f32::max),
        );
    }
    // 15 K of steel moves the commands by tens of µrad: the temperature was used.
    assert!(moved > 1e-5, "largest change {moved} rad");
    let q = poses(1, 5)[0];
    let c_target = kc_target {
        kind: 0,
        xyz_mm: [1000.0, 0.0, 1000.0],
        rot: [0.0; 9],
    };
    for (bad, why) in [
        (
            kc_compensate_config {
                at_temperature: 2,
                ..c_cfg
            },
            KC_INVALID_ARGUMENT,
        ),
        (
            kc_compensate_config {
                temperature_c: f32::NAN,
                ..c_cfg
            },
            KC_NOT_FINITE,
        ),
        // A sensor reading no arm works at (broken, or in kelvin or °F): refused, not a
        // command 7.7 mm off with KC_OK.
        (
            kc_compensate_config {
                temperature_c: -273.15,
                ..c_cfg
            },
            KC_INVALID_ARGUMENT,
        ),
        (
            kc_compensate_config {
                temperature_c: 151.0,
                ..c_cfg
            },
            KC_INVALID_ARGUMENT,
        ),
    ] {
        let mut got = kc_solution::default();
        // SAFETY: as above.
        let s = unsafe { kc_compensate(&*r, &c_target, q.as_ptr(), &bad, &mut got) };
        assert_eq!(s, why);
    }
}
