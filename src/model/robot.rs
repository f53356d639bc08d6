//! The constant robot description: base pose, MDH rows with tilt, tool point, joint corrections,
//! joint couplings.
//!
//! This is the *model* (read-mostly); per-evaluation scratch lives in
//! [`crate::ForwardKinematics`]. The constant trigonometry of every row (`alpha`, `beta`) is
//! cached here, so it is paid once per parameter change, not once per pose.

use crate::model::coupling::{CouplingError, Couplings};
use crate::model::effects::{EffectError, Effects};
use crate::model::tool::{ToolExtra, MAX_TOOL_POINTS};
use crate::{Frame, Real};
use crate::{Inline, ValueStorage};
use nalgebra::Vector3;

pub use crate::model::bounds::{MAX_ANGLE, MAX_LENGTH};

/// `Ok` when every value is finite ([`RobotError::NotFinite`]) and at most `bound` in
/// magnitude ([`RobotError::OutOfRange`]); the first value that is not decides the error.
pub(crate) fn check_bounded<T: Real>(values: &[T], bound: T) -> Result<(), RobotError> {
    // `!(|v| <= bound)` with a finite bound: NaN and ±∞ fail too, so one comparison per value
    // finds the first bad one; finiteness only tells which error it is.
    match values.iter().find(|v| !(v.abs() <= bound)) {
        None => Ok(()),
        Some(v) if v.finite() => Err(RobotError::OutOfRange),
        Some(_) => Err(RobotError::NotFinite),
    }
}

/// One joint's modified Denavit–Hartenberg row (Craig) plus the Hayati tilt `beta`:
/// `T_i(q) = Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta + q)·Tz(d)`. Angles in rad, lengths in mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Joint<T: Real> {
    /// Twist about the previous frame's x axis (Craig's `alpha_{i-1}`), rad.
    pub alpha: T,
    /// Length along the previous frame's x axis (Craig's `a_{i-1}`), mm.
    pub a: T,
    /// Offset added to the joint angle `q`, rad.
    pub theta: T,
    /// Offset along the joint axis z, mm.
    pub d: T,
    /// Hayati tilt about the y axis after `a`, rad (0 in a plain MDH row).
    pub beta: T,
    /// Lower joint limit (rad); `lower < upper`.
    pub lower: T,
    /// Upper joint limit (rad).
    pub upper: T,
}

impl<T: Real> Joint<T> {
    /// A row with no tilt and limits of ±180°.
    pub fn mdh(alpha: T, a: T, theta: T, d: T) -> Self {
        Self {
            alpha,
            a,
            theta,
            d,
            beta: T::zero(),
            lower: -T::pi(),
            upper: T::pi(),
        }
    }

    /// The same row with degrees for the angles (file and command-line units).
    pub fn mdh_deg(alpha_deg: f64, a_mm: f64, theta_deg: f64, d_mm: f64) -> Self {
        Self::mdh(
            T::of(alpha_deg.to_radians()),
            T::of(a_mm),
            T::of(theta_deg.to_radians()),
            T::of(d_mm),
        )
    }

    /// `Ok` when the row is one a robot can have: every value finite, angles within
    /// ±[`MAX_ANGLE`], lengths within ±[`MAX_LENGTH`], and `lower < upper`.
    pub fn check(&self) -> Result<(), RobotError> {
        check_bounded(
            &[self.alpha, self.theta, self.beta, self.lower, self.upper],
            T::of(MAX_ANGLE),
        )?;
        check_bounded(&[self.a, self.d], T::of(MAX_LENGTH))?;
        if self.lower < self.upper {
            Ok(())
        } else {
            Err(RobotError::NotFinite)
        }
    }
}

/// `Ok` when `base` is a pose a robot base can have: finite, origin within ±[`MAX_LENGTH`] and
/// axes forming a rotation ([`Frame::is_rotation`]).
fn check_base<T: Real>(base: &Frame<T>) -> Result<(), RobotError> {
    check_bounded(base.o.as_slice(), T::of(MAX_LENGTH))?;
    if base.is_rotation() {
        Ok(())
    } else {
        Err(RobotError::NotRotation)
    }
}

/// `Ok` when rows, tool point and base are what [`Robot::new`] accepts (checked in that
/// order). Over a slice of rows: one copy per scalar type, not one per robot shape.
fn check_geometry<T: Real>(
    base: &Frame<T>,
    joints: &[Joint<T>],
    tool: &Vector3<T>,
) -> Result<(), RobotError> {
    for j in joints {
        j.check()?;
    }
    check_bounded(tool.as_slice(), T::of(MAX_LENGTH))?;
    check_base(base)
}

