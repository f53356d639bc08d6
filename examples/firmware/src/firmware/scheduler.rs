//! The 1 kHz servo period: the servo tick holding a pose, and background work in idle slices.

use super::checks::Checks;
use super::kernels::{fk_f32, track};
use super::{fail, MODEL, PERIOD_INSNS, SLICE_LIMIT_INSNS};
use crate::bench::Counter;
use crate::scenario::{self, N};
use cortex_m::interrupt as irq;
use cortex_m_semihosting::hprintln;
use kinecal::compensate::{Target, Tracker};
use kinecal::ForwardKinematics;

/// The servo tick while background work runs: the robot holds a pose, compensated every
/// period with whatever model [`MODEL`] holds at that moment.
pub(super) struct Servo {
    tracker: Tracker<f32, N>,
    target: Target<f32>,
    nominal: [f32; N],
    pub(super) worst: u32,
    pub(super) faults: u32,
}

impl Servo {
    pub(super) fn new() -> Self {
        let nominal = scenario::nominal_joints::<f32>(0);
        let mut fk = ForwardKinematics::new();
        fk_f32(&mut fk, &scenario::nominal::<f32>(), &nominal);
        let target = Target::Pose(fk.flange_pose());
        Self {
            tracker: Tracker::new(scenario::compensation()),
            target,
            nominal,
            worst: 0,
            faults: 0,
        }
    }

    fn tick(&mut self) {
        let r = irq::free(|cs| {
            MODEL
                .borrow(cs)
                .borrow()
                .as_ref()
                .map(|m| track(&mut self.tracker, m, &self.target, &self.nominal))
        });
        if !matches!(r, Some(Ok(_))) {
            self.faults += 1;
        }
    }
}

/// Background work in 1 kHz periods: each period runs the servo tick, then `slice` until the
/// period's remaining instructions are used up or `slice` reports that the work is done.
pub(super) struct Idle {
    periods: u32,
    slices: u32,
    total: u32,
    worst_slice: u32,
    /// Instructions of the slice that wrote the snapshot (0: none).
    snapshot: u32,
}

/// What one idle slice did.
pub(super) enum Work {
    /// A bounded step of the algorithm; more to do.
    Step,
    /// Wrote the snapshot to flash instead of stepping.
    Snapshot,
    /// The algorithm has finished.
    Done,
}

impl Idle {
    pub(super) fn run<F: FnMut() -> Work>(
        counter: &mut Counter,
        servo: &mut Servo,
        limit_periods: u32,
        mut slice: F,
    ) -> Self {
        Self::run_dyn(counter, servo, limit_periods, &mut slice)
    }

    /// [`Idle::run`] for any slice (one copy of the scheduler for every stage).
    #[inline(never)]
    fn run_dyn(
        counter: &mut Counter,
        servo: &mut Servo,
        limit_periods: u32,
        slice: &mut dyn FnMut() -> Work,
    ) -> Self {
        let mut s = Idle {
            periods: 0,
            slices: 0,
            total: 0,
            worst_slice: 0,
            snapshot: 0,
        };
        loop {
            s.periods += 1;
            let ((), tick) = counter.insns_of(|| servo.tick());
            servo.worst = servo.worst.max(tick);
            let mut left = PERIOD_INSNS.saturating_sub(tick);
            loop {
                let (work, n) = counter.insns_of(&mut *slice);
                s.slices += 1;
                s.total += n;
                match work {
                    Work::Snapshot => s.snapshot = n,
                    Work::Step | Work::Done => s.worst_slice = s.worst_slice.max(n),
                }
                if let Work::Done = work {
                    return s;
                }
                if n >= left {
                    break;
                }
                left -= n;
            }
            if s.periods >= limit_periods {
                fail("background work did not finish in time");
            }
        }
    }

    pub(super) fn report(&self, what: &str, checks: &mut Checks) {
        hprintln!(
            "{}: {} slices in {} servo periods, {} instructions in all, worst slice {}, snapshot slice {}",
            what,
            self.slices,
            self.periods,
            self.total,
            self.worst_slice,
            self.snapshot
        );
        checks.check(
            "idle.slice_bounded",
            self.worst_slice <= SLICE_LIMIT_INSNS,
            format_args!(
                "{what}: worst slice {} ≤ {} instructions",
                self.worst_slice, SLICE_LIMIT_INSNS
            ),
        );
    }
}
