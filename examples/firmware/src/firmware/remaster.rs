//! Stage 3c: a quick re-calibration of theta2 and theta3 after a re-mastering.

use super::checks::{fx, Checks};
use super::identify::{lm_idle, lm_per_pose, new_remaster_lm, NewLm};
use super::kernels::lm_step;
use super::scheduler::Servo;
use super::tables::TRUE_ROWS;
use super::{place, Lm, Stateful};
use crate::bench::Counter;
use crate::scenario::{self, N};
use core::mem::MaybeUninit;
use kinecal::identify::lm::LmError;
use kinecal::Measurement;

/// Stage 3c: a quick re-calibration after a re-mastering. The controller's model is the true
/// robot with theta2 and theta3 off by [`scenario::REMASTER_DEG`] (the robot was re-mastered
/// since); LM over those two parameters alone (the others held), on the first
/// [`scenario::REMASTER_POSES`] identification poses, in idle slices, must find the host's
/// true rows again within what the tracker's noise allows.
#[inline(never)]
pub(super) fn remaster(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    lm_slot: &mut MaybeUninit<Result<Lm, LmError>>,
    id: &[Measurement<f32, N>],
) {
    const POSES: usize = scenario::REMASTER_POSES;
    let data = &id[..POSES];
    let lm = place(lm_slot, new_remaster_lm as NewLm);
    // Poses 2..=9 of the accumulation pass (the first call also validates the data, the last
    // also analyses identifiability). The run continues from here.
    let _ = lm_step(lm, data, 1);
    bench.lm_remaster = lm_per_pose(counter, lm, data, POSES as u32 - 2);
    let (idle, end) = lm_idle(counter, servo, lm, data);
    idle.report("remaster", checks);
    let joints = lm.robot().joints();
    let mut worst = 0.0f32;
    for j in 1..3 {
        worst = worst.max((joints[j].theta - TRUE_ROWS[j][2]).abs());
    }
    checks.check(
        "lm.remaster",
        end.is_some() && worst <= scenario::REMASTER_TOLERANCE_RAD as f32,
        format_args!(
            "theta2, theta3 within {} µrad of the truth",
            fx(worst * 1e6, 3)
        ),
    );
}