/// Cached constant trigonometry of one row.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub(crate) struct RowTrig<T: Real> {
    pub ca: T,
    pub sa: T,
    pub cb: T,
    pub sb: T,
    pub tilted: bool,
}

/// Why a robot description was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RobotError {
    /// A parameter is NaN or infinite, or a joint's limits are not `lower < upper`.
    NotFinite,
    /// A length beyond ±[`MAX_LENGTH`] or an angle beyond ±[`MAX_ANGLE`].
    OutOfRange,
    /// The base axes are not a rotation (not orthonormal and right-handed within
    /// [`crate::model::frame::ROTATION_TOLERANCE`]).
    NotRotation,
    /// A joint coupling was refused (see [`Couplings::add`]).
    BadCoupling(CouplingError),
    /// A joint correction was refused (see [`Effects::push`]).
    BadEffect(EffectError),
}

impl From<CouplingError> for RobotError {
    fn from(e: CouplingError) -> Self {
        RobotError::BadCoupling(e)
    }
}

impl From<EffectError> for RobotError {
    fn from(e: EffectError) -> Self {
        RobotError::BadEffect(e)
    }
}

/// A serial robot with `N` revolute joints, its joint-correction values kept in `V`
/// ([`Inline`]`<V>` inside the robot, or a host's storage: [`crate::ValueStorage`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Robot<T: Real, const N: usize, V: ValueStorage = Inline<0>> {
    base: Frame<T>,
    joints: [Joint<T>; N],
    tool: Vector3<T>,
    effects: Effects<T, V>,
    trig: [RowTrig<T>; N],
    /// Cached [`Robot::reach`] (it needs a square root, costly in `f32` on a Cortex-M4F).
    reach: T,
    /// Joints read relative to another (FANUC J3); empty for most arms. Last, so that the
    /// hot fields keep their offsets (an `f32` load reaches 1020 bytes on a Cortex-M4F).
    couplings: Couplings<T, N>,
    /// Further tool points and the measured frame's orientation (after the hot fields too).
    extra: ToolExtra<T>,
}

impl<T: Real, const N: usize, V: ValueStorage> Robot<T, N, V> {
    /// A robot from its base pose (measurement frame ← base), rows and tool point (flange frame).
    ///
    /// Refused ([`RobotError`]) unless every value is finite and within what a robot can be:
    /// lengths (rows' `a`, `d`, tool point, base origin) within ±[`MAX_LENGTH`] (1 km), angles
    /// (`alpha`, `theta`, `beta`, limits) within ±[`MAX_ANGLE`], `lower < upper` in every row,
    /// and the base axes a rotation ([`Frame::is_rotation`]). Such a robot's forward
    /// kinematics are finite in `f32` and `f64`.
    pub fn new(
        base: Frame<T>,
        joints: [Joint<T>; N],
        tool: Vector3<T>,
    ) -> Result<Self, RobotError> {
        check_geometry(&base, &joints, &tool)?;
        let mut r = Self {
            base,
            joints,
            tool,
            effects: Effects::for_joints(N),
            couplings: Couplings::default(),
            trig: [RowTrig::default(); N],
            reach: T::one(),
            extra: ToolExtra::default(),
        };
        r.refresh();
        Ok(r)
    }

    /// Recomputes the cached trigonometry and reach after the geometry changed.
    pub(crate) fn refresh(&mut self) {
        for (t, j) in self.trig.iter_mut().zip(self.joints.iter()) {
            let (sa, ca) = j.alpha.sincos();
            let (sb, cb) = j.beta.sincos();
            *t = RowTrig {
                ca,
                sa,
                cb,
                sb,
                tilted: j.beta != T::zero(),
            };
        }
        self.extra.identity = self.extra.axes == Frame::identity();
        let mut s = self.tool.norm();
        for j in self.joints.iter() {
            s += j.a.abs() + j.d.abs();
        }
        self.reach = if s > T::zero() { s } else { T::one() };
    }

