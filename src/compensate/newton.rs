//! The damped Newton iteration from a seed inside the step box: [`compensate`] and
//! [`compensate_from`].

use super::config::Config;
use super::evaluate::{evaluate_into, Eval};
use super::finite::{all_finite, finite, stiffer};
use super::outcome::{CompensateError, Solution};
use super::step::{blocked, conditioning, constrained_step};
use super::target::{Target, FAR};
use crate::forward::ForwardKinematics;
use crate::ValueStorage;
use crate::{Real, Robot};

/// The corrected joint command for `target` on the identified `robot`, starting from `seed`
/// (rad), which also centres the step box `|q − seed| ≤ config.max_step`.
///
/// Six-joint (or larger) arms with a [`Target::Pose`] solve 6 equations; a [`Target::Point`]
/// solves 3. When the joints outnumber the equations, each step is the minimum-norm change
/// *from the seed* of the linearised problem, so the redundancy stays where the seed put it.
pub fn compensate<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    target: &Target<T>,
    seed: &[T; N],
    config: &Config<T>,
) -> Result<Solution<T, N>, CompensateError<T, N>> {
    compensate_from(robot, target, seed, seed, config)
}

/// As [`compensate`], but the iteration starts at `start` (a warm start, clamped into the box)
/// while the box and the redundancy pull stay centred on `seed`.
pub fn compensate_from<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    target: &Target<T>,
    seed: &[T; N],
    start: &[T; N],
    config: &Config<T>,
) -> Result<Solution<T, N>, CompensateError<T, N>> {
    let m = target.rows();
    if N == 0
        || !config.is_valid()
        || !target.is_finite()
        || !all_finite(seed)
        || !all_finite(start)
        || (m == 6 && N < 6)
    {
        return Err(CompensateError::InvalidInput);
    }
    let reach = robot.reach();
    // A target a thousand reaches away is a unit or frame mistake, and its squared residual
    // could overflow (f32 already at ~1e19 mm).
    let far = reach * T::of(FAR);
    let offset = target.point() - robot.base().o;
    // Both are finite here, so the difference is finite or ±inf, never NaN.
    if offset.iter().any(|c| c.abs() > far) || offset.norm_squared() > far * far {
        return Err(CompensateError::InvalidInput);
    }
    let scale = config.orientation_scale.unwrap_or(reach);

    // The step box: within max_step of the seed and within the limits. A seed beyond a limit
    // by more than max_step gets a one-point box max_step towards the range.
    let mut lo = [T::zero(); N];
    let mut hi = [T::zero(); N];
    let mut pinned = false;
    for j in 0..N {
        let lim = &robot.joints()[j];
        let (s, d) = (seed[j], config.max_step);
        lo[j] = if s - d > lim.lower { s - d } else { lim.lower };
        hi[j] = if s + d < lim.upper { s + d } else { lim.upper };
        if lo[j] > hi[j] {
            let t = if s > lim.upper { s - d } else { s + d };
            lo[j] = t;
            hi[j] = t;
            pinned = true;
        }
    }
    let clamp = |q: &mut [T; N]| {
        for j in 0..N {
            if q[j] < lo[j] {
                q[j] = lo[j];
            } else if q[j] > hi[j] {
                q[j] = hi[j];
            }
        }
    };

    let mut fk = ForwardKinematics::new();
    if V::CAPACITY > 0 {
        fk.temp_c = config.temperature_c;
    }
    let mut q0 = *start;
    clamp(&mut q0);
    // Two evaluation slots used in turn (best, candidate): accepting a step flips an index
    // instead of copying the Jacobian.
    let mut slots = [Eval::empty(), Eval::empty()];
    evaluate_into(&mut slots[0], &mut fk, robot, target, scale, &q0);
    let mut b = 0usize;
    if !finite(slots[0].rn2) {
        return Err(CompensateError::InvalidInput);
    }
    let damp2 = config.damping * config.damping;
    // Rounding level of the model's point: a few dozen ulps of the coordinates involved.
    // Scale of the coordinates without a square root (|x|+|y|+|z| bounds the norm within √3).
    let size = target.point().iter().fold(T::zero(), |a, c| a + c.abs()) + reach;
    let noise = T::EPS * T::of(64.0) * size;
    let mut mu = T::one();
    let mut steps = 0u8;
    // Squared norms throughout: no square root per evaluation (software on a Cortex-M4F).
    // A residual at the scalar's rounding level (one ulp of the coordinates, ~0.65 µm in f32
    // at 3 m, ~1e-12 mm in f64) cannot be improved by another step: stop there.
    let floor = T::EPS * size;
    let tol = if config.tolerance > floor {
        config.tolerance
    } else {
        floor
    };
    let tol2 = tol * tol;
    while steps < config.iterations && slots[b].rn2 > tol2 {
        let best = &slots[b];
        steps += 1;
        let lambda2 = mu * (damp2 + best.rn2);
        let dq = match constrained_step(best, m, lambda2, seed, &lo, &hi) {
            Some(dq) => dq,
            None => {
                mu = stiffer(mu);
                continue;
            }
        };
        let mut q = best.q;
        let mut moved = false;
        for j in 0..N {
            let before = q[j];
            q[j] += dq[j];
            moved |= q[j] != before;
        }
        clamp(&mut q);
        if !moved {
            break;
        }
        let best_rn2 = best.rn2;
        let c = 1 - b;
        evaluate_into(&mut slots[c], &mut fk, robot, target, scale, &q);
        let cand = &slots[c];
        // Once the residual is at the rounding level of the model (f32 lives there), the step
        // just taken was the last useful one: more would only wander in the noise.
        let at_noise = best_rn2 <= noise * noise;
        if finite(cand.rn2) && cand.rn2 < best_rn2 {
            b = c;
            mu = if mu > T::one() {
                mu * T::of(0.1)
            } else {
                T::one()
            };
        } else {
            mu = stiffer(mu);
        }
        if at_noise {
            break;
        }
    }

    let best = &slots[b];
    let sol = Solution {
        q: best.q,
        position_error: best.pos2.sqrt(),
        orientation_error: best.angle(),
        sigma: conditioning(best, m),
        iterations: steps,
    };
    // σ_h is finite by construction (0 when the Gram matrix is not definite).
    let singular = sol.sigma < config.singular * reach;
    if pinned {
        return Err(CompensateError::Limited(sol));
    }
    if best.rn2 <= config.accept * config.accept {
        return if singular {
            Err(CompensateError::Singular(sol))
        } else {
            Ok(sol)
        };
    }
    if (target.point() - robot.base().o).norm() > reach {
        return Err(CompensateError::Unreachable(sol));
    }
    if singular {
        return Err(CompensateError::Singular(sol));
    }
    if blocked(best, m, &lo, &hi) {
        return Err(CompensateError::Limited(sol));
    }
    Err(CompensateError::Unreachable(sol))
}
