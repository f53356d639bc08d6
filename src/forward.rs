//! Forward kinematics and, beside it, its derivatives: the identification Jacobian
//! `∂p/∂(parameters)` and the joint Jacobian `∂(p, orientation)/∂q`.
//!
//! [`ForwardKinematics`] is the per-evaluation workspace (Pinocchio's `Data`): one
//! [`ForwardKinematics::compute`] fills every joint frame, the measured point and the lever arms,
//! and the Jacobians are then read off those frames without another pass.
//!
//! Order of operations (`docs/formats.md#effects` and `#couplings`): joint readings `r` → the
//! joint corrections act on the readings, `r' = r + dq(r)` → the couplings map `r'` to model
//! angles → geometry. So the geometric parameters' Jacobian columns are those of the model
//! angles, while the effect columns and the joint Jacobian are derivatives with respect to
//! readings (the chain rule through the couplings, [`ForwardKinematics::reading_column`]).
//!
//! A model with a `thermal-expansion` term is evaluated at the temperature
//! [`ForwardKinematics::temp_c`] (the caller sets it: a measurement's `temp_c`, the firmware's
//! sensor): every length scales by `s = 1 + c·(T − T0)`, so every joint origin and the point
//! move away from the base origin by the factor `s` while no orientation changes. Without a
//! temperature (`None`) the model is evaluated at its reference temperature (`s = 1`).
//!
//! A model with a `base-drift` term is evaluated at the time [`ForwardKinematics::time_s`]:
//! the base, every joint frame and the point translate by `v·(t − t0)` (the tracker drifted).
//! Without a time (`None`) nothing moves, which is how compensation evaluates it: the drift is
//! the measuring session's, not the arm's.
//!
//! ```
//! use kinecal::forward::{point, ForwardKinematics};
//! use kinecal::model::param::Param;
//! use kinecal::{Frame, Joint, Robot};
//! use nalgebra::Vector3;
//!
//! let rows = [
//!     Joint::mdh_deg(0.0, 0.0, 0.0, 400.0),
//!     Joint::mdh_deg(90.0, 100.0, 0.0, 0.0),
//!     Joint::mdh_deg(0.0, 500.0, 0.0, 0.0),
//! ];
//! let tool = Vector3::new(300.0, 0.0, 0.0);
//! let robot: Robot<f64, 3> = Robot::new(Frame::identity(), rows, tool).unwrap();
//! let mut fk = ForwardKinematics::new();
//!
//! // Zero pose: up d1 = 400, out along x by a2 + a3 + tool_x = 100 + 500 + 300.
//! let p = fk.compute(&robot, &[0.0; 3]);
//! assert!((p - Vector3::new(900.0, 0.0, 400.0)).norm() < 1e-9);
//!
//! // Joint 2 at +90° (readings in rad) points the upper arm straight up.
//! let p = fk.compute(&robot, &[0.0, 90f64.to_radians(), 0.0]);
//! assert!((p - Vector3::new(100.0, 0.0, 1200.0)).norm() < 1e-9);
//!
//! // Derivatives read off the same pass: d1 moves the point along the base z axis,
//! // joint 1 (vertical) moves it sideways by its distance from the axis.
//! let mut cols = [Vector3::zeros(); 2];
//! fk.identification_jacobian(&robot, &[Param::D(0), Param::ToolX], &mut cols).unwrap();
//! assert!((cols[0] - Vector3::z()).norm() < 1e-12);
//! assert!((fk.joint_column(0) - Vector3::new(0.0, 100.0, 0.0)).norm() < 1e-9);
//!
//! // The base pose places everything in the measurement frame (a tracker 2 m away).
//! let mut placed = robot.clone();
//! placed.set_base(Frame::from_xyz_rpy([2000.0, 0.0, 0.0], [0.0; 3])).unwrap();
//! assert!((point(&placed, &[0.0; 3]) - Vector3::new(2900.0, 0.0, 400.0)).norm() < 1e-9);
//! ```

