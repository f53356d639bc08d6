//! Robot, effects, couplings and stepper settings built from arbitrary numbers.
//!
//! Invariants:
//! - `no-panic`;
//! - `accepted-robot-finite`: `Robot::new` accepts only robots whose numbers are finite and
//!   whose forward kinematics at finite readings is finite;
//! - `error-leaves-unchanged`: a refused `set_joint`/`set_base`/`set_tool`/`set_coupling`/
//!   `Effects::push` changes nothing;
//! - `effect-joint-in-robot`: an effect accepted into a robot's list is on one of its joints;
//! - `lm-config-refused-iff-invalid`, `pso-config-valid`, `bpnn-config-valid`: the steppers'
//!   constructors accept exactly the settings their checks describe, and what they accept
//!   runs finite.

use super::{any_f64, invariant, robot_finite, robot_magnitude, skip, vec_finite};
use arbitrary::Unstructured;
use kinecal::forward::point;
use kinecal::identify::bpnn::{Activation, Bpnn, BpnnConfig};
use kinecal::identify::lm::{FixedLevenberg, LmConfig, LmError};
use kinecal::identify::pso::{Pso, PsoConfig};
use kinecal::model::param::ParamSet;
use kinecal::{EffectKind, Frame, Joint, Robot};
use nalgebra::Vector3;

const N: usize = 3;
type V = kinecal::Inline<12>;

fn joint(u: &mut Unstructured, nominal: &Joint<f64>) -> Joint<f64> {
    Joint {
        alpha: any_f64(u, nominal.alpha, 3.0),
        a: any_f64(u, nominal.a, 1000.0),
        theta: any_f64(u, nominal.theta, 3.0),
        d: any_f64(u, nominal.d, 1000.0),
        beta: any_f64(u, 0.0, 0.1),
        lower: any_f64(u, -3.2, 3.0),
        upper: any_f64(u, 3.2, 3.0),
    }
}

