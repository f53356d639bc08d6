//! Stage 3: LM identification in idle slices, resumed from a snapshot; the stages' LM solvers.

use super::checks::{fx, Checks};
use super::kernels::{fk_f32, lm_step, restore, save};
use super::scheduler::{Idle, Servo, Work};
use super::tables::{true_robot, v3};
use super::{fail, fail_fmt, place, Lm, Shared, Stateful, LM_SLICE, MODEL, SNAPSHOT_BYTES};
use crate::bench::Counter;
use crate::reference as host;
use crate::scenario::{self, ID_POSES, N, P};
use core::hint::black_box;
use cortex_m::interrupt as irq;
use cortex_m_semihosting::hprintln;
use kinecal::identify::lm::{rms_error, FixedLm, Levenberg, LmError, LmProgress};
use kinecal::{ForwardKinematics, Measurement, Robot};

/// Stage 3: LM in idle slices, with a snapshot halfway that a fresh solver resumes from.
#[inline(never)]
pub(super) fn identify(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    shared: &mut Shared,
    id: &[Measurement<f32, N>],
    val: &[Measurement<f32, N>],
) {
    let Shared { flash, lm: lm_slot } = shared;
    let lm = place(&mut **lm_slot, new_lm as NewLm);
    // One pose into the normal equations (poses 2..=49 of the first pass; the first call also
    // validates the data, the 50th also analyses identifiability). The run continues from here.
    let _ = lm_step(lm, id, 1);
    bench.lm_pose = lm_per_pose(counter, lm, id, ID_POSES as u32 - 2);
    let mut saved: Option<(usize, u32)> = None;
    let mut error = None;
    let idle = Idle::run(counter, servo, 10_000, || {
        let p = lm.progress();
        if saved.is_none() && p.iteration * 2 >= host::LM_ITERATIONS {
            // Halfway: this slice writes the state to flash instead of stepping.
            let mut w: &mut [u8] = &mut flash[..];
            saved = save(&*lm, &mut w)
                .ok()
                .map(|()| (SNAPSHOT_BYTES - w.len(), p.iteration));
            return Work::Snapshot;
        }
        match lm_step(lm, id, LM_SLICE) {
            Ok(p) if p.stopped.is_some() => Work::Done,
            Ok(_) => Work::Step,
            Err(e) => {
                error = Some(e);
                Work::Done
            }
        }
    });
    if let Some(e) = error {
        fail_fmt(format_args!("LM refused the data: {:?}", e));
    }
    let p = lm.progress();
    hprintln!(
        "identify: LM {:?} after {} iterations (host f64: {}), cost {} mm²",
        p.stopped,
        p.iteration,
        host::LM_ITERATIONS,
        fx(p.cost, 6)
    );
    idle.report("identify", checks);
    let model = lm.robot().clone();
    checks.close(
        "lm.id_rms_mm",
        rms_error(&model, id) as f64,
        host::LM_ID_RMS_MM,
        1e-3,
    );
    checks.close(
        "lm.val_rms_mm",
        rms_error(&model, val) as f64,
        host::LM_VAL_RMS_MM,
        1e-3,
    );
    let mut fk = ForwardKinematics::<f32, N>::new();
    let mut worst = 0.0f32;
    for (m, want) in val.iter().zip(host::LM_VAL_PREDICTED.iter()) {
        worst = worst.max((fk_f32(&mut fk, &model, &m.q) - v3(want)).norm());
    }
    checks.check(
        "lm.model_vs_host",
        worst < 5e-3,
        format_args!(
            "f32 and f64 identified models differ by {} µm at most on held-out poses",
            fx(worst * 1e3, 3)
        ),
    );

    // Power lost at the snapshot: a fresh solver restored from flash runs to the end again.
    let (len, at) = saved.unwrap_or_else(|| fail("LM finished before its snapshot"));
    let first = lm.progress();
    // The same slot: the first solver is done with (its end and model are kept).
    let lm = place(&mut **lm_slot, new_lm as NewLm);
    let restored = restore(lm, &flash[..len]);
    let mut steps = 0u32;
    let end = loop {
        match lm_step(lm, id, LM_SLICE) {
            Ok(p) if p.stopped.is_some() => break Some(p),
            Ok(_) if steps < 100_000 => steps += 1,
            _ => break None,
        }
    };
    checks.check(
        "lm.snapshot_resume",
        restored.is_ok() && end == Some(first) && lm.robot() == &model,
        format_args!("{len}-byte snapshot at iteration {at}, restored into a fresh solver: {:?}, same end: {}", restored, end == Some(first)),
    );
    irq::free(|cs| *MODEL.borrow(cs).borrow_mut() = Some(model));
}

/// A constructor of the LM solver for one stage: plain functions, so that one copy of
/// [`place`] builds them all.
pub(super) type NewLm = fn() -> Result<Lm, LmError>;

pub(super) fn new_lm() -> Result<Lm, LmError> {
    lm_of(scenario::nominal(), scenario::params())
}

pub(super) fn new_probe_lm() -> Result<Lm, LmError> {
    lm_of(scenario::nominal_probe(), scenario::pose6d_params())
}

/// The re-mastering's solver: theta2 and theta3 from the model before the re-mastering.
pub(super) fn new_remaster_lm() -> Result<Lm, LmError> {
    lm_of(
        true_robot(scenario::REMASTER_DEG.to_radians() as f32),
        scenario::remaster_params(),
    )
}

/// The solver over `set` from `start`, with the scenario's settings (one copy for every stage).
#[inline(never)]
pub(super) fn lm_of(
    start: Robot<f32, N>,
    set: kinecal::model::param::ParamSet<P>,
) -> Result<Lm, LmError> {
    Levenberg::new(start, FixedLm::new(set), scenario::lm_config())
}

/// Instructions per pose of `lm`'s accumulation pass: `calls` single-pose steps over `data`
/// (see [`Counter::per_call_once`]; one copy for every LM stage).
#[inline(never)]
pub(super) fn lm_per_pose(
    counter: &mut Counter,
    lm: &mut Lm,
    data: &[Measurement<f32, N>],
    calls: u32,
) -> f32 {
    counter.per_call_once(calls, || {
        let _ = black_box(lm_step(black_box(&mut *lm), data, 1));
    })
}

/// `lm` over `data` in idle slices until it stops: the scheduler's record and the progress it
/// stopped with (`None`: the data were refused).
#[inline(never)]
pub(super) fn lm_idle(
    counter: &mut Counter,
    servo: &mut Servo,
    lm: &mut Lm,
    data: &[Measurement<f32, N>],
) -> (Idle, Option<LmProgress<f32>>) {
    let mut end = None;
    let idle = Idle::run(counter, servo, 10_000, || {
        match lm_step(lm, data, LM_SLICE) {
            Ok(p) if p.stopped.is_some() => {
                end = Some(p);
                Work::Done
            }
            Ok(_) => Work::Step,
            Err(_) => Work::Done,
        }
    });
    (idle, end)
}