use crate::model::coupling::Couplings;
use crate::model::param::{Param, ParamError};
use crate::model::robot::RowTrig;
use crate::ValueStorage;
use crate::{Frame, Joint, Real, Robot};
use nalgebra::Vector3;

/// Scratch of one forward-kinematics evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForwardKinematics<T: Real, const N: usize> {
    /// Joint frame `i` (after `T_1 … T_{i+1}`), in the measurement frame.
    pub frames: [Frame<T>; N],
    /// The base frame the chain started from (`B`).
    pub base: Frame<T>,
    /// The measured point `p(q)`, mm, measurement frame.
    pub point: Vector3<T>,
    /// Which of the robot's tool points `point` is (0: [`Robot::tool`]).
    pub tool: u8,
    /// Joint readings as given.
    pub q: [T; N],
    /// Angles applied to the geometry (model angles): readings plus the model's joint
    /// corrections, then mapped through the couplings.
    pub q_geometric: [T; N],
    /// Lever arms τ_j (m) of a unit downward force at the point, computed at the readings'
    /// model angles without corrections (zero unless the model has a compliance term).
    pub tau: [T; N],
    /// Temperature (°C) the next evaluation is at, for a model with a thermal-expansion term;
    /// `None`: at the term's reference temperature. Set by the caller, kept across evaluations.
    pub temp_c: Option<T>,
    /// Length scale `1 + c·(T − T0)` of the last evaluation of a model with a
    /// thermal-expansion term (1 at its reference temperature or without the term; not written
    /// for models without value capacity).
    pub expansion: T,
    /// `T − T0` of the last evaluation of a model with a thermal-expansion term, °C (0 without
    /// a temperature or without the term; not written for models without value capacity).
    pub delta_t: T,
    /// Time (s) the next evaluation is at, for a model with a base-drift term; `None`: at the
    /// term's reference time (no drift). Set by the caller, kept across evaluations.
    pub time_s: Option<T>,
}

/// When an observation was taken: the temperature and time a model's thermal-expansion and
/// base-drift terms are evaluated at ([`ForwardKinematics::compute_at`]). A temperature alone
/// converts into it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Conditions<T> {
    /// The arm's temperature, °C.
    pub temp_c: Option<T>,
    /// The time, s (the session's clock, a data file's `t_s`).
    pub time_s: Option<T>,
}

impl<T> From<Option<T>> for Conditions<T> {
    fn from(temp_c: Option<T>) -> Self {
        Self {
            temp_c,
            time_s: None,
        }
    }
}

impl<T: Real, const N: usize> Default for ForwardKinematics<T, N> {
    fn default() -> Self {
        Self {
            frames: [Frame::identity(); N],
            base: Frame::identity(),
            point: Vector3::zeros(),
            tool: 0,
            q: [T::zero(); N],
            q_geometric: [T::zero(); N],
            tau: [T::zero(); N],
            temp_c: None,
            expansion: T::one(),
            delta_t: T::zero(),
            time_s: None,
        }
    }
}

/// `F · Rx(α)·Tx(a)·Ry(β)·Rz(θ+q)·Tz(d)`, with the constant trigonometry cached in `t`.
#[inline(always)]
fn advance<T: Real>(f: &Frame<T>, j: &Joint<T>, t: &RowTrig<T>, q: T) -> Frame<T> {
    // Rx(alpha): x unchanged.
    let mut x = f.x;
    let mut y = f.y * t.ca + f.z * t.sa;
    let mut z = f.z * t.ca - f.y * t.sa;
    // Tx(a).
    let mut o = f.o + f.x * j.a;
    // Ry(beta): only for tilted rows.
    if t.tilted {
        let nx = x * t.cb - z * t.sb;
        z = x * t.sb + z * t.cb;
        x = nx;
    }
    // Rz(theta + q).
    let (s, c) = (j.theta + q).sincos();
    let nx = x * c + y * s;
    y = y * c - x * s;
    x = nx;
    // Tz(d).
    o += z * j.d;
    Frame { x, y, z, o }
}