fn fk_finite(r: &Robot<f64, N, V>, u: &mut Unstructured) {
    if skip("robot-huge") && robot_magnitude(r) > 1e100 {
        return;
    }
    let q: [f64; N] = std::array::from_fn(|i| {
        let j = &r.joints()[i];
        let t = super::near(u, 0.5, 0.5);
        j.lower + (j.upper - j.lower) * t
    });
    if q.iter().all(|x| x.is_finite()) {
        let p = point(r, &q);
        invariant!(
            "accepted-robot-finite",
            vec_finite(&p),
            "FK {p:?} at {q:?} of {r:?}"
        );
    }
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let nominal = super::arm3::<V>();
    let rows: [Joint<f64>; N] = std::array::from_fn(|i| joint(&mut u, &nominal.joints()[i]));
    let base = Frame::from_xyz_rpy(
        [
            any_f64(&mut u, 0.0, 1e3),
            any_f64(&mut u, 0.0, 1e3),
            any_f64(&mut u, 0.0, 1e3),
        ],
        [
            any_f64(&mut u, 0.0, 3.0),
            any_f64(&mut u, 0.0, 3.0),
            any_f64(&mut u, 0.0, 3.0),
        ],
    );
    let tool = Vector3::new(
        any_f64(&mut u, 300.0, 300.0),
        any_f64(&mut u, 0.0, 300.0),
        any_f64(&mut u, 0.0, 300.0),
    );
    let mut robot = match Robot::<f64, N, V>::new(base, rows, tool) {
        Ok(r) => {
            if !(skip("robot-huge") && robot_magnitude(&r) > 1e100) {
                invariant!("accepted-robot-finite", robot_finite(&r), "{r:?}");
            }
            fk_finite(&r, &mut u);
            r
        }
        Err(_) => nominal,
    };

    // A sequence of edits; each refused one must change nothing.
    for _ in 0..u.int_in_range(0..=8u8).unwrap_or(0) {
        let before = robot.clone();
        let op = u.int_in_range(0..=4u8).unwrap_or(0);
        let refused = match op {
            0 => {
                let i = u.int_in_range(0..=N).unwrap_or(0);
                let j = joint(&mut u, robot.joint(i.min(N - 1)).unwrap());
                robot.set_joint(i, j).is_err()
            }
            1 => {
                let t = Vector3::new(
                    any_f64(&mut u, 0.0, 500.0),
                    any_f64(&mut u, 0.0, 500.0),
                    any_f64(&mut u, 0.0, 500.0),
                );
                robot.set_tool(t).is_err()
            }
            2 => {
                let mut f = Frame::identity();
                f.o = Vector3::new(
                    any_f64(&mut u, 0.0, 1e3),
                    any_f64(&mut u, 0.0, 1e3),
                    any_f64(&mut u, 0.0, 1e3),
                );
                f.x.x = any_f64(&mut u, 1.0, 0.1);
                robot.set_base(f).is_err()
            }
            3 => {
                let j = u.int_in_range(0..=N).unwrap_or(0);
                let from = u.int_in_range(0..=N).unwrap_or(0);
                let ratio = any_f64(&mut u, 1.0, 2.0);
                robot.set_coupling(j, from, ratio).is_err()
            }
            _ => {
                let kind = [
                    EffectKind::Scale,
                    EffectKind::Cyclic,
                    EffectKind::Compliance,
                    EffectKind::Table,
                    EffectKind::Thermal,
                    EffectKind::Drift,
                ][u.int_in_range(0..=5usize).unwrap_or(0)];
                let joint = u.int_in_range(0..=N + 1).unwrap_or(0);
                let n_joints = if u.ratio(1u8, 4).unwrap_or(false) {
                    N + 2
                } else {
                    N
                };
                let order = u.int_in_range(0..=3u16).unwrap_or(1);
                let start = any_f64(&mut u, -3.0, 1.0);
                let step = any_f64(&mut u, 0.5, 0.5);
                let len = u.int_in_range(0..=5usize).unwrap_or(1);
                let values: Vec<f64> = (0..len).map(|_| any_f64(&mut u, 0.0, 1e-3)).collect();
                match robot
                    .effects_mut()
                    .push(kind, joint, n_joints, order, start, step, &values)
                {
                    Ok(_) => {
                        invariant!(
                            "effect-joint-in-robot",
                            joint < N,
                            "effect on joint {joint} of a {N}-joint robot accepted"
                        );
                        false
                    }
                    Err(_) => true,
                }
            }
        };
        if refused {
            invariant!(
                "error-leaves-unchanged",
                robot == before,
                "op {op}: {before:?} -> {robot:?}"
            );
        } else {
            if !(skip("robot-huge") && robot_magnitude(&robot) > 1e100) {
                invariant!(
                    "accepted-robot-finite",
                    robot_finite(&robot),
                    "after op {op}: {robot:?}"
                );
            }
            fk_finite(&robot, &mut u);
        }
    }

    // LM settings: refused exactly when `is_valid` says so.
    let cfg = LmConfig::<f64> {
        max_iterations: u.int_in_range(0..=50u32).unwrap_or(10),
        cost_tolerance: any_f64(&mut u, 1e-10, 1e-10),
        step_tolerance: any_f64(&mut u, 1e-9, 1e-9),
        rank_tolerance: any_f64(&mut u, 1e-8, 1e-8),
        ridge: any_f64(&mut u, 1e-9, 1e-9),
        initial_damping: any_f64(&mut u, 1e-3, 1e-3),
        max_analyses: u.int_in_range(0..=8u8).unwrap_or(1),
        activation_tolerance: any_f64(&mut u, 1e-4, 1e-4),
        keep_curvature: u.ratio(1u8, 2).unwrap_or(false),
        complete_passes: u.ratio(1u8, 2).unwrap_or(false),
        scale_by_products: u.ratio(1u8, 2).unwrap_or(false),
    };
    let lm = FixedLevenberg::<f64, N, V, 16>::fixed(
        robot.clone(),
        ParamSet::full(N, false).unwrap(),
        cfg,
    );
    invariant!(
        "lm-config-refused-iff-invalid",
        matches!(lm, Err(LmError::Config)) == !cfg.is_valid(),
        "{cfg:?}: {:?}",
        lm.as_ref().err()
    );

    // PSO settings: what is accepted has a finite box and the swarm starts inside it.
    let lower: [f64; 2] = [any_f64(&mut u, -1.0, 1.0), any_f64(&mut u, -1.0, 1.0)];
    let upper: [f64; 2] = [any_f64(&mut u, 1.0, 1.0), any_f64(&mut u, 1.0, 1.0)];
    if let Ok(mut pc) = PsoConfig::new(lower, upper) {
        pc.inertia = any_f64(&mut u, 0.9, 0.5);
        pc.cognitive = any_f64(&mut u, 0.5, 0.5);
        pc.social = any_f64(&mut u, 1.25, 0.5);
        pc.max_velocity = any_f64(&mut u, 0.2, 0.2);
        pc.initial_velocity = any_f64(&mut u, 0.5, 0.5);
        pc.stagnation_tolerance = any_f64(&mut u, 1e-6, 1e-6);
        if let Ok(p) = Pso::<f64, 3, 2, 8>::new(pc, 7) {
            let ok = (0..2).all(|d| {
                pc.lower[d].is_finite() && pc.upper[d].is_finite() && pc.lower[d] < pc.upper[d]
            }) && [
                pc.inertia,
                pc.cognitive,
                pc.social,
                pc.max_velocity,
                pc.initial_velocity,
                pc.stagnation_tolerance,
            ]
            .iter()
            .all(|c| c.is_finite() && *c >= 0.0);
            invariant!("pso-config-valid", ok, "{pc:?}");
            for x in p.positions() {
                invariant!(
                    "pso-config-valid",
                    (0..2).all(|d| x[d] >= pc.lower[d] && x[d] <= pc.upper[d]),
                    "{x:?} outside {pc:?}"
                );
            }
            for v in p.velocities() {
                invariant!("pso-config-valid", v.iter().all(|c| c.is_finite()), "{v:?}");
            }
        }
    }

    // BPNN settings: what is accepted is in range and its net answers finite values.
    let bc = BpnnConfig::<f64> {
        learning_rate: any_f64(&mut u, 0.01, 0.01),
        momentum: any_f64(&mut u, 0.5, 0.6),
        batch: u.int_in_range(0..=4u32).unwrap_or(1),
        activation: if u.ratio(1u8, 2).unwrap_or(false) {
            Activation::Tanh
        } else {
            Activation::Sigmoid
        },
    };
    if let Ok(net) = Bpnn::<f64, 2, 3, 1>::new(bc, 3) {
        let ok = bc.learning_rate.is_finite()
            && bc.learning_rate > 0.0
            && bc.momentum >= 0.0
            && bc.momentum < 1.0
            && bc.batch >= 1;
        invariant!("bpnn-config-valid", ok, "{bc:?}");
        let y = net.forward(&[super::near(&mut u, 0.0, 1e6), 0.5]);
        invariant!("bpnn-config-valid", y[0].is_finite(), "{y:?}");
    }
}
