//! Corrected targets for a controller that keeps its nominal kinematics: the compensated joint
//! command, expressed as the target the controller's own (nominal) model reaches there.
//!
//! A controller that runs no foreign code takes Cartesian targets and solves its nominal
//! inverse kinematics. Sending it, instead of the target, the point (or pose) its nominal model
//! reaches at the command that brings the identified robot to the target, makes it move the real
//! robot there. The nominal robot stands where the identified model's base is (the measurement
//! frame), so its base is replaced by the model's.

use super::{compensate, CompensateError, Config, Solution, Target};
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};

/// The target to send to a controller with the `nominal` kinematics so that the robot the
/// identified `model` describes reaches `target`: the nominal robot, placed at the model's base,
/// at the compensated command (a point for a point target, the tool pose for a pose target),
/// with that command. The seed and the settings are [`compensate`]'s; its errors are returned
/// as they are (a failed compensation carries its best command, but no target to send).
pub fn nominal_target<T: Real, const N: usize, V: ValueStorage, W: ValueStorage>(
    model: &Robot<T, N, V>,
    nominal: &Robot<T, N, W>,
    target: &Target<T>,
    seed: &[T; N],
    config: &Config<T>,
) -> Result<(Target<T>, Solution<T, N>), CompensateError<T, N>> {
    let s = compensate(model, target, seed, config)?;
    let pose = matches!(target, Target::Pose(_));
    Ok((nominal_reach(model, nominal, pose, &s.q), s))
}

/// Where the `nominal` robot, placed at `model`'s base, puts the tool at the readings `q`: the
/// point, or with `pose` the tool pose (as [`ForwardKinematics::tool_pose`]).
pub fn nominal_reach<T: Real, const N: usize, V: ValueStorage, W: ValueStorage>(
    model: &Robot<T, N, V>,
    nominal: &Robot<T, N, W>,
    pose: bool,
    q: &[T; N],
) -> Target<T> {
    // Nominal chain at the model's base: B_model · B_nominal⁻¹ · (nominal FK).
    let rebase = model.base().compose(&nominal.base().inverse());
    let mut fk = ForwardKinematics::<T, N>::new();
    let p = fk.compute(nominal, q);
    if pose {
        Target::Pose(rebase.compose(&fk.tool_pose(nominal)))
    } else {
        Target::Point(rebase.point(&p))
    }
}
