//! The library's kinematics against the independent reference (`kinecal_host::reference`):
//! forward kinematics in f64 and f32, the identification Jacobian and the joint Jacobian
//! against central differences, every effect kind, 6 and 7 joints, tilt and base poses.

use kinecal::forward::ForwardKinematics;
use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal::{Frame, Joint, Robot};
use kinecal_host::reference::RefRobot;
use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

/// Effect-value capacity of the test robots.
type V = kinecal::Inline<64>;

/// A random robot: rows (alpha, a, theta, d, beta), base (xyz, rpy), tool.
#[derive(Clone, Debug)]
struct Desc {
    rows: Vec<[f64; 5]>,
    base: [f64; 6],
    tool: [f64; 3],
}

/// alpha: often a right angle or zero (industrial arms), sometimes anything.
fn arb_alpha() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(PI / 2.0),
        Just(-PI / 2.0),
        Just(PI),
        -PI..PI,
    ]
}

/// A length: zero or up to `max` mm either way.
fn arb_len(max: f64) -> impl Strategy<Value = f64> {
    prop_oneof![1 => Just(0.0), 3 => -max..max]
}

fn arb_desc(n: usize, max_len: f64, max_base: f64) -> impl Strategy<Value = Desc> {
    let row = (
        arb_alpha(),
        arb_len(max_len),
        -PI..PI,
        arb_len(max_len),
        prop_oneof![Just(0.0), -0.05f64..0.05],
    )
        .prop_map(|(al, a, th, d, b)| [al, a, th, d, b]);
    (
        prop::collection::vec(row, n),
        prop::array::uniform3(-max_base..max_base),
        (-PI..PI, -PI / 2.0..PI / 2.0, -PI..PI),
        prop::array::uniform3(-200.0f64..200.0),
    )
        .prop_map(|(rows, xyz, (r, p, y), tool)| Desc {
            rows,
            base: [xyz[0], xyz[1], xyz[2], r, p, y],
            tool,
        })
}

fn robot<const N: usize>(d: &Desc) -> Robot<f64, N, V> {
    let joints: [Joint<f64>; N] = std::array::from_fn(|i| {
        let [alpha, a, theta, dd, beta] = d.rows[i];
        Joint {
            alpha,
            a,
            theta,
            d: dd,
            beta,
            lower: -PI,
            upper: PI,
        }
    });
    let base = Frame::from_xyz_rpy(
        [d.base[0], d.base[1], d.base[2]],
        [d.base[3], d.base[4], d.base[5]],
    );
    Robot::new(base, joints, Vector3::from(d.tool)).unwrap()
}

fn arb_q(n: usize) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(-1.2 * PI..1.2 * PI, n)
}

fn arr<const N: usize>(q: &[f64]) -> [f64; N] {
    std::array::from_fn(|i| q[i])
}

/// Every geometric parameter of an `n`-joint robot.
fn geometric_params(n: usize) -> Vec<Param> {
    let mut v = vec![
        Param::BaseX,
        Param::BaseY,
        Param::BaseZ,
        Param::BaseRx,
        Param::BaseRy,
        Param::BaseRz,
    ];
    for i in 0..n as u8 {
        v.extend([
            Param::Alpha(i),
            Param::A(i),
            Param::Theta(i),
            Param::D(i),
            Param::Beta(i),
        ]);
    }
    v.extend([Param::ToolX, Param::ToolY, Param::ToolZ]);
    v
}

/// Central differences are good to ~1e-8 mm per unit here; 1e-6 relative + 1e-7 absolute.
fn close(lib: &Vector3<f64>, reference: &Vector3<f64>) -> bool {
    (lib - reference).norm() <= 1e-6 * reference.norm() + 1e-7
}

fn frame_rotation(f: &Frame<f64>) -> Matrix3<f64> {
    f.rotation()
}

/// An effect to add: kind, joint, order, start, step, values.
#[derive(Clone, Debug)]
struct Eff {
    kind: EffectKind,
    joint: usize,
    order: u16,
    start: f64,
    step: f64,
    values: Vec<f64>,
}

fn arb_effect(n: usize, kind: EffectKind) -> impl Strategy<Value = Eff> {
    (
        0..n,
        1u16..5,
        3usize..12,
        prop::collection::vec(-2e-3f64..2e-3, 12),
    )
        .prop_map(move |(joint, order, knots, vals)| {
            let (start, step, len) = match kind {
                EffectKind::Table => (-PI, 2.0 * PI / (knots - 1) as f64, knots),
                EffectKind::Cyclic => (0.0, 0.0, 2),
                _ => (0.0, 0.0, 1),
            };
            Eff {
                kind,
                joint,
                order,
                start,
                step,
                values: vals[..len].to_vec(),
            }
        })
}

