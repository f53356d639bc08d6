//! Candidate measurement poses: random configurations within the joint limits, and the same
//! with the wrist turned so the reflector faces the tracker.
//!
//! Uniform sampling yields few feasible poses in a tracker cell (about 3 % in a cell like
//! Jost et al.'s: most fail the incidence limit), so the pool is built mostly by *aiming*:
//! draw every joint at random, then turn the last three joints (the wrist) by damped
//! Gauss–Newton until the tool z axis points at a target near the tracker. The target is drawn
//! so that the angle between the tool axis and the beam is spread uniformly over the solid
//! angle of the incidence cone (up to 97 % of the limit), because optimal designs sit at its
//! edge. The method needs no closed-form inverse kinematics, so it works for any wrist.

// `!(x > y)` is deliberate: it is also true for NaN. Index loops mirror the formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::model::param::Param;
use crate::planning::cell::Scene;
use crate::planning::information::scaled_rows;
use crate::planning::selection::Candidate;
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};
use nalgebra::{Matrix3, Vector3};
use rand_core::Rng;

/// Uniform number in [0, 1).
pub fn uniform<T: Real, R: Rng + ?Sized>(rng: &mut R) -> T {
    T::of((rng.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0))
}

/// A configuration drawn uniformly within the joint limits.
pub fn uniform_configuration<T: Real, const N: usize, V: ValueStorage, R: Rng + ?Sized>(
    rng: &mut R,
    robot: &Robot<T, N, V>,
) -> [T; N] {
    let mut q = [T::zero(); N];
    for (qi, j) in q.iter_mut().zip(robot.joints().iter()) {
        let u: T = uniform(rng);
        *qi = (j.lower + (j.upper - j.lower) * u).min(j.upper);
    }
    q
}

/// Moves `angle` into `[lower, upper]` by whole turns if possible.
fn wrap_into<T: Real>(angle: T, lower: T, upper: T) -> Option<T> {
    let two_pi = T::two_pi();
    let mut a = angle;
    for _ in 0..4 {
        if a < lower {
            a += two_pi;
        } else if a > upper {
            a -= two_pi;
        } else {
            return Some(a);
        }
    }
    None
}

/// Turns the last three joints of `q` (all joints for shorter arms) so that the tool z axis
/// points from the measured point at `target`. Returns `false` when it did not converge to
/// within `tolerance` (rad) or a wrist joint cannot be brought within its limits.
pub fn aim_wrist<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    fk: &mut ForwardKinematics<T, N>,
    q: &mut [T; N],
    target: &Vector3<T>,
    tolerance: T,
) -> bool {
    let first = N.saturating_sub(3);
    let k = N - first;
    if k == 0 {
        return false;
    }
    for _ in 0..20 {
        fk.compute(robot, q);
        // The measured frame's z axis (rigid to the flange: the wrist turns it alike).
        let z = fk.tool_pose(robot).z;
        let to = target - fk.point;
        let len = to.norm();
        if !(len > T::zero()) {
            return false;
        }
        let d = to / len;
        // Rotation vector taking z onto d.
        let axis = z.cross(&d);
        let s = axis.norm();
        let c = z.dot(&d);
        let angle = s.atan2(c);
        if angle.abs() < tolerance {
            // Bring the wrist into its limits (whole turns do not change the pose).
            for i in first..N {
                let j = &robot.joints()[i];
                match wrap_into(q[i], j.lower, j.upper) {
                    Some(a) => q[i] = a,
                    None => return false,
                }
            }
            return true;
        }
        let w = if s > T::of(1e-9) {
            axis * (angle / s)
        } else {
            // Opposite: any axis perpendicular to z.
            let p = if z.x.abs() < T::of(0.9) {
                Vector3::x()
            } else {
                Vector3::y()
            };
            z.cross(&p).normalize() * angle
        };
        // Damped least squares on the components perpendicular to z.
        let mut cols = [Vector3::zeros(); 3];
        for (c, i) in cols.iter_mut().zip(first..N) {
            let zi = fk.frames[i].z;
            *c = zi - z * z.dot(&zi);
        }
        let mut a = Matrix3::<T>::zeros();
        let mut b = Vector3::<T>::zeros();
        for r in 0..k {
            b[r] = cols[r].dot(&w);
            for c in 0..k {
                a[(r, c)] = cols[r].dot(&cols[c]);
            }
        }
        for r in 0..3 {
            a[(r, r)] += T::of(1e-6) + if r < k { T::zero() } else { T::one() };
        }
        let dq = match a.cholesky() {
            Some(ch) => ch.solve(&b),
            None => return false,
        };
        // Limit the step: the linearisation is poor for large turns.
        let big = dq.iter().fold(T::zero(), |m, v| m.max(v.abs()));
        let lim = T::of(0.7);
        let f = if big > lim { lim / big } else { T::one() };
        for (r, i) in (first..N).enumerate() {
            q[i] += dq[r] * f;
        }
        if !q.iter().all(|v| v.finite()) {
            return false;
        }
    }
    false
}

