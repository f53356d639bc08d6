//! Stage 4: a small PSO in idle slices with snapshot and resume, and the BPNN's predictions.

use super::checks::{fx, Checks};
use super::kernels::{pso_step, restore, save};
use super::scheduler::{Idle, Servo, Work};
use super::{fail, place, Stateful, Swarm, PERIOD_INSNS, PSO_SLICE, SNAPSHOT_BYTES};
use crate::bench::Counter;
use crate::reference as host;
use crate::scenario::{self, Net, N, SWARM};
use core::hint::black_box;
use core::mem::MaybeUninit;
use cortex_m_semihosting::hprintln;
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::pso::PsoError;
use kinecal::Measurement;

/// Stage 4: a small PSO in idle slices, with a snapshot and resume as for LM.
#[inline(never)]
pub(super) fn search(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    id: &[Measurement<f32, N>],
    flash: &mut [u8; SNAPSHOT_BYTES],
) {
    let nominal = scenario::nominal::<f32>();
    let params = scenario::params();
    let mut fitness =
        PositionFitness::new(&nominal, &params, id).unwrap_or_else(|_| fail("fitness setup"));
    // One static slot serves both swarms (the first is done with when the second is built):
    // 6.6 KB of RAM less than a slot each.
    let slot = slot!(Result<Swarm, PsoError>);
    let swarm = place(&mut *slot, || {
        Swarm::new(scenario::pso_config(), scenario::PSO_SEED)
    });
    // One particle (move + fitness over the 50 poses): the first iteration's particles but the
    // last (whose call also ends the iteration), after the initial swarm. The run continues.
    let _ = pso_step(swarm, &mut fitness, SWARM);
    bench.pso_particle = counter.per_call_once(SWARM as u32 - 1, || {
        let _ = black_box(pso_step(black_box(&mut *swarm), &mut fitness, 1));
    });
    let mut saved: Option<(usize, u32)> = None;
    let idle = Idle::run(counter, servo, 10_000, || {
        let p = swarm.progress();
        if saved.is_none() && p.iteration * 2 >= scenario::PSO_ITERATIONS {
            let mut w: &mut [u8] = &mut flash[..];
            saved = save(&*swarm, &mut w)
                .ok()
                .map(|()| (SNAPSHOT_BYTES - w.len(), p.iteration));
            return Work::Snapshot;
        }
        match pso_step(swarm, &mut fitness, PSO_SLICE) {
            Ok(p) if p.stopped.is_some() => Work::Done,
            Ok(_) => Work::Step,
            Err(_) => fail("PSO refused the objective"),
        }
    });
    let first = swarm.progress();
    let history = swarm.history();
    let start = history.first().copied().unwrap_or(f32::INFINITY);
    hprintln!(
        "search: PSO {} particles x {} iterations, best {} mm² (initial swarm {} mm², host f64 {} mm², nominal {} mm²)",
        SWARM,
        first.iteration,
        fx(first.best_fitness, 3),
        fx(start, 3),
        fx(host::PSO_BEST_MM2, 3),
        fx(host::NOMINAL_COST_MM2, 3)
    );
    idle.report("search", checks);
    checks.check(
        "pso.improves",
        first.best_fitness < start && first.best_fitness.is_finite(),
        format_args!(
            "best fitness {} < initial swarm's {}",
            fx(first.best_fitness, 3),
            fx(start, 3)
        ),
    );
    let best = *swarm.best_position();

    // Resume from the snapshot in a swarm drawn from another seed: everything must be replaced.
    let (len, at) = saved.unwrap_or_else(|| fail("PSO finished before its snapshot"));
    let swarm = place(slot, || {
        Swarm::new(scenario::pso_config(), scenario::PSO_SEED + 1)
    });
    let restored = restore(swarm, &flash[..len]);
    let end = loop {
        match pso_step(swarm, &mut fitness, PSO_SLICE) {
            Ok(p) if p.stopped.is_some() => break Some(p),
            Ok(_) => {}
            Err(_) => break None,
        }
    };
    checks.check(
        "pso.snapshot_resume",
        // Bit for bit (and one comparison of 96 bytes instead of 24 unrolled float ones).
        restored.is_ok()
            && end == Some(first)
            && swarm.best_position().map(f32::to_bits) == best.map(f32::to_bits),
        format_args!("{len}-byte snapshot at iteration {at}, restored into a swarm of another seed: {:?}, same end: {}", restored, end == Some(first)),
    );

    checks.check(
        "servo.hold",
        servo.faults == 0 && servo.worst <= PERIOD_INSNS,
        format_args!(
            "held pose through all background work, worst tick {} instructions, {} faults",
            servo.worst, servo.faults
        ),
    );
}

/// BPNN-PSO's network as the controller uses it: trained on the host (here: the seeded net the
/// host also builds), it predicts particle positions; checked against the host's f64 output.
#[inline(never)]
pub(super) fn predict(checks: &mut Checks) -> &'static mut Net<f32> {
    let net = place(slot!(Result<Net<f32>, ()>), || Ok(scenario::net()));
    let out = net.forward(&scenario::net_input());
    let worst = out
        .iter()
        .zip(host::NET_OUTPUT.iter())
        .map(|(a, b)| (*a as f64 - b).abs())
        .fold(0.0, f64::max);
    checks.check(
        "bpnn.forward",
        worst < 1e-5,
        format_args!("max |y_f32 - y_f64| = {}e-6", fx(worst * 1e6, 3)),
    );
    net
}
