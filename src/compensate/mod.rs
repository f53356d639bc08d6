//! Online compensation: the joint command that brings the *identified* robot to a target.
//!
//! The controller knows where it wants the tool (a point in the measurement frame, or a full
//! tool pose) and has a joint vector near the answer: its nominal inverse kinematics, or the
//! previous cycle's command. [`compensate`] runs a fixed, small number of damped Newton
//! (Levenberg–Marquardt) steps on the identified model from that seed. Because
//! [`ForwardKinematics::compute`] applies the joint corrections and the joint Jacobian (as
//! [`ForwardKinematics::joint_jacobian`] has it) carries their slope, compliance, cyclic, scale
//! and table effects are inverted along with the geometry.
//!
//! Seeds, commands and joint limits are the controller's own *readings*: with joint couplings
//! (FANUC J3 read from the horizontal, [`crate::Couplings`]) the forward kinematics maps them
//! to model angles and the joint Jacobian is taken with respect to the readings (chain rule),
//! so the Newton steps, the step box and the limits all live in the controller's coordinates.
//!
//! Safety, in the order a servo loop needs it:
//! - every command stays in the box `|q − seed| ≤ max_step` ∩ joint limits, so the answer is
//!   never a jump, whatever the target;
//! - non-finite inputs are refused before anything is computed ([`CompensateError::InvalidInput`]);
//! - a singular, limited or unreachable target returns a typed error that still carries the best
//!   command found inside the box, so the controller can hold or creep instead of stopping dead.
//!
//! Cost per call: at most `iterations + 1` forward kinematics (with their joint Jacobians, read
//! off the same pass) plus one or two ≤ 6×6 LDLᵀ solves per step and one for the conditioning,
//! in straight-line code, no allocation; once the residual reaches the scalar type's rounding
//! level one more step is taken and the iteration stops, so `f32` does not spend its budget
//! wandering in the noise. [`Tracker`] is the streaming form for trajectories: it keeps the
//! previous correction and starts the next cycle from it (usually one or two steps then
//! suffice).

use crate::forward::ForwardKinematics;
use crate::model::frame::{orientation_error, orientation_sin_cos};
use crate::{Frame, Real, Robot};
use nalgebra::Vector3;

/// Targets farther than this many reaches ([`Robot::reach`]) from the base are refused as
/// invalid input rather than iterated on.
pub const FAR: f64 = 1000.0;

/// Where the tool should go, in the measurement frame (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target<T: Real> {
    /// Only the measured point (3 equations): any robot.
    Point(Vector3<T>),
    /// Point (the frame's origin) and tool orientation (the flange axes, as in
    /// [`ForwardKinematics::tool_pose`]): 6 equations, robots with six or more joints.
    Pose(Frame<T>),
}

impl<T: Real> Target<T> {
    /// The target point (mm, measurement frame).
    pub fn point(&self) -> &Vector3<T> {
        match self {
            Target::Point(p) => p,
            Target::Pose(f) => &f.o,
        }
    }

    /// Number of equations: 3 for a point, 6 for a pose.
    pub fn rows(&self) -> usize {
        match self {
            Target::Point(_) => 3,
            Target::Pose(_) => 6,
        }
    }

    /// True when every number is finite.
    pub fn is_finite(&self) -> bool {
        match self {
            Target::Point(p) => all_finite(p.as_slice()),
            Target::Pose(f) => {
                all_finite(f.x.as_slice())
                    && all_finite(f.y.as_slice())
                    && all_finite(f.z.as_slice())
                    && all_finite(f.o.as_slice())
            }
        }
    }
}