impl<T: Real, const N: usize> ForwardKinematics<T, N> {
    /// A zeroed workspace (identity frames); [`Self::compute`] fills it.
    pub fn new() -> Self {
        Self::default()
    }

    fn chain<V: ValueStorage>(&mut self, robot: &Robot<T, N, V>, q: &[T; N], tool: &Vector3<T>) {
        // Origins are accumulated relative to the base origin and shifted once at the end:
        // with the robot metres away from the tracker, summing in absolute coordinates
        // rounds every step at the large magnitude (f32: 1.1 µm worst case at 3 m, vs 0.7 µm).
        let b = robot.base().o;
        let mut f = *robot.base();
        f.o = Vector3::zeros();
        for i in 0..N {
            f = advance(&f, &robot.joints()[i], &robot.trig()[i], q[i]);
            self.frames[i] = f;
            self.frames[i].o += b;
        }
        self.point = if N > 0 { f.point(tool) + b } else { b };
    }

    /// Evaluates the chain at joint readings `q` and returns the measured point.
    ///
    /// With a compliance term the lever arms need the pose first, so the chain runs twice;
    /// without one, once. Non-finite readings give non-finite output, never a panic. Finite
    /// readings beyond ±[`MAX_ANGLE`](crate::model::bounds::MAX_ANGLE) (1e4 rad, ~1,600 turns: no
    /// joint reads that) are clamped to it, so that every finite reading gives a finite point
    /// (a harmonic or a coupling of 1e308 rad would overflow). A robot without couplings pays
    /// one branch for them.
    pub fn compute<V: ValueStorage>(&mut self, robot: &Robot<T, N, V>, q: &[T; N]) -> Vector3<T> {
        self.evaluate(robot, q, robot.tool(), 0)
    }

    /// [`Self::compute`] for tool point `k` (0 is [`Robot::tool`]; a further reflector of a
    /// robot with several, [`Robot::tool_point`]); `None` (workspace unchanged) when the robot
    /// has no point `k`.
    pub fn compute_point<V: ValueStorage>(
        &mut self,
        robot: &Robot<T, N, V>,
        q: &[T; N],
        k: usize,
    ) -> Option<Vector3<T>> {
        let tool = *robot.tool_point(k)?;
        Some(self.evaluate(robot, q, &tool, k as u8))
    }

    #[inline(always)]
    fn evaluate<V: ValueStorage>(
        &mut self,
        robot: &Robot<T, N, V>,
        q: &[T; N],
        tool: &Vector3<T>,
        k: u8,
    ) -> Vector3<T> {
        self.tool = k;
        self.base = *robot.base();
        let limit = T::of(crate::model::bounds::MAX_ANGLE);
        let q = &q.map(|x| {
            if x.abs() > limit && x.finite() {
                limit.copysign(x)
            } else {
                x
            }
        });
        self.q = *q;
        let effects = robot.effects();
        if effects.is_empty() {
            self.q_geometric = *q;
            self.tau = [T::zero(); N];
        } else {
            if effects.needs_lever_arms() {
                // The pose of the readings' model angles, without corrections.
                self.q_geometric = *q;
                if !robot.couplings().is_empty() {
                    self.couple_angles(robot.couplings());
                }
                let q0 = self.q_geometric;
                self.chain(robot, &q0, tool);
                self.tau = self.lever_arms();
            } else {
                self.tau = [T::zero(); N];
            }
            let dq = effects.correction(q, &self.tau);
            for i in 0..N {
                self.q_geometric[i] = q[i] + dq[i];
            }
        }
        if !robot.couplings().is_empty() {
            self.couple_angles(robot.couplings());
        }
        let qg = self.q_geometric;
        self.chain(robot, &qg, tool);
        // A model without value capacity (the firmware's) has no term: not even the search.
        if V::CAPACITY > 0 {
            match effects.thermal() {
                Some((_, c, t0)) => self.expand(c, t0),
                None => {
                    self.expansion = T::one();
                    self.delta_t = T::zero();
                }
            }
            if let (Some((_, v, t0)), Some(t)) = (effects.drift(), self.time_s) {
                self.drift(v, t - t0);
            }
        }
        self.point
    }