    /// The base pose: robot base frame in the measurement frame.
    pub fn base(&self) -> &Frame<T> {
        &self.base
    }
    /// The MDH rows, base to flange.
    pub fn joints(&self) -> &[Joint<T>; N] {
        &self.joints
    }
    /// Row `i` (0-based), `None` beyond the last joint.
    pub fn joint(&self, i: usize) -> Option<&Joint<T>> {
        self.joints.get(i)
    }
    /// The measured point in the flange frame (mm).
    pub fn tool(&self) -> &Vector3<T> {
        &self.tool
    }
    /// Number of measured points on the tool (reflectors), the first ([`Robot::tool`]) included.
    pub fn tool_point_count(&self) -> usize {
        self.extra.count as usize
    }
    /// Tool point `k` (flange frame, mm; 0 is [`Robot::tool`]), `None` beyond the last.
    pub fn tool_point(&self, k: usize) -> Option<&Vector3<T>> {
        match k {
            0 => Some(&self.tool),
            k if k < self.tool_point_count() => self.extra.more.get(k - 1),
            _ => None,
        }
    }
    /// Orientation of the measured frame in the flange frame (the tool frame a 6-DoF probe
    /// reports; identity unless set). Its origin is zero: the points carry the positions.
    pub fn tool_axes(&self) -> &Frame<T> {
        &self.extra.axes
    }
    /// True when [`Robot::tool_axes`] is the identity (the measured frame is the flange's).
    #[inline(always)]
    pub fn tool_axes_identity(&self) -> bool {
        self.extra.identity
    }
    /// The non-geometric joint corrections and their values.
    pub fn effects(&self) -> &Effects<T, V> {
        &self.effects
    }
    /// The joint couplings: readings → model angles (see [`crate::model::coupling`]).
    pub fn couplings(&self) -> &Couplings<T, N> {
        &self.couplings
    }
    pub(crate) fn trig(&self) -> &[RowTrig<T>; N] {
        &self.trig
    }

    /// Replaces the base pose (checked as in [`Robot::new`]); on error the robot is unchanged.
    pub fn set_base(&mut self, base: Frame<T>) -> Result<(), RobotError> {
        check_base(&base)?;
        self.base = base;
        Ok(())
    }

    /// Replaces one row (checked as in [`Robot::new`]; an index beyond the last joint is
    /// [`RobotError::OutOfRange`]); on error the robot is unchanged.
    pub fn set_joint(&mut self, i: usize, j: Joint<T>) -> Result<(), RobotError> {
        j.check()?;
        let Some(row) = self.joints.get_mut(i) else {
            return Err(RobotError::OutOfRange);
        };
        *row = j;
        self.refresh();
        Ok(())
    }

    /// Replaces the tool point (checked as in [`Robot::new`]); on error the robot is unchanged.
    pub fn set_tool(&mut self, tool: Vector3<T>) -> Result<(), RobotError> {
        check_bounded(tool.as_slice(), T::of(MAX_LENGTH))?;
        self.tool = tool;
        self.refresh();
        Ok(())
    }

    /// Replaces tool point `k`, or adds it when `k` is the current count (checked as in
    /// [`Robot::new`]; beyond the count or [`MAX_TOOL_POINTS`] is [`RobotError::OutOfRange`]).
    /// On error the robot is unchanged.
    pub fn set_tool_point(&mut self, k: usize, p: Vector3<T>) -> Result<(), RobotError> {
        if k == 0 {
            return self.set_tool(p);
        }
        let count = self.tool_point_count();
        if k > count || k >= MAX_TOOL_POINTS {
            return Err(RobotError::OutOfRange);
        }
        check_bounded(p.as_slice(), T::of(MAX_LENGTH))?;
        self.extra.more[k - 1] = p;
        if k == count {
            self.extra.count += 1;
        }
        Ok(())
    }

    /// Sets the orientation of the measured frame in the flange frame (its origin is ignored);
    /// axes that are not a rotation are [`RobotError::NotRotation`], non-finite ones
    /// [`RobotError::NotFinite`]. On error the robot is unchanged.
    pub fn set_tool_axes(&mut self, axes: Frame<T>) -> Result<(), RobotError> {
        let mut a = axes;
        a.o = Vector3::zeros();
        if [a.x, a.y, a.z]
            .iter()
            .any(|v| v.iter().any(|c| !c.finite()))
        {
            return Err(RobotError::NotFinite);
        }
        if !a.is_rotation() {
            return Err(RobotError::NotRotation);
        }
        self.extra.axes = a;
        self.extra.identity = a == Frame::identity();
        Ok(())
    }