/// Tuning of the Newton iteration and of the safety checks.
///
/// The defaults suit an industrial arm with seeds within a degree of the answer: from 0.3° off
/// they converge to ~10 nm in `f64` in 2–3 steps, and to the `f32` rounding floor of the
/// model's point (a few tenths of a micrometre at 3 m from the tracker) in 2–3 steps in `f32`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config<T: Real> {
    /// Most Newton steps per call; each costs one forward kinematics. Default 8.
    pub iterations: u8,
    /// Damping floor λ₀ (mm). Each step solves with λ² = μ·(λ₀² + |r|²): the residual term
    /// (Sugihara's) shortens steps towards far or singular targets and vanishes at convergence,
    /// so the converged answer is not biased. Default 0.1 mm.
    pub damping: T,
    /// Stop early once the residual is below this (mm, orientation scaled). Default 1e-5 mm
    /// (10 nm: far below any robot's repeatability, reached in 2–3 steps from 0.3° off).
    pub tolerance: T,
    /// A residual above this after the iterations is not a success (mm, orientation scaled).
    /// Default 0.01 mm, ten times below a laser tracker's noise.
    pub accept: T,
    /// Per-joint bound on |command − seed| (rad): the largest correction the controller
    /// accepts. Default 2° (0.0349 rad).
    pub max_step: T,
    /// Length scale (mm per rad) that makes orientation error comparable to position error
    /// in pose targets; `None` uses [`Robot::reach`], the scale identification uses. Default None.
    pub orientation_scale: Option<T>,
    /// Singular when the scaled Jacobian's conditioning σ_h (see [`Solution::sigma`]) falls
    /// below `singular · reach` (mm/rad). Default 0.01: at a 2 m reach, 20 mm/rad, i.e. a
    /// 1 mm correction would need ~3° along the weakest direction. About 1–2° from a
    /// wrist singularity for pose targets.
    pub singular: T,
}

impl<T: Real> Default for Config<T> {
    fn default() -> Self {
        Self {
            iterations: 8,
            damping: T::of(0.1),
            tolerance: T::of(1e-5),
            accept: T::of(0.01),
            max_step: T::of(2f64.to_radians()),
            orientation_scale: None,
            singular: T::of(0.01),
        }
    }
}

impl<T: Real> Config<T> {
    /// True when every setting is finite and in range.
    pub fn is_valid(&self) -> bool {
        let nonneg = |x: T| finite(x) && x >= T::zero();
        let pos = |x: T| finite(x) && x > T::zero();
        nonneg(self.damping)
            && nonneg(self.tolerance)
            && pos(self.accept)
            && pos(self.max_step)
            && nonneg(self.singular)
            && self.orientation_scale.is_none_or(pos)
    }
}

/// A joint command and how well it meets the target on the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution<T: Real, const N: usize> {
    /// The joint command (rad): within `max_step` of the seed (to the rounding of seed ±
    /// max_step) and inside the joint limits, except that a seed beyond a limit by more than
    /// `max_step` is moved exactly `max_step` towards it (reported as `Limited`).
    pub q: [T; N],
    /// |target point − model point at `q`| (mm).
    pub position_error: T,
    /// Angle between target and model tool orientation at `q` (rad); 0 for point targets.
    pub orientation_error: T,
    /// Conditioning of the scaled Jacobian at `q` (mm/rad): σ_h = (Σ 1/σ_i²)^(-1/2), a cheap
    /// bound on the smallest singular value, σ_h ≤ σ_min ≤ √m·σ_h (m = 3 or 6 equations).
    pub sigma: T,
    /// Newton steps tried.
    pub iterations: u8,
}

/// Outcome class of one compensation, for logs and the `status` column of `kinecal compensate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    Ok,
    Singular,
    Unreachable,
    Limited,
    Invalid,
}

impl Status {
    /// Lower-case name: `ok`, `singular`, `unreachable`, `limited`, `invalid`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Singular => "singular",
            Status::Unreachable => "unreachable",
            Status::Limited => "limited",
            Status::Invalid => "invalid",
        }
    }

    /// The class of a compensation result.
    pub fn of<T: Real, const N: usize>(r: &Result<Solution<T, N>, CompensateError<T, N>>) -> Self {
        match r {
            Ok(_) => Status::Ok,
            Err(e) => e.status(),
        }
    }
}