    /// Translates the base, every joint frame and the point by `v·dt` (a base-drift term at
    /// `dt` seconds from its reference time; out of line: only models with the term pay).
    #[inline(never)]
    fn drift(&mut self, v: [T; 3], dt: T) {
        let d = Vector3::new(v[0], v[1], v[2]) * dt;
        self.base.o += d;
        for f in self.frames.iter_mut() {
            f.o += d;
        }
        self.point += d;
    }

    /// Sets [`Self::expansion`] and [`Self::delta_t`] from the term `(c, T0)` and
    /// [`Self::temp_c`], and scales every joint origin's and the point's offset from the base
    /// origin by the expansion (out of line: only models with the term pay).
    #[inline(never)]
    fn expand(&mut self, c: T, t0: T) {
        let dt = match self.temp_c {
            Some(t) => t - t0,
            None => T::zero(),
        };
        let s = T::one() + c * dt;
        self.expansion = s;
        self.delta_t = dt;
        if dt == T::zero() {
            return;
        }
        let b = self.base.o;
        for f in self.frames.iter_mut() {
            f.o = b + (f.o - b) * s;
        }
        self.point = b + (self.point - b) * s;
    }

    /// The length scale the last evaluation applied: [`Self::expansion`], which every
    /// evaluation of a model with value capacity writes (exactly 1 without a thermal-expansion
    /// term), so a column does not search the effect list again (the C ABI's Jacobian paid
    /// ~140 instructions for that); a model without value capacity folds it to 1.
    #[inline(always)]
    fn length_scale<V: ValueStorage>(&self, _robot: &Robot<T, N, V>) -> T {
        if V::CAPACITY > 0 {
            self.expansion
        } else {
            T::one()
        }
    }

    /// [`Self::compute_point`] at the conditions `at` (a temperature `Option<T>` in °C, or
    /// [`Conditions`] with a time too; `None`: the terms' references): sets [`Self::temp_c`]
    /// and [`Self::time_s`] first.
    pub fn compute_at<V: ValueStorage>(
        &mut self,
        robot: &Robot<T, N, V>,
        q: &[T; N],
        k: usize,
        at: impl Into<Conditions<T>>,
    ) -> Option<Vector3<T>> {
        let at = at.into();
        self.temp_c = at.temp_c;
        self.time_s = at.time_s;
        self.compute_point(robot, q, k)
    }

    /// `q_geometric` ← model angles of `q_geometric` (out of line: only coupled robots pay).
    #[inline(never)]
    fn couple_angles(&mut self, couplings: &Couplings<T, N>) {
        self.q_geometric = couplings.to_model(&self.q_geometric);
    }

    /// The flange orientation with the origin at the measured point.
    pub fn flange_pose(&self) -> Frame<T> {
        let mut f = if N > 0 { self.frames[N - 1] } else { self.base };
        f.o = self.point;
        f
    }

    /// The tool pose: the measured frame's orientation (the flange axes times
    /// [`Robot::tool_axes`]) with the origin at the measured point.
    pub fn tool_pose<V: ValueStorage>(&self, robot: &Robot<T, N, V>) -> Frame<T> {
        let f = self.flange_pose();
        if robot.tool_axes_identity() {
            return f;
        }
        let a = robot.tool_axes();
        Frame {
            x: f.direction(&a.x),
            y: f.direction(&a.y),
            z: f.direction(&a.z),
            o: f.o,
        }
    }

    /// Lever arms τ_j = ((z_j × (p − o_j)) · g) / 1000 (m), g = −z of the robot base frame.
    pub fn lever_arms(&self) -> [T; N] {
        let g = -self.base.z;
        let k = T::of(1e-3);
        let mut tau = [T::zero(); N];
        for (t, f) in tau.iter_mut().zip(self.frames.iter()) {
            *t = f.z.cross(&(self.point - f.o)).dot(&g) * k;
        }
        tau
    }

