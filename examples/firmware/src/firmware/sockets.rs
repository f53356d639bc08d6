//! Stage 3d: calibration without a tracker, from a socket set.

use super::checks::{fx, Checks};
use super::identify::NewLm;
use super::probe::stored_value;
use super::scheduler::{Idle, Servo, Work};
use super::tables::{SOCKET_Q, SOCKET_VALUES};
use super::{place, Lm, Stateful};
use crate::bench::Counter;
use crate::reference as host;
use crate::scenario::{self, N, P, SOCKETS, SOCKET_ROWS};
use core::hint::black_box;
use core::mem::MaybeUninit;
use cortex_m_semihosting::hprintln;
use kinecal::identify::lm::{
    constraint_scratch_len, FixedLm, Levenberg, LmConfig, LmError, LmProgress,
};
use kinecal::io::constraint::{ConstraintGroup, ConstraintRow};

/// Rows of the session.
const ROWS: usize = SOCKETS * SOCKET_ROWS;
/// The constraint run's scratch: one group's normal equations and columns.
const SCRATCH: usize = constraint_scratch_len(P);

/// The socket run's solver: [`scenario::params`] from the nominal robot, with the settings for
/// constraint sessions.
fn new_socket_lm() -> Result<Lm, LmError> {
    Levenberg::new(
        scenario::nominal(),
        FixedLm::new(scenario::params()),
        LmConfig::for_constraints(),
    )
}

#[inline(never)]
fn socket_step(
    lm: &mut Lm,
    rows: &[ConstraintRow<f32, N>],
    groups: &[ConstraintGroup<f32>],
    scratch: &mut [f32],
    budget: usize,
) -> Result<LmProgress<f32>, LmError> {
    lm.step_constraints(rows, groups, scratch, budget)
}

/// Stage 3d: the arm touched [`SOCKETS`] unknown sockets [`SOCKET_ROWS`] times each (the
/// host's joint readings); the constraint LM from the nominal robot, a socket (8 rows) per
/// idle slice, must find the host's `f64` values and hold what the host held.
#[inline(never)]
pub(super) fn sockets(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    lm_slot: &mut MaybeUninit<Result<Lm, LmError>>,
) {
    let rows: [ConstraintRow<f32, N>; ROWS] =
        core::array::from_fn(|i| ConstraintRow::new(SOCKET_Q[i], scenario::SOCKET_SIGMA_MM as f32));
    let groups = scenario::socket_groups::<f32>();
    let mut scratch = [0.0f32; SCRATCH];
    let lm = place(lm_slot, new_socket_lm as NewLm);
    // Sockets 2 and 3 of the first pass, a socket per call (the first call also validates the
    // session; the last of the pass also analyses identifiability). The run continues from here.
    let _ = socket_step(lm, &rows, &groups, &mut scratch, SOCKET_ROWS);
    let per_socket = counter.per_call_once(SOCKETS as u32 - 2, || {
        let _ = black_box(socket_step(
            black_box(&mut *lm),
            &rows,
            &groups,
            &mut scratch,
            SOCKET_ROWS,
        ));
    });
    bench.lm_socket = per_socket / SOCKET_ROWS as f32;
    let mut end = None;
    let idle = Idle::run(counter, servo, 10_000, || {
        match socket_step(lm, &rows, &groups, &mut scratch, SOCKET_ROWS) {
            Ok(p) if p.stopped.is_some() => {
                end = Some(p);
                Work::Done
            }
            Ok(_) => Work::Step,
            Err(_) => Work::Done,
        }
    });
    let robot = lm.robot();
    let (mut mm, mut rad) = (0.0f32, 0.0f32);
    let mut same_held = true;
    for (k, p) in scenario::params().iter().enumerate() {
        same_held &= lm.is_active(k) != host::SOCKET_HELD[k];
        let Some(got) = stored_value(robot, *p) else {
            continue;
        };
        let e = (got - SOCKET_VALUES[0][k]).abs();
        if p.is_length() {
            mm = mm.max(e);
        } else {
            rad = rad.max(e);
        }
    }
    let p = end.unwrap_or_else(|| lm.progress());
    hprintln!(
        "sockets: LM {:?} after {} iterations (host f64: {}), {} sockets x {} rows",
        p.stopped,
        p.iteration,
        host::SOCKET_ITERATIONS,
        SOCKETS,
        SOCKET_ROWS
    );
    idle.report("sockets", checks);
    checks.check(
        "lm.sockets",
        end.is_some() && same_held && mm <= 5e-3 && rad <= 5e-6,
        format_args!(
            "24 parameters from {} socket contacts vs host f64: within {} µm, {} µrad, the same {} held",
            ROWS,
            fx(mm * 1e3, 3),
            fx(rad * 1e6, 3),
            host::SOCKET_HELD.iter().filter(|h| **h).count()
        ),
    );
}