/// Why no command meets the target; all but `InvalidInput` carry the best safe command, which
/// is finite and inside the step box around the seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CompensateError<T: Real, const N: usize> {
    /// A target, seed or configuration value is NaN, infinite or out of range, the target is
    /// more than [`FAR`] × reach from the base (a unit or frame mistake, not a target), a pose
    /// target was given to a robot with fewer than six joints, or [`Tracker::follow`] has no previous
    /// command. Nothing was computed: hold the previous command.
    InvalidInput,
    /// The Jacobian at the answer is (nearly) rank-deficient (σ_h below the threshold): a
    /// wrist, shoulder or elbow singularity, or the edge of the workspace. The target may even
    /// be met, but neighbouring targets would need large joint motion.
    Singular(Solution<T, N>),
    /// The residual did not converge and nothing else explains it, or the target lies beyond
    /// the arm's reach (farther from the base than Σ(|a|+|d|) + |tool|).
    Unreachable(Solution<T, N>),
    /// The residual did not converge because a joint limit or the step bound stops the joints
    /// that would reduce it (or the seed lies beyond a joint limit by more than `max_step`).
    /// When the Jacobian is also singular there, `Singular` is reported instead: the
    /// singularity is the cause, the bound only what stopped the resulting large step.
    Limited(Solution<T, N>),
}

impl<T: Real, const N: usize> CompensateError<T, N> {
    /// The best safe command found, if any was computed.
    pub fn best(&self) -> Option<&Solution<T, N>> {
        match self {
            CompensateError::InvalidInput => None,
            CompensateError::Singular(s)
            | CompensateError::Unreachable(s)
            | CompensateError::Limited(s) => Some(s),
        }
    }

    pub fn status(&self) -> Status {
        match self {
            CompensateError::InvalidInput => Status::Invalid,
            CompensateError::Singular(_) => Status::Singular,
            CompensateError::Unreachable(_) => Status::Unreachable,
            CompensateError::Limited(_) => Status::Limited,
        }
    }
}

/// The corrected joint command for `target` on the identified `robot`, starting from `seed`
/// (rad), which also centres the step box `|q − seed| ≤ config.max_step`.
///
/// Six-joint (or larger) arms with a [`Target::Pose`] solve 6 equations; a [`Target::Point`]
/// solves 3. When the joints outnumber the equations, each step is the minimum-norm change
/// *from the seed* of the linearised problem, so the redundancy stays where the seed put it.
pub fn compensate<T: Real, const N: usize, const V: usize>(
    robot: &Robot<T, N, V>,
    target: &Target<T>,
    seed: &[T; N],
    config: &Config<T>,
) -> Result<Solution<T, N>, CompensateError<T, N>> {
    compensate_from(robot, target, seed, seed, config)
}

