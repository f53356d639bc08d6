//! Forward kinematics and its Jacobians on accepted robots.
//!
//! Invariants:
//! - `no-panic`;
//! - `fk-finite`: for an accepted robot and finite readings the point, the tool pose, the joint
//!   Jacobian and the identification Jacobian (all parameters) are finite;
//! - `jacobian-matches-fd`: on a moderate robot (lengths ≤ 1e4 mm, readings within ±2π, no
//!   table effects, which have kinks, effect values within ±0.1 and coupling ratios within ±10,
//!   which multiply the difference step, and no compliance term, whose lever arms the geometric
//!   columns hold fixed by design: `ForwardKinematics::identification_jacobian`) the joint
//!   Jacobian and the identification columns of the row, tool and base-origin parameters match
//!   central finite differences.

use super::{finite_f64, invariant, near, robot_magnitude, skip, vec_finite};
use arbitrary::Unstructured;
use kinecal::model::param::{Param, ParamSet};
use kinecal::{EffectKind, ForwardKinematics, Frame, Joint, Robot};
use nalgebra::Vector3;

/// The spread of moderate joint readings (rad): about a turn, as the corpus was generated.
#[allow(clippy::approx_constant)]
const TURN: f64 = 6.28;

const N: usize = 6;
type V = kinecal::Inline<16>;