/// A random aiming target near the tracker as seen from `point`: the beam direction tilted by
/// an angle whose cosine is uniform over the cap of half-angle `max_angle`.
pub fn aim_target<T: Real, R: Rng + ?Sized>(
    rng: &mut R,
    tracker: &Vector3<T>,
    point: &Vector3<T>,
    max_angle: T,
) -> Vector3<T> {
    let g = tracker - point;
    let len = g.norm();
    if !(len > T::zero()) {
        return *tracker;
    }
    let u = g / len;
    let cmin = max_angle.cos();
    let c = T::one() - (T::one() - cmin) * uniform::<T, R>(rng);
    let s = (T::one() - c * c).max(T::zero()).sqrt();
    let phi = T::two_pi() * uniform::<T, R>(rng);
    let p = if u.x.abs() < T::of(0.9) {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = u.cross(&p).normalize();
    let e2 = u.cross(&e1);
    let (sp, cp) = phi.sincos();
    let dir = u * c + (e1 * cp + e2 * sp) * s;
    point + dir * len
}

/// How pool poses are drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling<T: Real> {
    /// Fraction of draws that aim the wrist at the tracker (the rest are uniform).
    pub aimed_fraction: T,
    /// Fraction of the incidence limit the aiming targets use (below 1 so that the pose
    /// survives the point moving a little while the wrist turns).
    pub cone_fraction: T,
    /// Check collisions, the floor and the beam (false: limits and incidence only).
    pub collisions: bool,
}

impl<T: Real> Default for Sampling<T> {
    fn default() -> Self {
        Self {
            aimed_fraction: T::one(),
            cone_fraction: T::of(0.97),
            collisions: true,
        }
    }
}

/// Draws one configuration (aimed or uniform, per `sampling`) and returns it as a candidate
/// when the scene finds it feasible, with its scaled Jacobian rows for `params`.
pub fn draw<
    T: Real,
    const N: usize,
    V: ValueStorage,
    const P: usize,
    const C: usize,
    const O: usize,
    R: Rng + ?Sized,
>(
    rng: &mut R,
    robot: &Robot<T, N, V>,
    scene: &Scene<T, C, O>,
    params: &[Param],
    sampling: &Sampling<T>,
    fk: &mut ForwardKinematics<T, N>,
) -> Option<Candidate<T, N, P>> {
    let mut q = uniform_configuration(rng, robot);
    let aimed = uniform::<T, R>(rng) < sampling.aimed_fraction;
    if aimed {
        fk.compute(robot, &q);
        let tracker = fk.base.point(&scene.tracker().position);
        let target = aim_target(
            rng,
            &tracker,
            &fk.point,
            scene.tracker().max_incidence * sampling.cone_fraction,
        );
        if !aim_wrist(robot, fk, &mut q, &target, T::of(1e-4)) {
            return None;
        }
    }
    candidate(robot, scene, params, &q, sampling.collisions, fk)
}

/// The candidate at `q` if the scene finds it feasible (limits, incidence, and with
/// `collisions` the capsules, floor and beam).
pub fn candidate<
    T: Real,
    const N: usize,
    V: ValueStorage,
    const P: usize,
    const C: usize,
    const O: usize,
>(
    robot: &Robot<T, N, V>,
    scene: &Scene<T, C, O>,
    params: &[Param],
    q: &[T; N],
    collisions: bool,
    fk: &mut ForwardKinematics<T, N>,
) -> Option<Candidate<T, N, P>> {
    fk.compute(robot, q);
    let a = scene.check(robot, fk, collisions);
    if !a.feasible() {
        return None;
    }
    let mut rows = [[T::zero(); P]; 3];
    scaled_rows(robot, fk, params, &mut rows).ok()?;
    Some(Candidate {
        q: *q,
        rows,
        incidence: a.incidence,
        clearance: a.clearance,
        selected: false,
    })
}