/// As [`compensate`], but the iteration starts at `start` (a warm start, clamped into the box)
/// while the box and the redundancy pull stay centred on `seed`.
pub fn compensate_from<T: Real, const N: usize, const V: usize>(
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

/// `x − x`: 0 for a finite `x`, NaN for ±∞ and NaN.
#[allow(clippy::eq_op)] // the subtraction is the test
#[inline(always)]
fn nan_unless_finite<T: Real>(x: T) -> T {
    x - x
}

/// True for a finite `x`, by [`nan_unless_finite`]: two floating-point instructions, where the
/// bit test of [`Real::finite`] takes about a dozen integer ones on a Cortex-M4F (the checks
/// run several times per Newton step).
#[inline(always)]
fn finite<T: Real>(x: T) -> bool {
    nan_unless_finite(x) == T::zero()
}

/// True when every value is finite (one non-finite value makes the sum NaN; the sum of
/// zeros cannot overflow).
#[inline(always)]
fn all_finite<T: Real>(v: &[T]) -> bool {
    v.iter().fold(T::zero(), |s, x| s + nan_unless_finite(*x)) == T::zero()
}

/// Ten times more damping after a failed step, capped so that it stays finite.
fn stiffer<T: Real>(mu: T) -> T {
    if mu < T::of(1e12) {
        mu * T::of(10.0)
    } else {
        mu
    }
}

/// `$body` for `$j` = 0, …, 5: the firmware's unroll threshold keeps LLVM from unrolling an
/// outer loop whose inner loops' bounds depend on it; written out, every bound is a constant
/// and every index of the packed triangle one.
macro_rules! for_0_to_5 {
    ($j:ident => $body:block) => {{
        let $j: usize = 0;
        $body
        let $j: usize = 1;
        $body
        let $j: usize = 2;
        $body
        let $j: usize = 3;
        $body
        let $j: usize = 4;
        $body
        let $j: usize = 5;
        $body
    }};
}

/// Residual and scaled Jacobian at one joint vector.
#[derive(Clone, Copy)]
struct Eval<T: Real, const N: usize> {
    q: [T; N],
    /// Residual target − model: position (mm), then scaled orientation (mm) for poses (zero
    /// for point targets).
    r: [T; 6],
    /// |r|² (mm², orientation scaled).
    rn2: T,
    /// |position error|² (mm²).
    pos2: T,
    /// sin² and cos of the orientation error angle (0 and 1 for point targets).
    ori_sin2: T,
    ori_cos: T,
    /// Column j: ∂(model)/∂q_j, orientation rows scaled (mm/rad); rows past `m` unused.
    cols: [Col<T>; N],
}

/// One column of the scaled joint Jacobian: position rows, then orientation rows.
#[derive(Clone, Copy)]
struct Col<T>([T; 6]);

impl<T> core::ops::Deref for Col<T> {
    type Target = [T; 6];
    #[inline(always)]
    fn deref(&self) -> &[T; 6] {
        &self.0
    }
}

impl<T> core::ops::DerefMut for Col<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T; 6] {
        &mut self.0
    }
}

// What `Couplings::reading_columns` needs of a column.
impl<T: Real> core::ops::AddAssign for Col<T> {
    fn add_assign(&mut self, o: Self) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
    }
}

impl<T: Real> core::ops::Mul<T> for Col<T> {
    type Output = Self;
    fn mul(mut self, k: T) -> Self {
        for a in self.0.iter_mut() {
            *a *= k;
        }
        self
    }
}

impl<T: Real, const N: usize> Eval<T, N> {
    fn empty() -> Self {
        Eval {
            q: [T::zero(); N],
            r: [T::zero(); 6],
            rn2: T::zero(),
            pos2: T::zero(),
            ori_sin2: T::zero(),
            ori_cos: T::one(),
            cols: [Col([T::zero(); 6]); N],
        }
    }

    /// The orientation error angle (rad), computed once for the reported solution.
    fn angle(&self) -> T {
        self.ori_sin2.sqrt().atan2(self.ori_cos)
    }
}

/// Evaluates the model at `q` into `e` (residual, its norms, the scaled joint Jacobian),
/// overwriting every field.
fn evaluate_into<T: Real, const N: usize, const V: usize>(
    e: &mut Eval<T, N>,
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    target: &Target<T>,
    scale: T,
    q: &[T; N],
) {
    let p = fk.compute(robot, q);
    let dp = target.point() - p;
    let pose = match target {
        Target::Pose(f) => Some(f),
        Target::Point(_) => None,
    };
    // The columns for the model angles, straight off the frames: z_j × (p − o_j) and z_j.
    // For a plain model (the servo loop's usual case) they are the joint Jacobian.
    let cols = &mut e.cols;
    for (j, c) in cols.iter_mut().enumerate() {
        let l = fk.joint_column(j);
        c[0] = l.x;
        c[1] = l.y;
        c[2] = l.z;
        if pose.is_some() {
            let a = &fk.frames[j].z;
            c[3] = a.x * scale;
            c[4] = a.y * scale;
            c[5] = a.z * scale;
        }
    }
    if !(robot.effects().is_empty() && robot.couplings().is_empty()) {
        reading_columns(cols, fk, robot, pose.is_some(), scale);
    }
    let r = &mut e.r;
    r[0] = dp.x;
    r[1] = dp.y;
    r[2] = dp.z;
    let (mut ori_sin2, mut ori_cos) = (T::zero(), T::one());
    if let Some(f) = pose {
        // The residual is sin(θ)·axis: zero exactly where θ·axis is, with the same Jacobian to
        // first order, and free of atan2 and sqrt. Past 90° it would shrink again, so there
        // the exact rotation vector takes over.
        let tool = fk.tool_pose();
        let (v, c) = orientation_sin_cos(f, &tool);
        let w = if c > T::zero() {
            v
        } else {
            orientation_error(f, &tool)
        };
        ori_sin2 = v.norm_squared();
        ori_cos = c;
        for i in 0..3 {
            r[3 + i] = w[i] * scale;
        }
    } else {
        r[3] = T::zero();
        r[4] = T::zero();
        r[5] = T::zero();
    }
    let rn2 = r.iter().fold(T::zero(), |s, v| s + *v * *v);
    e.q = *q;
    e.rn2 = rn2;
    e.pos2 = dp.norm_squared();
    e.ori_sin2 = ori_sin2;
    e.ori_cos = ori_cos;
}