fn add<const N: usize>(r: &mut Robot<f64, N, V>, e: &Eff) {
    r.effects_mut()
        .push(e.kind, e.joint, N, e.order, e.start, e.step, &e.values)
        .unwrap();
}

/// True when no table knot is within `margin` rad of the table joint's reading (the
/// correction has a kink there, so differences straddling it are not derivatives).
fn away_from_knots(e: &[Eff], q: &[f64], margin: f64) -> bool {
    e.iter().filter(|e| e.kind == EffectKind::Table).all(|e| {
        let n = e.values.len();
        (0..n).all(|k| (q[e.joint] - (e.start + e.step * k as f64)).abs() > margin)
    })
}

fn check_fk_f64<const N: usize>(d: &Desc, q: &[f64], effects: &[Eff]) -> Result<(), TestCaseError> {
    let mut r = robot::<N>(d);
    for e in effects {
        add(&mut r, e);
    }
    let reference = RefRobot::from_robot(&r);
    let mut fk = ForwardKinematics::<f64, N>::new();
    let p = fk.compute(&r, &arr::<N>(q));
    let pr = reference.point(q);
    prop_assert!(
        (p - pr).norm() <= 1e-9,
        "point {} vs reference {}: {:e} mm",
        p,
        pr,
        (p - pr).norm()
    );
    // The tool orientation and every joint frame.
    let rr = reference.tool_rotation(q);
    prop_assert!((frame_rotation(&fk.tool_pose(&r)) - rr).norm() <= 1e-12);
    let qg = reference.corrected(q);
    let frames = reference.frames_in_base(&qg);
    for (i, f) in frames.iter().enumerate() {
        let t = reference.base * f;
        let o = Vector3::new(t[(0, 3)], t[(1, 3)], t[(2, 3)]);
        prop_assert!(
            (fk.frames[i].o - o).norm() <= 1e-9,
            "origin of frame {}",
            i + 1
        );
        let rot: Matrix3<f64> = t.fixed_view::<3, 3>(0, 0).into_owned();
        prop_assert!(
            (frame_rotation(&fk.frames[i]) - rot).norm() <= 1e-12,
            "axes of frame {}",
            i + 1
        );
    }
    Ok(())
}

fn check_jacobian<const N: usize>(
    d: &Desc,
    q: &[f64],
    effects: &[Eff],
    geometric: bool,
) -> Result<(), TestCaseError> {
    let mut r = robot::<N>(d);
    for e in effects {
        add(&mut r, e);
    }
    let reference = RefRobot::from_robot(&r);
    let mut fk = ForwardKinematics::<f64, N>::new();
    fk.compute(&r, &arr::<N>(q));
    let mut params = if geometric {
        geometric_params(N)
    } else {
        Vec::new()
    };
    params.extend((0..r.effects().values().len()).map(|k| Param::Effect(k as u16)));
    let mut cols = vec![Vector3::zeros(); params.len()];
    fk.identification_jacobian(&r, &params, &mut cols).unwrap();
    for (p, c) in params.iter().zip(&cols) {
        prop_assert_eq!(*c, fk.column(&r, *p).unwrap());
        let want = reference.dp_dparam(q, *p);
        prop_assert!(
            close(c, &want),
            "{}: library {} vs differences {} (|Δ| = {:e})",
            p.name(&r),
            c,
            want,
            (c - want).norm()
        );
    }
    Ok(())
}

fn check_joint_jacobian<const N: usize>(
    d: &Desc,
    q: &[f64],
    effects: &[Eff],
) -> Result<(), TestCaseError> {
    let mut r = robot::<N>(d);
    for e in effects {
        add(&mut r, e);
    }
    let reference = RefRobot::from_robot(&r);
    let mut fk = ForwardKinematics::<f64, N>::new();
    fk.compute(&r, &arr::<N>(q));
    let (lin, ang) = fk.joint_jacobian(&r);
    for j in 0..N {
        let want = reference.dp_dq(q, j);
        prop_assert!(
            close(&lin[j], &want),
            "dp/dq{}: {} vs {}",
            j + 1,
            lin[j],
            want
        );
        let want = reference.dr_dq(q, j);
        prop_assert!(
            (ang[j] - want).norm() <= 1e-8,
            "dR/dq{}: {} vs {}",
            j + 1,
            ang[j],
            want
        );
    }
    Ok(())
}