    /// `∂p/∂q_j` at the current pose: z_j × (p − o_j), for the model angle `q_j`.
    #[inline(always)]
    pub fn joint_column(&self, j: usize) -> Vector3<T> {
        let f = &self.frames[j];
        f.z.cross(&(self.point - f.o))
    }

    /// `∂p/∂r'_j` at the current pose for the corrected reading `r'_j` of joint `j` (what a
    /// joint correction adds to): the model-angle column plus, for every joint `k` coupled
    /// from `j`, `ratio_k · ∂p/∂q_k`. Equals [`Self::joint_column`] without couplings.
    #[inline]
    pub fn reading_column<V: ValueStorage>(&self, robot: &Robot<T, N, V>, j: usize) -> Vector3<T> {
        let couplings = robot.couplings();
        if couplings.is_empty() {
            self.joint_column(j)
        } else {
            self.coupled_column(couplings, j)
        }
    }

    /// [`Self::reading_column`] of a coupled robot (out of line: only coupled robots pay).
    #[inline(never)]
    fn coupled_column(&self, couplings: &Couplings<T, N>, j: usize) -> Vector3<T> {
        let mut c = self.joint_column(j);
        for i in 0..couplings.len() {
            if let Some((k, f, ratio)) = couplings.entry(i) {
                if f == j {
                    c += self.joint_column(k) * ratio;
                }
            }
        }
        c
    }

