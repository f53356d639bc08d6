//! The model at one joint vector: residual to the target and the scaled joint Jacobian with
//! respect to the controller's readings.

use super::target::Target;
use crate::forward::ForwardKinematics;
use crate::model::frame::{orientation_error, orientation_sin_cos};
use crate::ValueStorage;
use crate::{Real, Robot};

/// Residual and scaled Jacobian at one joint vector.
#[derive(Clone, Copy)]
pub(super) struct Eval<T: Real, const N: usize> {
    pub(super) q: [T; N],
    /// Residual target − model: position (mm), then scaled orientation (mm) for poses (zero
    /// for point targets).
    pub(super) r: [T; 6],
    /// |r|² (mm², orientation scaled).
    pub(super) rn2: T,
    /// |position error|² (mm²).
    pub(super) pos2: T,
    /// sin² and cos of the orientation error angle (0 and 1 for point targets).
    pub(super) ori_sin2: T,
    pub(super) ori_cos: T,
    /// Column j: ∂(model)/∂q_j, orientation rows scaled (mm/rad); rows past `m` unused.
    pub(super) cols: [Col<T>; N],
}

/// One column of the scaled joint Jacobian: position rows, then orientation rows.
#[derive(Clone, Copy)]
pub(super) struct Col<T>([T; 6]);

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
    pub(super) fn empty() -> Self {
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
    pub(super) fn angle(&self) -> T {
        self.ori_sin2.sqrt().atan2(self.ori_cos)
    }
}

/// Evaluates the model at `q` into `e` (residual, its norms, the scaled joint Jacobian),
/// overwriting every field.
pub(super) fn evaluate_into<T: Real, const N: usize, V: ValueStorage>(
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
        let tool = fk.tool_pose(robot);
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
pub(super) fn reading_columns<T: Real, const N: usize, V: ValueStorage>(
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
pub(super) fn dot<T: Real>(a: &[T; 6], b: &[T; 6], m: usize) -> T {
    let p = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    if m > 3 {
        p + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
    } else {
        p
    }
}