/// The f32 library against the f64 reference: `(total, arithmetic)` error in mm, where
/// `total` compares with the reference at the exact f64 inputs and `arithmetic` with the
/// reference at the f32-rounded inputs (what the f32 computation was given).
fn f32_error<const N: usize>(d: &Desc, q: &[f64]) -> (f64, f64) {
    let r = robot::<N>(d);
    let r32: Robot<f32, N, V> = r.cast().unwrap();
    let q32: [f32; N] = std::array::from_fn(|i| q[i] as f32);
    let p = ForwardKinematics::<f32, N>::new().compute(&r32, &q32);
    let p = Vector3::new(p.x as f64, p.y as f64, p.z as f64);
    let total = (p - RefRobot::from_robot(&r).point(q)).norm();
    let q_rounded: Vec<f64> = q32.iter().map(|x| *x as f64).collect();
    let arithmetic =
        (p - RefRobot::from_robot(&r32.cast::<f64>().unwrap()).point(&q_rounded)).norm();
    (total, arithmetic)
}

/// Scales a description so that the sum of |a| + |d| and the tool length is at most `reach`.
fn limit_reach(mut d: Desc, reach: f64) -> Desc {
    let s: f64 =
        d.rows.iter().map(|r| r[1].abs() + r[3].abs()).sum::<f64>() + Vector3::from(d.tool).norm();
    if s > reach {
        let k = reach / s;
        for r in d.rows.iter_mut() {
            r[1] *= k;
            r[3] *= k;
        }
        d.tool = d.tool.map(|t| t * k);
    }
    d
}