fn fd_param(robot: &Robot<f64, N, V>, q: &[f64; N], p: Param, h: f64) -> Option<Vector3<f64>> {
    let eval = |s: f64| -> Option<Vector3<f64>> {
        let mut r = robot.clone();
        match p {
            Param::A(i) | Param::D(i) | Param::Alpha(i) | Param::Theta(i) | Param::Beta(i) => {
                let mut j = *r.joint(i as usize)?;
                match p {
                    Param::A(_) => j.a += s,
                    Param::D(_) => j.d += s,
                    Param::Alpha(_) => j.alpha += s,
                    Param::Theta(_) => j.theta += s,
                    _ => j.beta += s,
                }
                r.set_joint(i as usize, j).ok()?;
            }
            Param::ToolX | Param::ToolY | Param::ToolZ => {
                let mut t = *r.tool();
                let k = [Param::ToolX, Param::ToolY, Param::ToolZ]
                    .iter()
                    .position(|x| *x == p)?;
                t[k] += s;
                r.set_tool(t).ok()?;
            }
            Param::BaseX | Param::BaseY | Param::BaseZ => {
                let mut b = *r.base();
                let k = [Param::BaseX, Param::BaseY, Param::BaseZ]
                    .iter()
                    .position(|x| *x == p)?;
                b.o[k] += s;
                r.set_base(b).ok()?;
            }
            _ => return None,
        }
        Some(ForwardKinematics::new().compute(&r, q))
    };
    Some((eval(h)? - eval(-h)?) / (2.0 * h))
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let nominal = super::ur10::<V>();
    let moderate_input = u.ratio(3u8, 4).unwrap_or(true);
    let num = |u: &mut Unstructured, c: f64, s: f64| {
        if moderate_input {
            near(u, c, s)
        } else {
            finite_f64(u, c, s)
        }
    };
    let rows: [Joint<f64>; N] = std::array::from_fn(|i| {
        let j = nominal.joints()[i];
        Joint {
            alpha: num(&mut u, j.alpha, 0.05),
            a: num(&mut u, j.a, 10.0),
            theta: num(&mut u, j.theta, 0.05),
            d: num(&mut u, j.d, 10.0),
            beta: num(&mut u, 0.0, 0.01),
            lower: j.lower,
            upper: j.upper,
        }
    });
    let base = Frame::from_xyz_rpy(
        [
            num(&mut u, 0.0, 2e3),
            num(&mut u, 0.0, 2e3),
            num(&mut u, 0.0, 2e3),
        ],
        [
            num(&mut u, 0.0, 3.0),
            num(&mut u, 0.0, 3.0),
            num(&mut u, 0.0, 3.0),
        ],
    );
    let tool = Vector3::new(
        num(&mut u, 0.0, 100.0),
        num(&mut u, 0.0, 100.0),
        num(&mut u, 109.0, 100.0),
    );
    let Ok(mut robot) = Robot::<f64, N, V>::new(base, rows, tool) else {
        return;
    };
    let mut tables = false;
    for _ in 0..u.int_in_range(0..=3u8).unwrap_or(0) {
        let kind = [
            EffectKind::Scale,
            EffectKind::Cyclic,
            EffectKind::Compliance,
            EffectKind::Table,
        ][u.int_in_range(0..=3usize).unwrap_or(0)];
        let j = u.int_in_range(0..=N - 1).unwrap_or(0);
        let len = match kind {
            EffectKind::Cyclic => 2,
            EffectKind::Table => 4,
            _ => 1,
        };
        let values: Vec<f64> = (0..len).map(|_| num(&mut u, 0.0, 1e-3)).collect();
        let order = u.int_in_range(1..=3u16).unwrap_or(1);
        if robot
            .effects_mut()
            .push(kind, j, N, order, -3.0, 2.0, &values)
            .is_ok()
        {
            // Tables have kinks; compliance makes the geometric columns approximate (the
            // lever arms are held fixed): neither is compared with finite differences.
            tables |= matches!(kind, EffectKind::Table | EffectKind::Compliance);
        }
    }
    if u.ratio(1u8, 4).unwrap_or(false) {
        let _ = robot.set_coupling(2, 1, num(&mut u, 1.0, 0.5));
    }
    let q: [f64; N] = std::array::from_fn(|_| {
        if moderate_input {
            near(&mut u, 0.0, TURN)
        } else {
            finite_f64(&mut u, 0.0, TURN)
        }
    });
    if skip("robot-huge") && robot_magnitude(&robot) > 1e100 {
        return;
    }

    let mut fk = ForwardKinematics::<f64, N>::new();
    let p = fk.compute(&robot, &q);
    invariant!(
        "fk-finite",
        vec_finite(&p),
        "point {p:?} at {q:?} of {robot:?}"
    );
    let pose = fk.tool_pose(&robot);
    invariant!(
        "fk-finite",
        [pose.x, pose.y, pose.z, pose.o].iter().all(vec_finite),
        "pose {pose:?}"
    );
    let (lin, ang) = fk.joint_jacobian(&robot);
    invariant!(
        "fk-finite",
        lin.iter().chain(ang.iter()).all(vec_finite),
        "joint Jacobian {lin:?} {ang:?}"
    );
    let params = ParamSet::<64>::full(N, true)
        .unwrap()
        .with_effects(&robot)
        .unwrap();
    let mut cols = vec![Vector3::zeros(); params.len()];
    let r = fk.identification_jacobian(&robot, &params, &mut cols);
    invariant!("fk-finite", r.is_ok(), "{r:?}");
    invariant!(
        "fk-finite",
        cols.iter().all(vec_finite),
        "identification Jacobian {cols:?}"
    );

    // A scale effect v or a coupling ratio r multiplies the finite-difference step (the angle
    // moves by (1 + v)·h): with v ≈ −8,577 the O(h²) error of the central difference reached
    // 1.2e-5 of the column, a false alarm. Compare where the step stays small.
    let gains_small = robot.effects().values().iter().all(|v| v.abs() <= 0.1)
        && (0..N).all(|j| {
            robot
                .couplings()
                .get(j)
                .is_none_or(|(_, r)| r.abs() <= 10.0)
        });
    let moderate = robot_magnitude(&robot) <= 1e4
        && q.iter().all(|x| x.abs() <= 7.0)
        && !tables
        && gains_small;
    if !moderate {
        return;
    }
    let scale = robot.reach() + p.norm();
    let tol = 1e-5 * scale;
    for j in 0..N {
        let h = 1e-6;
        let mut qp = q;
        let mut qm = q;
        qp[j] += h;
        qm[j] -= h;
        let fd = (ForwardKinematics::new().compute(&robot, &qp)
            - ForwardKinematics::new().compute(&robot, &qm))
            / (2.0 * h);
        invariant!(
            "jacobian-matches-fd",
            (fd - lin[j]).norm() <= tol,
            "joint {j}: analytic {:?}, fd {fd:?} at {q:?} of {robot:?}",
            lin[j]
        );
    }
    for (k, prm) in params.iter().enumerate() {
        let h = if prm.is_length() { 1e-4 } else { 1e-6 };
        if let Some(fd) = fd_param(&robot, &q, *prm, h) {
            let tol = if prm.is_length() {
                1e-6 * (1.0 + cols[k].norm())
            } else {
                tol
            };
            invariant!(
                "jacobian-matches-fd",
                (fd - cols[k]).norm() <= tol,
                "{prm:?}: analytic {:?}, fd {fd:?}",
                cols[k]
            );
        }
    }
}
