//! The building blocks out of line: one copy each, shared by the stages and measured alone.

use super::{Lm, Swarm};
use crate::scenario::{Net, N, P};
use kinecal::compensate::{compensate, Target, Tracker};
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::lm::{LmError, LmProgress};
use kinecal::identify::pso::PsoError;
use kinecal::io::snapshot::Snapshot;
use kinecal::{ForwardKinematics, Measurement, Param, Robot};
use nalgebra::Vector3;

#[inline(never)]
pub(super) fn fk_f32(
    fk: &mut ForwardKinematics<f32, N>,
    robot: &Robot<f32, N>,
    q: &[f32; N],
) -> Vector3<f32> {
    fk.compute(robot, q)
}

#[inline(never)]
pub(super) fn fk_f64(
    fk: &mut ForwardKinematics<f64, N>,
    robot: &Robot<f64, N>,
    q: &[f64; N],
) -> Vector3<f64> {
    fk.compute(robot, q)
}

#[inline(never)]
pub(super) fn jacobian_f32(
    fk: &ForwardKinematics<f32, N>,
    robot: &Robot<f32, N>,
    set: &[Param],
    out: &mut [Vector3<f32>; P],
) {
    let _ = fk.identification_jacobian(robot, set, out);
}

#[inline(never)]
pub(super) fn compensate_f32(
    robot: &Robot<f32, N>,
    target: &Target<f32>,
    seed: &[f32; N],
    cfg: &kinecal::compensate::Config<f32>,
) -> Result<kinecal::compensate::Solution<f32, N>, kinecal::compensate::CompensateError<f32, N>> {
    compensate(robot, target, seed, cfg)
}

#[inline(never)]
pub(super) fn lm_step(
    lm: &mut Lm,
    data: &[Measurement<f32, N>],
    budget: usize,
) -> Result<LmProgress<f32>, LmError> {
    lm.step(data, budget)
}

#[inline(never)]
pub(super) fn pso_step(
    swarm: &mut Swarm,
    fitness: &mut PositionFitness<'_, f32, N, kinecal::Inline<0>, P>,
    budget: usize,
) -> Result<kinecal::identify::pso::PsoProgress<f32>, PsoError> {
    swarm.step(fitness, budget)
}

#[inline(never)]
pub(super) fn save<S: Snapshot>(
    stepper: &S,
    flash: &mut &mut [u8],
) -> Result<(), kinecal::io::snapshot::SnapshotError> {
    stepper.save(flash)
}

#[inline(never)]
pub(super) fn restore<S: Snapshot>(
    stepper: &mut S,
    mut flash: &[u8],
) -> Result<(), kinecal::io::snapshot::SnapshotError> {
    stepper.restore(&mut flash)
}

#[inline(never)]
pub(super) fn track(
    tracker: &mut Tracker<f32, N>,
    model: &Robot<f32, N>,
    target: &Target<f32>,
    nominal: &[f32; N],
) -> Result<kinecal::compensate::Solution<f32, N>, kinecal::compensate::CompensateError<f32, N>> {
    tracker.next(model, target, nominal)
}

#[inline(never)]
pub(super) fn bpnn_forward_f32(net: &Net<f32>, x: &[f32; P]) -> [f32; P] {
    net.forward(x)
}

/// A fresh kinematics workspace (out of line: one copy of its initialisation per scalar).
#[inline(never)]
pub(super) fn new_fk<T: kinecal::Real>() -> ForwardKinematics<T, N> {
    ForwardKinematics::new()
}