    /// Couples `joint` to `from` (0-based): the model angle of `joint` is its reading plus
    /// `ratio` times the reading of `from`. On error the robot is unchanged.
    pub fn set_coupling(&mut self, joint: usize, from: usize, ratio: T) -> Result<(), RobotError> {
        self.couplings.add(joint, from, ratio)?;
        Ok(())
    }

    /// Removes the coupling of `joint`, if any.
    pub fn remove_coupling(&mut self, joint: usize) {
        self.couplings.remove(joint);
    }

    /// Removes every coupling: readings are model angles again.
    pub fn clear_couplings(&mut self) {
        self.couplings.clear();
    }

    /// The effect list, to add corrections (see [`Effects::push`]; the list refuses joints
    /// beyond this robot's `N`).
    pub fn effects_mut(&mut self) -> &mut Effects<T, V> {
        self.effects.set_joints(N);
        &mut self.effects
    }

    /// `Ok` when the whole model is one [`Robot::new`] and [`Effects::push`] would accept (after
    /// the model was changed in place, e.g. decoded from a snapshot).
    pub(crate) fn check(&self) -> Result<(), RobotError> {
        check_geometry(&self.base, &self.joints, &self.tool)?;
        if !self.extra.is_valid() {
            return Err(RobotError::OutOfRange);
        }
        check_bounded(self.effects.values(), T::of(MAX_ANGLE))
    }

    pub(crate) fn tool_extra_mut(&mut self) -> &mut ToolExtra<T> {
        &mut self.extra
    }

    #[allow(clippy::type_complexity)]
    pub(crate) fn parts_mut(
        &mut self,
    ) -> (
        &mut Frame<T>,
        &mut [Joint<T>; N],
        &mut Vector3<T>,
        &mut Effects<T, V>,
    ) {
        (
            &mut self.base,
            &mut self.joints,
            &mut self.tool,
            &mut self.effects,
        )
    }

    /// Sum of |a| + |d| over the rows plus the tool length: a length scale (mm) that makes
    /// one radian of an angle parameter comparable to a millimetre of a length parameter.
    pub fn reach(&self) -> T {
        self.reach
    }

    /// True when every reading is within its joint's limits.
    pub fn within_limits(&self, q: &[T; N]) -> bool {
        q.iter()
            .zip(self.joints.iter())
            .all(|(q, j)| *q >= j.lower && *q <= j.upper)
    }

    /// The same robot in another scalar type (effects and couplings included), checked as in
    /// [`Robot::new`]: a value that does not fit `U` (a table step that rounds to zero, say)
    /// is an error, never an infinite or degenerate model.
    pub fn cast<U: Real>(&self) -> Result<Robot<U, N, V>, RobotError> {
        let c = |x: T| U::of(x.to_f64());
        let joints = self.joints.map(|j| Joint {
            alpha: c(j.alpha),
            a: c(j.a),
            theta: c(j.theta),
            d: c(j.d),
            beta: c(j.beta),
            lower: c(j.lower),
            upper: c(j.upper),
        });
        let mut r = Robot::new(
            self.base.cast_unchecked(),
            joints,
            Vector3::new(c(self.tool.x), c(self.tool.y), c(self.tool.z)),
        )?;
        r.couplings = self.couplings.cast()?;
        r.extra = self.extra.cast();
        if !r.extra.is_valid() {
            return Err(RobotError::OutOfRange);
        }
        for (i, e) in self.effects.iter().enumerate() {
            let src = self.effects.values_of(i);
            r.effects.push_with::<RobotError>(
                e.kind,
                e.joint as usize,
                N,
                e.order,
                c(e.start),
                c(e.step),
                src.len(),
                |vals| {
                    for (d, s) in vals.iter_mut().zip(src) {
                        *d = c(*s);
                    }
                    Ok(())
                },
            )?;
        }
        Ok(r)
    }

    /// The same geometry, effects and couplings with another value storage `W` (fails if it
    /// holds too few values).
    pub fn with_capacity<W: ValueStorage>(
        &self,
    ) -> Result<Robot<T, N, W>, crate::model::effects::EffectError> {
        let mut r = Robot {
            base: self.base,
            joints: self.joints,
            tool: self.tool,
            effects: Effects::for_joints(N),
            couplings: self.couplings,
            trig: self.trig,
            reach: self.reach,
            extra: self.extra,
        };
        for (i, e) in self.effects.iter().enumerate() {
            r.effects.push(
                e.kind,
                e.joint as usize,
                N,
                e.order,
                e.start,
                e.step,
                self.effects.values_of(i),
            )?;
        }
        Ok(r)
    }
}
