//! Compensation (damped Newton on the identified model) and the tracker.
//!
//! Invariants:
//! - `no-panic`;
//! - `invalid-input-refused`: non-finite seeds, targets or settings give `InvalidInput`;
//! - `solution-safe`: every command returned (success or the best of an error) is finite and
//!   within `max_step` of the seed (to rounding); a success has a finite error below `accept`
//!   that matches the model's point at the command;
//! - `tracker-recovers`: after any error the tracker still follows a reachable target.

use super::{any_f64, invariant, near};
use arbitrary::Unstructured;
use kinecal::compensate::{compensate, CompensateError, Config, Solution, Target, Tracker};
use kinecal::forward::point;
use kinecal::Frame;
use nalgebra::Vector3;

const N: usize = 6;

fn check(
    r: &Result<Solution<f64, N>, CompensateError<f64, N>>,
    seed: &[f64; N],
    cfg: &Config<f64>,
    robot: &kinecal::Robot<f64, N, kinecal::Inline<0>>,
    target: &Target<f64>,
) {
    let sol = match r {
        Ok(s) => s,
        Err(e) => match e.best() {
            Some(s) => s,
            None => return,
        },
    };
    invariant!(
        "solution-safe",
        sol.q.iter().all(|x| x.is_finite()),
        "{sol:?}"
    );
    for i in 0..N {
        let slack = cfg.max_step * 1e-9 + 4.0 * f64::EPSILON * seed[i].abs().max(1.0);
        invariant!(
            "solution-safe",
            (sol.q[i] - seed[i]).abs() <= cfg.max_step + slack,
            "joint {i}: {:?} from seed {:?}, max_step {}",
            sol.q,
            seed,
            cfg.max_step
        );
    }
    if r.is_ok() {
        invariant!(
            "solution-safe",
            sol.position_error.is_finite() && sol.position_error <= cfg.accept * (1.0 + 1e-9),
            "{sol:?}"
        );
        let p = point(robot, &sol.q);
        let err = (p - target.point()).norm();
        invariant!(
            "solution-safe",
            (err - sol.position_error).abs() <= 1e-6 * (1.0 + p.norm()),
            "reported {}, actual {err}",
            sol.position_error
        );
    }
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let robot = super::ur10::<kinecal::Inline<0>>();
    let q_true: [f64; N] = std::array::from_fn(|_| near(&mut u, 0.0, 3.0));
    let seed: [f64; N] = std::array::from_fn(|i| {
        if u.ratio(1u8, 8).unwrap_or(false) {
            any_f64(&mut u, 0.0, 1e3)
        } else {
            q_true[i] + near(&mut u, 0.0, 0.05)
        }
    });
    let p = point(&robot, &q_true);
    let target = match u.int_in_range(0..=3u8).unwrap_or(0) {
        0 => Target::Point(p),
        1 => Target::Point(Vector3::new(
            any_f64(&mut u, p.x, 10.0),
            any_f64(&mut u, p.y, 10.0),
            any_f64(&mut u, p.z, 10.0),
        )),
        2 => {
            let mut fk = kinecal::ForwardKinematics::new();
            fk.compute(&robot, &q_true);
            Target::Pose(fk.flange_pose())
        }
        _ => {
            let mut f = Frame::from_xyz_rpy(
                [
                    any_f64(&mut u, 0.0, 1e3),
                    any_f64(&mut u, 0.0, 1e3),
                    any_f64(&mut u, 0.0, 1e3),
                ],
                [
                    near(&mut u, 0.0, 3.0),
                    near(&mut u, 0.0, 3.0),
                    near(&mut u, 0.0, 3.0),
                ],
            );
            f.o = p + Vector3::new(near(&mut u, 0.0, 1.0), 0.0, 0.0);
            Target::Pose(f)
        }
    };
    let mut cfg = Config::<f64>::default();
    if u.ratio(1u8, 3).unwrap_or(false) {
        cfg.iterations = u.int_in_range(0..=20u8).unwrap_or(8);
        cfg.damping = any_f64(&mut u, 0.1, 0.1);
        cfg.tolerance = any_f64(&mut u, 1e-5, 1e-5);
        cfg.accept = any_f64(&mut u, 0.01, 0.01);
        cfg.max_step = any_f64(&mut u, 0.035, 0.035);
        cfg.singular = any_f64(&mut u, 0.01, 0.01);
        if u.ratio(1u8, 3).unwrap_or(false) {
            cfg.orientation_scale = Some(any_f64(&mut u, 1000.0, 1000.0));
        }
    }
    let r = compensate(&robot, &target, &seed, &cfg);
    let invalid = !cfg.is_valid() || !target.is_finite() || seed.iter().any(|x| !x.is_finite());
    if invalid {
        invariant!(
            "invalid-input-refused",
            matches!(r, Err(CompensateError::InvalidInput)),
            "{r:?}"
        );
        return;
    }
    check(&r, &seed, &cfg, &robot, &target);

    // The tracker: a step sequence with errors in it, then a reachable target.
    let mut tr = Tracker::<f64, N>::new(cfg);
    let _ = tr.start(&seed);
    for _ in 0..u.int_in_range(0..=4u8).unwrap_or(0) {
        let t = Target::Point(Vector3::new(
            any_f64(&mut u, p.x, 5.0),
            any_f64(&mut u, p.y, 5.0),
            any_f64(&mut u, p.z, 5.0),
        ));
        let _ = tr.follow(&robot, &t);
    }
    if let Some(last) = tr.last().copied() {
        invariant!(
            "tracker-recovers",
            last.iter().all(|x| x.is_finite()),
            "{last:?}"
        );
        let easy = Target::Point(point(&robot, &last));
        let r = tr.follow(&robot, &easy);
        check(&r, &last, &cfg, &robot, &easy);
    }
}