/// Turns the model-angle columns in `cols` into the joint Jacobian with respect to the
/// readings of a model with couplings or joint corrections: the chain rule through the
/// couplings ([`crate::Couplings::reading_columns`]), then times `1 + slope` of the
/// corrections, the operations of [`ForwardKinematics::joint_jacobian`] in its order (same
/// values). Out of line: the servo loop's plain model does not come here.
#[inline(never)]
fn reading_columns<T: Real, const N: usize, const V: usize>(
    cols: &mut [Col<T>; N],
    fk: &ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    pose: bool,
    scale: T,
) {
    // The orientation rows unscaled (scaled last, as the sums of `joint_jacobian` round).
    for (c, f) in cols.iter_mut().zip(fk.frames.iter()) {
        c[3] = f.z.x;
        c[4] = f.z.y;
        c[5] = f.z.z;
    }
    let couplings = robot.couplings();
    if !couplings.is_empty() {
        couplings.reading_columns(cols);
    }
    let effects = robot.effects();
    if !effects.is_empty() {
        let slope = effects.correction_slope(&fk.q);
        for (c, s) in cols.iter_mut().zip(slope.iter()) {
            *c = *c * (T::one() + *s);
        }
    }
    let k = if pose { scale } else { T::zero() };
    for c in cols.iter_mut() {
        for v in &mut c[3..] {
            *v *= k;
        }
    }
}

/// Dot product of the first `m` rows (3 or 6, straight-line code for both: this is the servo
/// loop's innermost operation).
#[inline(always)]
fn dot<T: Real>(a: &[T; 6], b: &[T; 6], m: usize) -> T {
    let p = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    if m > 3 {
        p + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
    } else {
        p
    }
}