fn kinds() -> [EffectKind; 4] {
    [
        EffectKind::Scale,
        EffectKind::Cyclic,
        EffectKind::Compliance,
        EffectKind::Table,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fk_f64_matches_reference_6(d in arb_desc(6, 800.0, 3000.0), q in arb_q(6)) {
        check_fk_f64::<6>(&d, &q, &[])?;
    }

    #[test]
    fn fk_f64_matches_reference_7(d in arb_desc(7, 800.0, 3000.0), q in arb_q(7)) {
        check_fk_f64::<7>(&d, &q, &[])?;
    }

    /// f32 on a robot of at most 2 m reach placed within 3 m of the tracker: within 1 µm of
    /// the f64 reference, input rounding to f32 included.
    #[test]
    fn fk_f32_within_a_micrometre(d in arb_desc(6, 800.0, 3000.0), d7 in arb_desc(7, 800.0, 3000.0), q in arb_q(7)) {
        let (e6, _) = f32_error::<6>(&limit_reach(d, 2000.0), &q[..6]);
        prop_assert!(e6 <= 1e-3, "6 joints: {:e} mm", e6);
        let (e7, _) = f32_error::<7>(&limit_reach(d7, 2000.0), &q);
        prop_assert!(e7 <= 1e-3, "7 joints: {:e} mm", e7);
    }

    #[test]
    fn identification_jacobian_6(d in arb_desc(6, 800.0, 3000.0), q in arb_q(6)) {
        check_jacobian::<6>(&d, &q, &[], true)?;
    }

    #[test]
    fn identification_jacobian_7(d in arb_desc(7, 800.0, 3000.0), q in arb_q(7)) {
        check_jacobian::<7>(&d, &q, &[], true)?;
    }

    #[test]
    fn joint_jacobian_6_and_7(d in arb_desc(7, 800.0, 3000.0), q in arb_q(7)) {
        check_joint_jacobian::<7>(&d, &q, &[])?;
        let d6 = Desc { rows: d.rows[..6].to_vec(), ..d };
        check_joint_jacobian::<6>(&d6, &q[..6], &[])?;
    }

    /// Each effect kind alone, then all four together: FK and the effect value columns; the
    /// geometric columns too where the library's Jacobian is exact (no compliance: its lever
    /// arm depends on the geometry, a second-order term the library leaves out).
    #[test]
    fn effects_6(
        d in arb_desc(6, 800.0, 3000.0),
        q in arb_q(6),
        s in arb_effect(6, EffectKind::Scale),
        c in arb_effect(6, EffectKind::Cyclic),
        k in arb_effect(6, EffectKind::Compliance),
        t in arb_effect(6, EffectKind::Table),
    ) {
        let all = [s, c, k, t];
        for (kind, e) in kinds().iter().zip(all.iter()) {
            let one = std::slice::from_ref(e);
            check_fk_f64::<6>(&d, &q, one)?;
            if away_from_knots(one, &q, 1e-2) {
                check_jacobian::<6>(&d, &q, one, *kind != EffectKind::Compliance)?;
                if *kind != EffectKind::Compliance {
                    check_joint_jacobian::<6>(&d, &q, one)?;
                }
            }
        }
        check_fk_f64::<6>(&d, &q, &all)?;
        if away_from_knots(&all, &q, 1e-2) {
            check_jacobian::<6>(&d, &q, &all, false)?;
            check_jacobian::<6>(&d, &q, &all[..2], true)?;
            check_joint_jacobian::<6>(&d, &q, &[all[0].clone(), all[1].clone(), all[3].clone()])?;
        }
    }

    #[test]
    fn effects_7(
        d in arb_desc(7, 800.0, 3000.0),
        q in arb_q(7),
        c in arb_effect(7, EffectKind::Cyclic),
        k in arb_effect(7, EffectKind::Compliance),
        t in arb_effect(7, EffectKind::Table),
    ) {
        let all = [c, k, t];
        check_fk_f64::<7>(&d, &q, &all)?;
        if away_from_knots(&all, &q, 1e-2) {
            check_jacobian::<7>(&d, &q, &all, false)?;
        }
    }

    /// The library's roll/pitch/yaw convention (robot file `rpy_deg`) is the reference's
    /// `Rz(yaw)·Ry(pitch)·Rx(roll)`, and `Frame::rpy` inverts it away from pitch ±90°.
    #[test]
    fn base_rpy_convention(xyz in prop::array::uniform3(-3000.0f64..3000.0), r in -PI..PI, p in -1.5f64..1.5, y in -PI..PI) {
        let f = Frame::from_xyz_rpy(xyz, [r, p, y]);
        let m = kinecal_host::reference::pose_xyz_rpy(xyz, [r, p, y]);
        let rot: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
        prop_assert!((f.rotation() - rot).norm() < 1e-14);
        prop_assert_eq!(f.o, Vector3::from(xyz));
        let back = f.rpy();
        prop_assert!((back[0] - r).abs() < 1e-9 && (back[1] - p).abs() < 1e-9 && (back[2] - y).abs() < 1e-9, "{:?}", back);
    }

    #[test]
    fn sincos_f32_random(x in -4.0 * std::f32::consts::PI..4.0 * std::f32::consts::PI) {
        let (s, c) = kinecal::num::trig::sincos_f32(x);
        let xd = x as f64;
        prop_assert!((s as f64 - xd.sin()).abs() <= 2e-7 && (c as f64 - xd.cos()).abs() <= 2e-7);
    }
}

/// A table reading below the first and above the last knot gets the end value (clamped).
#[test]
fn table_is_clamped_at_the_ends() {
    let d = Desc {
        rows: vec![[0.0, 100.0, 0.0, 50.0, 0.0]; 6],
        base: [0.0; 6],
        tool: [10.0, 0.0, 0.0],
    };
    let mut r = robot::<6>(&d);
    r.effects_mut()
        .push(
            EffectKind::Table,
            2,
            6,
            1,
            -1.0,
            0.5,
            &[0.01, 0.02, -0.03, 0.04, 0.05],
        )
        .unwrap();
    let reference = RefRobot::from_robot(&r);
    for q2 in [-3.0, -1.0, -0.2, 0.7, 1.0, 2.5] {
        let q = [0.1, 0.2, q2, 0.3, 0.4, 0.5];
        let corrected = reference.corrected(&q)[2] - q2;
        let want = if q2 <= -1.0 {
            0.01
        } else if q2 >= 1.0 {
            0.05
        } else {
            corrected
        };
        assert!((corrected - want).abs() < 1e-15);
        let mut fk = ForwardKinematics::<f64, 6>::new();
        fk.compute(&r, &q);
        assert!(
            (fk.q_geometric[2] - q2 - corrected).abs() < 1e-15,
            "q = {q2}"
        );
    }
}

/// The f32 sine and cosine over [−4π, 4π], densely: max error ≤ 2e-7 against f64.
#[test]
fn sincos_f32_sweep() {
    let lim = 4.0 * std::f32::consts::PI;
    let n = 2_000_000;
    let (mut es, mut ec) = (0f64, 0f64);
    for i in 0..=n {
        let x = -lim + 2.0 * lim * (i as f32 / n as f32);
        let (s, c) = kinecal::num::trig::sincos_f32(x);
        es = es.max((s as f64 - (x as f64).sin()).abs());
        ec = ec.max((c as f64 - (x as f64).cos()).abs());
    }
    // Around every multiple of π/4 (quadrant and polynomial boundaries), ±64 ulp.
    for k in -16..=16 {
        let x0 = (k as f64 * std::f64::consts::FRAC_PI_4) as f32;
        let mut x = x0;
        for _ in 0..64 {
            x = f32::from_bits(x.to_bits().wrapping_sub(1));
        }
        for _ in 0..128 {
            let (s, c) = kinecal::num::trig::sincos_f32(x);
            es = es.max((s as f64 - (x as f64).sin()).abs());
            ec = ec.max((c as f64 - (x as f64).cos()).abs());
            x = f32::from_bits(x.to_bits().wrapping_add(1));
        }
    }
    println!("sincos_f32 max error over [-4pi, 4pi]: sin {es:e}, cos {ec:e}");
    assert!(es <= 2e-7 && ec <= 2e-7, "sin {es:e}, cos {ec:e}");
}

/// Any finite angle, however far outside a joint range, gives a sine and cosine in [−1, 1]
/// (beyond ~6.6e6 rad they were ±inf), those of the angle 0 there (documented as
/// not accurate), and NaN only for non-finite input.
#[test]
fn sincos_f32_is_bounded_for_every_finite_input() {
    let mut bits: u32 = 0x4ac0_0000; // 6.3e6, just below the fast path's limit
    let mut checked = 0;
    while f32::from_bits(bits).is_finite() {
        for x in [f32::from_bits(bits), -f32::from_bits(bits)] {
            let (s, c) = kinecal::num::trig::sincos_f32(x);
            assert!(s.abs() <= 1.0 && c.abs() <= 1.0, "x = {x:e}: ({s}, {c})");
            if x.abs() > 7.0e6 {
                assert_eq!((s, c), (0.0, 1.0), "x = {x:e}");
            }
            checked += 1;
        }
        bits += 0x0001_3579; // a few thousand magnitudes up to f32::MAX
    }
    assert!(checked > 1000);
    let (s, c) = kinecal::num::trig::sincos_f32(f32::MAX);
    assert!(s.abs() <= 1.0 && c.abs() <= 1.0);
    for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let (s, c) = kinecal::num::trig::sincos_f32(x);
        assert!(s.is_nan() && c.is_nan(), "{x}");
    }
}

