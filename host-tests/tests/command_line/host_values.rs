//! Host models keep their effect values on the heap (`HostValues`): as small as a model without
//! effects whatever their capacity, with the same limits, refusals and numbers as a model that
//! holds the same values inline (the firmware's `Inline<V>`).

use kinecal::forward::ForwardKinematics;
use kinecal::model::effects::EffectError;
use kinecal::{EffectKind, Frame, Inline, Joint, Robot};
use kinecal_cli::{HostRobot, HostValues, VCAP};
use nalgebra::Vector3;
use std::mem::size_of;

/// A UR10-like arm (MDH rows in degrees and millimetres) with an offset tool point.
fn arm() -> HostRobot<6> {
    let rows = [
        Joint::mdh_deg(0.0, 0.0, 0.0, 127.3),
        Joint::mdh_deg(90.0, 0.0, 0.0, 0.0),
        Joint::mdh_deg(0.0, -612.0, 0.0, 0.0),
        Joint::mdh_deg(0.0, -572.3, 0.0, 163.9),
        Joint::mdh_deg(90.0, 0.0, 0.0, 115.7),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 92.2),
    ];
    Robot::new(Frame::identity(), rows, Vector3::new(30.0, -20.0, 80.0)).unwrap()
}

/// `n` table values of a few hundredths of a degree, different at every knot.
fn knots(n: usize, seed: f64) -> Vec<f64> {
    (0..n)
        .map(|k| 4e-4 * (seed + 0.37 * k as f64).sin())
        .collect()
}

#[test]
fn a_host_robot_is_as_small_as_one_without_effects() {
    // The values are behind one vector (pointer, length, capacity) instead of VCAP inline.
    let plain = size_of::<Robot<f64, 7>>();
    assert!(
        size_of::<HostRobot<7>>() <= plain + 3 * size_of::<usize>(),
        "host robot {} bytes, plain model {plain}",
        size_of::<HostRobot<7>>()
    );
    assert!(size_of::<Robot<f64, 7, Inline<VCAP>>>() >= plain + VCAP * size_of::<f64>());
}

#[test]
fn host_values_hold_vcap_values_and_refuse_more_leaving_the_model_unchanged() {
    let mut r = arm();
    let first = knots(VCAP - 3, 0.1);
    let step = 360f64.to_radians() / (first.len() - 1) as f64;
    let e = r.effects_mut();
    e.push(
        EffectKind::Table,
        1,
        6,
        0,
        -180f64.to_radians(),
        step,
        &first,
    )
    .unwrap();
    e.push(EffectKind::Cyclic, 2, 6, 1, 0.0, 0.0, &[2e-4, -1e-4])
        .unwrap();
    let full_but_one = r.clone();
    // Two more values do not fit: refused, nothing changed (not even the spare slots).
    assert_eq!(
        r.effects_mut()
            .push(EffectKind::Cyclic, 3, 6, 2, 0.0, 0.0, &[1e-4, 1e-4]),
        Err(EffectError::Capacity)
    );
    assert_eq!(r, full_but_one);
    // A refused shape leaves it unchanged too.
    assert_eq!(
        r.effects_mut()
            .push(EffectKind::Scale, 3, 6, 0, 0.0, 0.0, &[f64::NAN]),
        Err(EffectError::Shape)
    );
    assert_eq!(r, full_but_one);
    // The last value fits exactly.
    r.effects_mut()
        .push(EffectKind::Scale, 3, 6, 0, 0.0, 0.0, &[3e-5])
        .unwrap();
    assert_eq!(r.effects().values().len(), VCAP);
    assert_eq!(r.effects().values_of(0), &first[..]);
    assert_eq!(r.effects().values_of(1), &[2e-4, -1e-4]);
    assert_eq!(r.effects().values_of(2), &[3e-5]);
    assert_eq!(
        r.effects_mut()
            .push(EffectKind::Scale, 4, 6, 0, 0.0, 0.0, &[1e-5]),
        Err(EffectError::Capacity)
    );
    // A model with fewer inline slots cannot take it; with VCAP inline it can.
    assert_eq!(
        r.with_capacity::<Inline<64>>().unwrap_err(),
        EffectError::Capacity
    );
    assert!(r.with_capacity::<Inline<VCAP>>().is_ok());
}

#[test]
fn heap_and_inline_values_give_bit_identical_kinematics_and_casts() {
    let mut r = arm();
    let table = knots(37, 0.7);
    let step = 350f64.to_radians() / 36.0;
    let e = r.effects_mut();
    e.push(
        EffectKind::Table,
        1,
        6,
        0,
        -175f64.to_radians(),
        step,
        &table,
    )
    .unwrap();
    e.push(EffectKind::Cyclic, 5, 6, 2, 0.0, 0.0, &[3e-4, 1e-4])
        .unwrap();
    e.push(EffectKind::Scale, 0, 6, 0, 0.0, 0.0, &[2e-5])
        .unwrap();
    let inline: Robot<f64, 6, Inline<VCAP>> = r.with_capacity().unwrap();
    let back: HostRobot<6> = inline.with_capacity().unwrap();
    assert_eq!(back, r, "heap -> inline -> heap is the same model");
    let (mut fk_heap, mut fk_inline) = (ForwardKinematics::new(), ForwardKinematics::new());
    for k in 0..200 {
        let q: [f64; 6] = core::array::from_fn(|j| (1.3 * k as f64 + 0.7 * j as f64).sin() * 3.0);
        assert_eq!(
            fk_heap.compute(&r, &q),
            fk_inline.compute(&inline, &q),
            "pose {k}"
        );
        assert_eq!(
            r.effects().correction(&q, &[0.0; 6]),
            inline.effects().correction(&q, &[0.0; 6])
        );
    }
    let heap32: Robot<f32, 6, HostValues> = r.cast().unwrap();
    let inline32: Robot<f32, 6, Inline<VCAP>> = inline.cast().unwrap();
    assert_eq!(heap32.effects().values(), inline32.effects().values());
    assert_eq!(heap32.effects().values().len(), table.len() + 3);
}
