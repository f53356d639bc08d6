//! Stage 5: a trajectory of 6-D targets compensated tick by tick in the 1 kHz servo loop.

use super::checks::{fx, Checks};
use super::kernels::{fk_f32, track};
use super::tables::{true_robot, COMMANDS};
use super::{MODEL, PERIOD_INSNS};
use crate::bench::Counter;
use crate::scenario::{self, N, TICKS};
use cortex_m::interrupt as irq;
use cortex_m_semihosting::hprintln;
use kinecal::compensate::{Target, Tracker};
use kinecal::ForwardKinematics;

/// Stage 5: the trajectory, one compensated 6-D target per 1 ms tick.
#[inline(never)]
pub(super) fn trajectory(counter: &mut Counter, checks: &mut Checks) {
    let nominal = scenario::nominal::<f32>();
    let truth = true_robot(0.0);
    let mut fk = ForwardKinematics::<f32, N>::new();
    let mut tracker = Tracker::new(scenario::compensation());
    let (mut worst_tick, mut faults) = (0u32, 0u32);
    let (mut err2, mut worst_err, mut worst_raw, mut worst_dq) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for (k, want) in COMMANDS.iter().enumerate() {
        // The interpolator's output for this tick: nominal joints and the pose they give.
        let qn = scenario::nominal_joints::<f32>(k);
        fk_f32(&mut fk, &nominal, &qn);
        let target = Target::Pose(fk.flange_pose());
        let (r, insns) = counter.insns_of(|| {
            irq::free(|cs| {
                MODEL
                    .borrow(cs)
                    .borrow()
                    .as_ref()
                    .map(|m| track(&mut tracker, m, &target, &qn))
            })
        });
        worst_tick = worst_tick.max(insns);
        let q = match r {
            Some(Ok(s)) => s.q,
            _ => {
                faults += 1;
                continue;
            }
        };
        // Where the real robot goes with and without compensation.
        let e = (fk_f32(&mut fk, &truth, &q) - target.point()).norm();
        let raw = (fk_f32(&mut fk, &truth, &qn) - target.point()).norm();
        err2 += e * e;
        worst_err = worst_err.max(e);
        worst_raw = worst_raw.max(raw);
        for (a, b) in q.iter().zip(want.iter()) {
            worst_dq = worst_dq.max((a - b).abs());
        }
    }
    let rms = libm::sqrtf(err2 / TICKS as f32);
    hprintln!(
        "servo: {} ticks, true robot off target by {} mm RMS, {} mm max (uncompensated {} mm max)",
        TICKS,
        fx(rms, 4),
        fx(worst_err, 4),
        fx(worst_raw, 3)
    );
    checks.check(
        "servo.deadline",
        faults == 0 && worst_tick <= PERIOD_INSNS,
        format_args!(
            "{} of {} ticks compensated, worst tick {} of {} instructions",
            TICKS as u32 - faults,
            TICKS,
            worst_tick,
            PERIOD_INSNS
        ),
    );
    checks.check(
        "servo.accuracy",
        faults == 0 && rms <= 0.03 && worst_err <= 0.1 && worst_raw > 10.0 * worst_err,
        format_args!(
            "RMS {} mm ≤ 0.03, max {} mm ≤ 0.1, uncompensated {} mm",
            fx(rms, 4),
            fx(worst_err, 4),
            fx(worst_raw, 3)
        ),
    );
    checks.check(
        "servo.vs_host",
        worst_dq < 2e-5,
        format_args!(
            "joint commands within {} µrad of the host's f64 ones",
            fx(worst_dq * 1e6, 3)
        ),
    );
}