/// The worst f32 error over many random 2-m robots at growing distances from the tracker,
/// printed for the README.
#[test]
fn f32_error_statistics() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    for base in [0.0, 1000.0, 2000.0, 3000.0] {
        let mut runner = TestRunner::deterministic();
        let (mut worst, mut sum, mut worst_a, mut sum_a, n) = (0f64, 0f64, 0f64, 0f64, 20_000);
        for _ in 0..n {
            let mut d = limit_reach(
                arb_desc(6, 800.0, 3000.0)
                    .new_tree(&mut runner)
                    .unwrap()
                    .current(),
                2000.0,
            );
            for c in d.base.iter_mut().take(3) {
                *c *= base / 3000.0;
            }
            let q = arb_q(6).new_tree(&mut runner).unwrap().current();
            let (e, a) = f32_error::<6>(&d, &q);
            worst = worst.max(e);
            sum += e;
            worst_a = worst_a.max(a);
            sum_a += a;
        }
        let (mean, mean_a) = (sum / n as f64, sum_a / n as f64);
        println!("f32 FK error, 2 m reach, base within {base} mm per axis, {n} cases:");
        println!("  total mean {mean:.2e} max {worst:.2e} mm; arithmetic only mean {mean_a:.2e} max {worst_a:.2e} mm");
        assert!(worst <= 1e-3 && worst_a <= 1e-3);
    }
}

#[test]
fn sincos_f64_matches_std_to_an_ulp_or_two() {
    let mut worst: f64 = 0.0;
    let n = 400_000;
    for i in 0..=n {
        let x = -50.0 + 100.0 * i as f64 / n as f64;
        let (s, c) = kinecal::num::trig::sincos_f64(x);
        worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
    }
    for k in -64i32..=64 {
        let x = k as f64 * std::f64::consts::FRAC_PI_4;
        for d in [-2e-16, 0.0, 2e-16] {
            let (s, c) = kinecal::num::trig::sincos_f64(x + d);
            worst = worst
                .max((s - (x + d).sin()).abs())
                .max((c - (x + d).cos()).abs());
        }
    }
    assert!(worst < 4.0 * f64::EPSILON, "max error {worst:e}");
    assert!(kinecal::num::trig::sincos_f64(f64::NAN).0.is_nan());
    let (s, c) = kinecal::num::trig::sincos_f64(1e9);
    assert!((s * s + c * c - 1.0).abs() < 1e-9);
}