    /// The general joint Jacobian (effects and/or couplings) from the model-angle columns in
    /// `lin`, `ang`: through the couplings to readings, then times `1 + slope`. Out of line:
    /// a plain model does not come here.
    #[inline(never)]
    fn reading_jacobian<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        lin: &mut [Vector3<T>; N],
        ang: &mut [Vector3<T>; N],
    ) {
        let couplings = robot.couplings();
        if !couplings.is_empty() {
            couplings.reading_columns(lin);
            couplings.reading_columns(ang);
        }
        let effects = robot.effects();
        if !effects.is_empty() {
            let slope = effects.correction_slope(&self.q);
            for j in 0..N {
                let g = T::one() + slope[j];
                lin[j] *= g;
                ang[j] *= g;
            }
        }
    }

    /// Frame before joint `i`'s row (the base for the first joint).
    #[inline]
    fn previous(&self, i: usize) -> &Frame<T> {
        if i == 0 {
            &self.base
        } else {
            &self.frames[i - 1]
        }
    }

    /// One column of the identification Jacobian, `∂p/∂param`, at the last computed pose.
    /// Inline: called once per parameter and pose in identification's inner loop, where a
    /// call returning the column through memory stalls on store forwarding.
    #[inline(always)]
    pub fn column<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Result<Vector3<T>, ParamError> {
        let pt = self.point;
        let joint = |i: u8| -> Result<usize, ParamError> {
            let i = i as usize;
            if i < N {
                Ok(i)
            } else {
                Err(ParamError::OutOfRange)
            }
        };
        Ok(match p {
            Param::BaseX => Vector3::x(),
            Param::BaseY => Vector3::y(),
            Param::BaseZ => Vector3::z(),
            Param::BaseRx => Vector3::x().cross(&(pt - self.base.o)),
            Param::BaseRy => Vector3::y().cross(&(pt - self.base.o)),
            Param::BaseRz => Vector3::z().cross(&(pt - self.base.o)),
            Param::Alpha(i) => {
                let f = self.previous(joint(i)?);
                f.x.cross(&(pt - f.o))
            }
            Param::A(i) => self.previous(joint(i)?).x * self.length_scale(robot),
            Param::Beta(i) => {
                let i = joint(i)?;
                let f = self.previous(i);
                let t = &robot.trig()[i];
                let y = f.y * t.ca + f.z * t.sa;
                let o = f.o + f.x * (robot.joints()[i].a * self.length_scale(robot));
                y.cross(&(pt - o))
            }
            Param::Theta(i) => self.joint_column(joint(i)?),
            Param::D(i) => self.frames[joint(i)?].z * self.length_scale(robot),
            Param::ToolX | Param::ToolY | Param::ToolZ => {
                if N == 0 {
                    return Err(ParamError::OutOfRange);
                }
                if self.tool != 0 {
                    return Ok(Vector3::zeros());
                }
                let f = &self.frames[N - 1];
                let c = match p {
                    Param::ToolX => f.x,
                    Param::ToolY => f.y,
                    _ => f.z,
                };
                c * self.length_scale(robot)
            }
            Param::ToolPoint(k, a) => self.point_column(robot, k, a)?,
            // The measured frame's orientation does not move its points.
            Param::ToolRx | Param::ToolRy | Param::ToolRz => Vector3::zeros(),
            Param::Effect(k) => self.effect_column(robot, k)?,
        })
    }

    /// The column of coordinate `a` of tool point `k` ≥ 1: the flange axis when the point
    /// computed is `k`, zero for the others. Out of line (robots with one point never come).
    #[inline(never)]
    fn point_column<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        k: u8,
        a: u8,
    ) -> Result<Vector3<T>, ParamError> {
        if N == 0 || k == 0 || k as usize >= robot.tool_point_count() || a > 2 {
            return Err(ParamError::OutOfRange);
        }
        if self.tool != k {
            return Ok(Vector3::zeros());
        }
        let f = &self.frames[N - 1];
        Ok([f.x, f.y, f.z][a as usize] * self.length_scale(robot))
    }

    /// One column of the orientation's identification Jacobian at the last computed pose: the
    /// rotation vector (in the measurement frame) the measured frame turns by per unit of
    /// `param` (per rad of an angle, per mm of a length: zero for every length). Beside
    /// [`Self::column`], for 6-D observations.
    pub fn rotation_column<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Result<Vector3<T>, ParamError> {
        let joint = |i: u8| -> Result<usize, ParamError> {
            let i = i as usize;
            if i < N {
                Ok(i)
            } else {
                Err(ParamError::OutOfRange)
            }
        };
        Ok(match p {
            Param::BaseX | Param::BaseY | Param::BaseZ => Vector3::zeros(),
            Param::BaseRx => Vector3::x(),
            Param::BaseRy => Vector3::y(),
            Param::BaseRz => Vector3::z(),
            Param::Alpha(i) => self.previous(joint(i)?).x,
            Param::A(i) | Param::D(i) => {
                joint(i)?;
                Vector3::zeros()
            }
            Param::Beta(i) => {
                let i = joint(i)?;
                let f = self.previous(i);
                let t = &robot.trig()[i];
                f.y * t.ca + f.z * t.sa
            }
            Param::Theta(i) => self.frames[joint(i)?].z,
            Param::ToolX | Param::ToolY | Param::ToolZ | Param::ToolPoint(..) => {
                self.column(robot, p)?;
                Vector3::zeros()
            }
            Param::ToolRx | Param::ToolRy | Param::ToolRz => {
                if N == 0 {
                    return Err(ParamError::OutOfRange);
                }
                let f = &self.frames[N - 1];
                match p {
                    Param::ToolRx => f.x,
                    Param::ToolRy => f.y,
                    _ => f.z,
                }
            }
            Param::Effect(k) => match robot.effects().basis(k as usize, &self.q, &self.tau) {
                Some((j, phi)) => self.reading_rotation_column(robot, j) * phi,
                // Thermal expansion turns nothing.
                None => {
                    self.effect_column(robot, k)?;
                    Vector3::zeros()
                }
            },
        })
    }

    /// The rotation column of the corrected reading `r'_j` (see [`Self::reading_column`]):
    /// `z_j` plus, for every joint `k` coupled from `j`, `ratio_k · z_k`.
    pub fn reading_rotation_column<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        j: usize,
    ) -> Vector3<T> {
        let couplings = robot.couplings();
        let mut c = self.frames[j].z;
        for i in 0..couplings.len() {
            if let Some((k, f, ratio)) = couplings.entry(i) {
                if f == j {
                    c += self.frames[k].z * ratio;
                }
            }
        }
        c
    }

    /// The column of effect value `k`: `∂p/∂r'_j · φ_k` (the correction acts on the reading of
    /// its joint `j`, so the column goes through the couplings); for the thermal-expansion
    /// value `c`, `(T − T0) · (p − b) / s` at the temperature [`Self::temp_c`]: the point's
    /// offset from the base origin at the reference temperature, times `T − T0` (zero without
    /// a temperature); for base-drift value `k` (axis `a`), `(t − t0)` along axis `a` at the
    /// time [`Self::time_s`] (zero without a time). Out of line, so that the geometric columns
    /// (the LM's inner loop) do not pay for it.
    #[inline(never)]
    fn effect_column<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        k: u16,
    ) -> Result<Vector3<T>, ParamError> {
        let effects = robot.effects();
        match effects.basis(k as usize, &self.q, &self.tau) {
            Some((j, phi)) => Ok(self.reading_column(robot, j) * phi),
            // From the term and the temperature rather than from the last evaluation, so that
            // a term added to the model the pose was computed for (at c = 0) has its column.
            None => match (effects.thermal(), self.temp_c) {
                (Some((i, c, t0)), Some(t)) if i == k as usize => {
                    let dt = t - t0;
                    Ok((self.point - self.base.o) * (dt / (T::one() + c * dt)))
                }
                (Some((i, ..)), None) if i == k as usize => Ok(Vector3::zeros()),
                _ => self.drift_column(robot, k as usize),
            },
        }
    }

    /// The column of base-drift value `k`: `(t − t0)` along its axis (zero without a time).
    fn drift_column<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        k: usize,
    ) -> Result<Vector3<T>, ParamError> {
        let Some((first, _, t0)) = robot.effects().drift() else {
            return Err(ParamError::OutOfRange);
        };
        let dt = match self.time_s {
            Some(t) => t - t0,
            None => T::zero(),
        };
        match k.checked_sub(first) {
            Some(0) => Ok(Vector3::x() * dt),
            Some(1) => Ok(Vector3::y() * dt),
            Some(2) => Ok(Vector3::z() * dt),
            _ => Err(ParamError::OutOfRange),
        }
    }

    /// The identification Jacobian for `params` at the last computed pose, one column per
    /// parameter into `out` (same length as `params`).
    ///
    /// With a compliance term the geometric columns hold the lever arms τ fixed: their change
    /// with the geometry enters only through the compliance times a lever-arm change (a few 1e-6
    /// of a column for 1e-3 rad/m compliances, seen by the `kinematics` fuzz target),
    /// and Gauss–Newton converges with the approximate columns; the effect columns are exact.
    pub fn identification_jacobian<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
        params: &[Param],
        out: &mut [Vector3<T>],
    ) -> Result<(), ParamError> {
        if out.len() != params.len() {
            return Err(ParamError::Shape);
        }
        for (o, p) in out.iter_mut().zip(params) {
            *o = self.column(robot, *p)?;
        }
        Ok(())
    }

    /// Joint Jacobian of the point (`lin[j] = ∂p/∂r_j`) and of the tool orientation
    /// (`ang[j]`, rotation vector per rad) with respect to the joint *readings* `r`, including
    /// the slope of the joint corrections and the couplings (chain rule).
    pub fn joint_jacobian<V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
    ) -> ([Vector3<T>; N], [Vector3<T>; N]) {
        let mut lin = [Vector3::zeros(); N];
        let mut ang = [Vector3::zeros(); N];
        for j in 0..N {
            lin[j] = self.joint_column(j);
            ang[j] = self.frames[j].z;
        }
        // A plain model (the servo loop's usual case): readings are model angles, slope 0.
        if !(robot.effects().is_empty() && robot.couplings().is_empty()) {
            self.reading_jacobian(robot, &mut lin, &mut ang);
        }
        (lin, ang)
    }
}

/// Forward kinematics of one configuration without keeping the workspace.
pub fn point<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    q: &[T; N],
) -> Vector3<T> {
    ForwardKinematics::new().compute(robot, q)
}