/// One damped step from `e.q`, with the joints whose step would leave the box at a bound
/// frozen (a small active-set loop), so a limited joint does not spoil the others' step.
fn constrained_step<T: Real, const N: usize>(
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    seed: &[T; N],
    lo: &[T; N],
    hi: &[T; N],
) -> Option<[T; N]> {
    let mut free = [true; N];
    let mut dq = [T::zero(); N];
    for _pass in 0..=N {
        dq = damped_step(e, m, lambda2, seed, &free)?;
        let mut changed = false;
        for j in 0..N {
            let x = e.q[j] + dq[j];
            if free[j] && ((x > hi[j] && e.q[j] >= hi[j]) || (x < lo[j] && e.q[j] <= lo[j])) {
                free[j] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    Some(dq)
}

/// The damped least-squares step over the free joints. With at most as many joints as
/// equations: `(JᵀJ + λ²I)·dq = Jᵀr`. With more joints: the minimum-norm change from the seed,
/// `dq = d + Jᵀ(JJᵀ + λ²I)⁻¹(r − J·d)` with `d = seed − q`. `None` if the solve failed.
fn damped_step<T: Real, const N: usize>(
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    seed: &[T; N],
    free: &[bool; N],
) -> Option<[T; N]> {
    let mut dq = [T::zero(); N];
    if N <= m {
        let (mut a, mut b) = ([T::zero(); TRI], [T::zero(); 6]);
        joint_system(&mut a, &mut b, e, m, lambda2, Some(free));
        if !solve6(&mut a, &mut b) {
            return None;
        }
        dq.copy_from_slice(&b[..N]);
    } else {
        let mut d = [T::zero(); N];
        for j in 0..N {
            if free[j] {
                d[j] = seed[j] - e.q[j];
            }
        }
        let (mut a, mut b) = ([T::zero(); TRI], e.r);
        task_system(&mut a, &mut b, e, m, lambda2, &d, free);
        if !solve6(&mut a, &mut b) {
            return None;
        }
        for j in (0..N).filter(|j| free[*j]) {
            dq[j] = d[j] + dot(&e.cols[j], &b, m);
        }
    }
    if all_finite(&dq) {
        Some(dq)
    } else {
        None
    }
}

/// Rows of the Jacobian when the joints are at most as many (`N ≤ m`): more than three joints
/// there means a pose target, so the servo loop's six joints fold `m` to the constant 6.
#[inline(always)]
fn rows_square<const N: usize>(m: usize) -> usize {
    if N > 3 {
        6
    } else {
        m
    }
}

/// `JᵀJ + λ²I` over the joints (`N ≤ m`) and, when `free` is given, `Jᵀr`, with the frozen
/// joints' rows and columns replaced by the identity's: order `N`, padded to 6 (see [`Tri`]).
fn joint_system<T: Real, const N: usize>(
    a: &mut Tri<T>,
    b: &mut [T; 6],
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    free: Option<&[bool; N]>,
) {
    let m = rows_square::<N>(m);
    for_0_to_5!(i => {
        if i < N {
            let c = &e.cols[i];
            for k in 0..i {
                a[ix(i, k)] = dot(c, &e.cols[k], m);
            }
            a[ix(i, i)] = dot(c, c, m) + lambda2;
            if free.is_some() {
                b[i] = dot(c, &e.r, m);
            }
        }
    });
    for i in N..6 {
        a[ix(i, i)] = T::one();
    }
    if let Some(free) = free {
        if free.iter().any(|f| !f) {
            freeze(a, b, free);
        }
    }
}

/// Replaces the rows and columns of the joints not `free` by the identity's (rare: a joint
/// at a bound of the step box).
#[inline(never)]
fn freeze<T: Real>(a: &mut Tri<T>, b: &mut [T; 6], free: &[bool]) {
    for (i, f) in free.iter().enumerate() {
        if !f {
            for k in 0..6 {
                a[if k < i { ix(i, k) } else { ix(k, i) }] = T::zero();
            }
            a[ix(i, i)] = T::one();
            b[i] = T::zero();
        }
    }
}

/// `JJᵀ + λ²I` over the free joints (`N > m`) into `a` (zero on entry) and `b −= J·d` (`b`
/// holds `r` on entry): order `m`, padded to 6.
#[inline(never)]
fn task_system<T: Real, const N: usize>(
    a: &mut Tri<T>,
    b: &mut [T; 6],
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    d: &[T; N],
    free: &[bool; N],
) {
    for j in (0..N).filter(|j| free[*j]) {
        let c = &e.cols[j];
        for i in 0..m {
            b[i] -= c[i] * d[j];
            for k in 0..=i {
                a[ix(i, k)] += c[i] * c[k];
            }
        }
    }
    for i in 0..6 {
        a[ix(i, i)] += if i < m { lambda2 } else { T::one() };
    }
}

/// σ_h = (trace((Gram)⁻¹))^(-1/2) of the scaled Jacobian (0 when the Gram matrix is singular):
/// within a factor √m of the smallest singular value, from one small LDLᵀ.
fn conditioning<T: Real, const N: usize>(e: &Eval<T, N>, m: usize) -> T {
    let (mut a, mut b) = ([T::zero(); TRI], [T::zero(); 6]);
    let n = if N <= m {
        joint_system(&mut a, &mut b, e, m, T::zero(), None);
        N
    } else {
        task_system(&mut a, &mut b, e, m, T::zero(), &[T::zero(); N], &[true; N]);
        m
    };
    harmonic(&mut a, n)
}

/// `trace(A⁻¹)^(-1/2)` of a symmetric positive definite `A` of order `n` (see [`Tri`]), 0 if
/// not definite. LDLᵀ, not Cholesky: no square roots but the last one (`f32` `sqrt` is a
/// software routine on a Cortex-M4F).
fn harmonic<T: Real>(a: &mut Tri<T>, n: usize) -> T {
    if n == 0 || !ldlt6(a) {
        return T::zero();
    }
    let tr = trace_inverse6(a, n);
    let s = T::one() / tr.sqrt();
    if finite(s) {
        s
    } else {
        T::zero()
    }
}

/// True when some joint sits at a bound of the box and the residual's descent direction `Jᵀr`
/// pushes it outward: the bound, not the model, stops the residual from shrinking.
fn blocked<T: Real, const N: usize>(e: &Eval<T, N>, m: usize, lo: &[T; N], hi: &[T; N]) -> bool {
    let mut g = [T::zero(); N];
    let mut gmax = T::zero();
    for (gj, c) in g.iter_mut().zip(e.cols.iter()) {
        *gj = dot(c, &e.r, m);
        if gj.abs() > gmax {
            gmax = gj.abs();
        }
    }
    let tiny = gmax * T::of(1e-3);
    (0..N).any(|j| (e.q[j] >= hi[j] && g[j] > tiny) || (e.q[j] <= lo[j] && g[j] < -tiny))
}

// The symmetric systems of the Newton steps and of the conditioning have order 1–3 or 6. All
// are solved as order 6, a smaller one padded with the identity (zero off-diagonal, one on the
// diagonal, zero right-hand side): the padding factors and solves exactly (pivots 1, zero
// multipliers), so the results are those of the unpadded system, while one straight-line 6 × 6
// routine serves every size. Operations and their order are those of `linalg::ldlt`,
// `ldlt_solve` and `ldlt_trace_inverse`.

/// Entries of a packed lower triangle of order 6.
const TRI: usize = 21;
/// Symmetric 6 × 6 matrix as its packed lower triangle: `(i, k)`, `k ≤ i`, at [`ix`].
type Tri<T> = [T; TRI];

#[inline(always)]
const fn ix(i: usize, k: usize) -> usize {
    i * (i + 1) / 2 + k
}

/// `A = L·D·Lᵀ` in place (unit `L` below the diagonal, `D` on it); false unless every pivot
/// is positive and finite.
#[inline(never)]
fn ldlt6<T: Real>(a: &mut Tri<T>) -> bool {
    // w[k] = L[j][k]·d[k], reused by every row below j.
    let mut w = [T::zero(); 6];
    for_0_to_5!(j => {
        let mut d = a[ix(j, j)];
        for k in 0..j {
            w[k] = a[ix(j, k)] * a[ix(k, k)];
            d -= a[ix(j, k)] * w[k];
        }
        if !(d > T::zero() && finite(d)) {
            return false;
        }
        a[ix(j, j)] = d;
        let inv = T::one() / d;
        for i in j + 1..6 {
            let mut s = a[ix(i, j)];
            for k in 0..j {
                s -= a[ix(i, k)] * w[k];
            }
            a[ix(i, j)] = s * inv;
        }
    });
    true
}

/// Solves `A·x = b` in place by LDLᵀ; false if `A` is not positive definite.
#[inline(never)]
fn solve6<T: Real>(a: &mut Tri<T>, b: &mut [T; 6]) -> bool {
    if !ldlt6(a) {
        return false;
    }
    for_0_to_5!(i => {
        let mut s = b[i];
        for k in 0..i {
            s -= a[ix(i, k)] * b[k];
        }
        b[i] = s;
    });
    for i in 0..6 {
        b[i] /= a[ix(i, i)];
    }
    for_0_to_5!(r => {
        let i = 5 - r;
        let mut s = b[i];
        for k in i + 1..6 {
            s -= a[ix(k, i)] * b[k];
        }
        b[i] = s;
    });
    true
}

/// `trace(A⁻¹)` of the leading `n × n` block from the factor of [`ldlt6`]:
/// `Σ_i Σ_k (L⁻¹)_{ki}² / d_k` (the padding past `n` adds exact zeros).
fn trace_inverse6<T: Real>(l: &Tri<T>, n: usize) -> T {
    let mut inv_d = [T::zero(); 6];
    for k in 0..6 {
        inv_d[k] = T::one() / l[ix(k, k)];
    }
    let mut tr = T::zero();
    let mut y = [T::zero(); 6];
    for_0_to_5!(i => {
        if i < n {
            // y = L⁻¹ e_i: zero above i, one at i, forward substitution below.
            y[i] = T::one();
            tr += inv_d[i];
            for k in i + 1..6 {
                let mut s = T::zero();
                for m in i..k {
                    s -= l[ix(k, m)] * y[m];
                }
                y[k] = s;
                tr += s * s * inv_d[k];
            }
        }
    });
    tr
}

/// Streaming compensation along a trajectory: keeps the previous command and starts each cycle
/// from it, so a servo loop usually needs one or two Newton steps per cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracker<T: Real, const N: usize> {
    /// Settings used by every cycle (may be changed between cycles).
    pub config: Config<T>,
    command: Option<[T; N]>,
    nominal: Option<[T; N]>,
}

impl<T: Real, const N: usize> Tracker<T, N> {
    pub fn new(config: Config<T>) -> Self {
        Self {
            config,
            command: None,
            nominal: None,
        }
    }

    /// Forgets the trajectory (the next call starts from its seed).
    pub fn reset(&mut self) {
        self.command = None;
        self.nominal = None;
    }

    /// Starts a trajectory at the joints' current position (rad), for [`Tracker::follow`].
    pub fn start(&mut self, q: &[T; N]) -> Result<(), CompensateError<T, N>> {
        if !all_finite(q) {
            return Err(CompensateError::InvalidInput);
        }
        self.command = Some(*q);
        self.nominal = None;
        Ok(())
    }

    /// The last command returned (also after a typed error: its best safe command).
    pub fn last(&self) -> Option<&[T; N]> {
        self.command.as_ref()
    }

    /// One trajectory point with the controller's nominal inverse kinematics `nominal` for it:
    /// the step box is centred on `nominal` (the command never strays more than `max_step` from
    /// the controller's own trajectory), and the iteration starts from the previous correction
    /// carried over, `last command + (nominal − previous nominal)`, which stays good even if
    /// the nominal solution switches branch.
    pub fn next<const V: usize>(
        &mut self,
        robot: &Robot<T, N, V>,
        target: &Target<T>,
        nominal: &[T; N],
    ) -> Result<Solution<T, N>, CompensateError<T, N>> {
        let mut start = *nominal;
        if let (Some(c), Some(n)) = (self.command, self.nominal) {
            for j in 0..N {
                start[j] = c[j] + (nominal[j] - n[j]);
            }
            if !all_finite(&start) {
                start = *nominal;
            }
        }
        let r = compensate_from(robot, target, nominal, &start, &self.config);
        self.remember(&r, Some(*nominal));
        r
    }

    /// One trajectory point without a nominal solution: the previous command is the seed, so
    /// the joints move at most `max_step` per cycle. Needs [`Tracker::start`] or an earlier call.
    pub fn follow<const V: usize>(
        &mut self,
        robot: &Robot<T, N, V>,
        target: &Target<T>,
    ) -> Result<Solution<T, N>, CompensateError<T, N>> {
        let seed = self.command.ok_or(CompensateError::InvalidInput)?;
        let r = compensate(robot, target, &seed, &self.config);
        self.remember(&r, None);
        r
    }

    fn remember(
        &mut self,
        r: &Result<Solution<T, N>, CompensateError<T, N>>,
        nominal: Option<[T; N]>,
    ) {
        let sol = match r {
            Ok(s) => s,
            Err(e) => match e.best() {
                Some(s) => s,
                None => return,
            },
        };
        self.command = Some(sol.q);
        self.nominal = nominal;
    }
}
