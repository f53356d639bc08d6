//! Base and tool frames from single-joint sweeps: the circle-point method (Gao et al. 2018 §2.2).
//!
//! Turning one joint while the others stay put moves the tracker target on a circle about that
//! joint's axis. Two such axes (joints 1 and 2) fix the robot base in the tracker frame up to
//! the nominal `d1`; the last two (wrist and flange) give the tool's distances from the flange
//! axis. Technicians run this on every tracker set-up because it needs nothing but the joint
//! order and the nominal first rows, and it puts identification within a fraction of a
//! millimetre of the answer.
//!
//! **What "the base" means here.** The model is `p = B·T_1(q_1)·…·tool`
//! (`docs/formats.md#kinematic-model`).
//! [`base_from_sweeps`] returns the `B` for which the *nominal* rows put joint 1's and joint 2's
//! axes where the sweeps found them. It registers the pair of axis lines: the axis-1 line, the
//! foot on it of the common normal with axis 2, and the common normal's direction (nominal
//! versus measured). For the usual first rows (row 1's alpha, a, beta = 0, row 2 without tilt)
//! this is exactly the recipe of the issue: z = joint 1's axis oriented by the right-hand rule
//! with increasing q1; origin = the point of axis 1 nearest axis 2, moved by −d1 along z;
//! x along the common normal towards axis 2 when row 2's a > 0 (away when a < 0), or
//! (z1 × z2)/sin(alpha) when the axes intersect, turned back about z by theta1 + q1 of the
//! joint-2 sweep. Because the nominal lines come from forward kinematics, nonzero alpha, a,
//! theta or beta in row 1 and a tilt in row 2 are handled as well. The direction about z is
//! the least-squares combination of the two independent clues, `z1 × z2` (exact whenever the
//! axes are not parallel) and the closest-point vector scaled by the joint-2 circle's radius
//! (exact whenever the axes do not intersect), each weighted by how well the sweeps determine
//! it; with exact data both give the same answer.
//!
//! The base height is not observable from the sweeps (it trades off with `d1`): the nominal `d1`
//! fixes it, as in the paper. Parallel joint-1 and joint-2 axes leave the height undetermined and
//! are refused.
//!
//! **Couplings.** With joint couplings (FANUC J3 read from the horizontal) a sweep is a
//! single-joint rotation of the *model* angle: [`base_from_sweeps`] and [`tool_from_sweeps`]
//! map the readings through the robot's couplings and require that only the swept joint's
//! model angle moved. Turning J2's reading alone also turns J3's model angle (the point then
//! does not move on a circle): that is refused with [`FramesError::CoupledJointMoved`]; the
//! sweep must move the coupled joint's reading by `−ratio ×` the swept joint's change.

use crate::frames::circle::{basis, fit_circle_with, unit, Circle, CircleError};
use crate::model::coupling::Couplings;
use crate::num::linalg::{cholesky, cholesky_solve, Square};
use crate::ValueStorage;
use crate::{ForwardKinematics, Frame, Real, Robot};
use nalgebra::Vector3;

/// Largest excursion (rad) of a joint that should stay still during another joint's sweep.
pub const FIXED_JOINT_TOLERANCE: f64 = 1e-3;

/// Why frames could not be found from the sweeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FramesError {
    /// The circle fit failed (too few points, non-finite values, points on a line).
    Circle(CircleError),
    /// Points and readings differ in number, or a joint index is beyond the robot's joints.
    Shape,
    /// A reading is NaN or infinite.
    NotFinite,
    /// The swept joint's readings do not change, or do not turn the points the way they say.
    NoRotation,
    /// A joint other than the swept one moved during the sweep (0-based joint index).
    OtherJointMoved(u8),
    /// The model angle of this joint (0-based) turned with the swept joint because it is
    /// coupled to it ([`crate::Couplings`]) while its reading stayed put: the sweep is not a
    /// single rotation. Move its reading by `−ratio ×` the swept joint's change instead.
    CoupledJointMoved(u8),
    /// The two axes are parallel: the base height or the common normal is undetermined.
    ParallelAxes,
    /// The two lines coincide.
    Coincident,
}

impl From<CircleError> for FramesError {
    fn from(e: CircleError) -> Self {
        FramesError::Circle(e)
    }
}

/// An infinite straight line: a point on it and a unit direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line<T: Real> {
    /// A point on the line (mm).
    pub point: Vector3<T>,
    /// Unit direction.
    pub direction: Vector3<T>,
}

impl<T: Real> Line<T> {
    /// A line through `point` along `direction` (normalised); `None` for a zero or non-finite one.
    pub fn new(point: Vector3<T>, direction: Vector3<T>) -> Option<Self> {
        if !point.iter().all(|v| v.finite()) {
            return None;
        }
        Some(Self {
            point,
            direction: unit(direction)?,
        })
    }

    /// The point of the line nearest `p`.
    pub fn closest(&self, p: &Vector3<T>) -> Vector3<T> {
        self.point + self.direction * (p - self.point).dot(&self.direction)
    }

    /// Distance of `p` from the line.
    pub fn distance(&self, p: &Vector3<T>) -> T {
        (p - self.closest(p)).norm()
    }
}

/// The common normal of two lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommonNormal<T: Real> {
    /// Its foot on the first line.
    pub on_first: Vector3<T>,
    /// Its foot on the second line.
    pub on_second: Vector3<T>,
    /// Distance between the lines (≥ 0).
    pub distance: T,
    /// Unit direction, from the first line towards the second; for intersecting lines
    /// (distance 0) `first × second` normalised.
    pub direction: Vector3<T>,
    /// `|first × second|`: sine of the angle between the lines.
    pub sin_angle: T,
    /// True when the lines are parallel (to √ε): the feet are then the first line's `point`
    /// and its projection onto the second line.
    pub parallel: bool,
}

/// Common normal of two lines: closest points, distance and direction; parallel lines get
/// the normal through the first line's `point`; coinciding lines have none.
pub fn common_normal<T: Real>(a: &Line<T>, b: &Line<T>) -> Result<CommonNormal<T>, FramesError> {
    let cross = a.direction.cross(&b.direction);
    let sin_angle = cross.norm();
    let w0 = a.point - b.point;
    let scale = T::one() + a.point.norm() + b.point.norm();
    if !(sin_angle.finite() && w0.iter().all(|v| v.finite())) {
        return Err(FramesError::NotFinite);
    }
    if sin_angle <= T::EPS.sqrt() {
        let on_first = a.point;
        let on_second = b.closest(&a.point);
        let gap = on_second - on_first;
        let distance = gap.norm();
        if distance <= T::EPS * T::of(64.0) * scale {
            return Err(FramesError::Coincident);
        }
        return Ok(CommonNormal {
            on_first,
            on_second,
            distance,
            direction: gap / distance,
            sin_angle,
            parallel: true,
        });
    }
    let c = a.direction.dot(&b.direction);
    let d = a.direction.dot(&w0);
    let e = b.direction.dot(&w0);
    let denom = sin_angle * sin_angle;
    let s = (c * e - d) / denom;
    let t = (e - c * d) / denom;
    let on_first = a.point + a.direction * s;
    let on_second = b.point + b.direction * t;
    let gap = on_second - on_first;
    let distance = gap.norm();
    let mut direction = cross / sin_angle;
    if direction.dot(&gap) < T::zero() && distance > T::EPS * T::of(64.0) * scale {
        direction = -direction;
    }
    Ok(CommonNormal {
        on_first,
        on_second,
        distance,
        direction,
        sin_angle,
        parallel: false,
    })
}

/// A joint's axis found from a sweep, with the circle it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointAxis<T: Real> {
    /// Through the circle's centre, along its normal, oriented so that increasing the joint
    /// reading turns the points right-handedly about it.
    pub line: Line<T>,
    /// The fitted circle (its normal oriented like the line).
    pub circle: Circle<T>,
    /// Range of the joint readings over the sweep (rad).
    pub span: T,
}

/// The axis of a joint from points measured while only that joint turned, `angles[i]` being
/// the joint reading (rad) at `points[i]`.
pub fn joint_axis<T: Real>(
    points: &[Vector3<T>],
    angles: &[T],
) -> Result<JointAxis<T>, FramesError> {
    if points.len() != angles.len() {
        return Err(FramesError::Shape);
    }
    let p = |i: usize| points.get(i).copied().unwrap_or_default();
    let q = |i: usize| angles.get(i).copied().unwrap_or_default();
    axis_with(points.len(), p, q)
}

fn axis_with<T: Real, P: Fn(usize) -> Vector3<T>, Q: Fn(usize) -> T>(
    n: usize,
    p: P,
    q: Q,
) -> Result<JointAxis<T>, FramesError> {
    let (mut lo, mut hi) = (T::zero(), T::zero());
    for i in 0..n {
        let a = q(i);
        if !a.finite() {
            return Err(FramesError::NotFinite);
        }
        if i == 0 || a < lo {
            lo = a;
        }
        if i == 0 || a > hi {
            hi = a;
        }
    }
    let mut circle = fit_circle_with(n, &p)?;
    // Right-hand rule: between consecutive samples the points turn by Δq about the axis, so
    // ((p_i − c) × (p_j − c))·n has the sign of sin(Δq) when n is oriented right. Weighting by
    // sin(Δq) makes the sum insensitive to the samples' order.
    let mut s = T::zero();
    for i in 1..n {
        let turn = (p(i - 1) - circle.centre)
            .cross(&(p(i) - circle.centre))
            .dot(&circle.normal);
        s += turn * (q(i) - q(i - 1)).sin();
    }
    if !(s.abs() > T::zero()) {
        return Err(FramesError::NoRotation);
    }
    if s < T::zero() {
        circle.normal = -circle.normal;
    }
    let line = Line::new(circle.centre, circle.normal).ok_or(FramesError::NotFinite)?;
    Ok(JointAxis {
        line,
        circle,
        span: hi - lo,
    })
}

/// The records of one single-joint sweep: `joint` (0-based) turned, the others stayed put.
#[derive(Clone, Copy, Debug)]
pub struct Sweep<'a, T: Real, const N: usize> {
    /// The joint that turned (0-based).
    pub joint: usize,
    /// Measured points (mm, measurement frame).
    pub points: &'a [Vector3<T>],
    /// Joint readings (rad) at each point.
    pub q: &'a [[T; N]],
}

impl<'a, T: Real, const N: usize> Sweep<'a, T, N> {
    fn check(&self) -> Result<(), FramesError> {
        if self.joint >= N || self.points.len() != self.q.len() {
            return Err(FramesError::Shape);
        }
        Ok(())
    }

    /// Mean readings over the sweep; errors if a joint other than the swept one moved by more
    /// than [`FIXED_JOINT_TOLERANCE`].
    pub fn fixed_readings(&self) -> Result<[T; N], FramesError> {
        self.fixed_readings_coupled(&Couplings::new())
    }

    /// As [`Sweep::fixed_readings`] for a robot with `couplings`: the joints other than the
    /// swept one must keep their *model* angles (readings through the couplings). Returns the
    /// mean readings.
    pub fn fixed_readings_coupled(
        &self,
        couplings: &Couplings<T, N>,
    ) -> Result<[T; N], FramesError> {
        self.check()?;
        if self.q.is_empty() {
            return Err(FramesError::Circle(CircleError::TooFewPoints));
        }
        let mut mean = [T::zero(); N];
        for row in self.q.iter() {
            for (m, v) in mean.iter_mut().zip(row) {
                if !v.finite() {
                    return Err(FramesError::NotFinite);
                }
                *m += *v;
            }
        }
        let nt = T::of(self.q.len() as f64);
        for m in mean.iter_mut() {
            *m /= nt;
        }
        let tol = T::of(FIXED_JOINT_TOLERANCE);
        if couplings.is_empty() {
            for row in self.q.iter() {
                for (j, (v, m)) in row.iter().zip(mean.iter()).enumerate() {
                    if j != self.joint && (*v - *m).abs() > tol {
                        return Err(FramesError::OtherJointMoved(j as u8));
                    }
                }
            }
            return Ok(mean);
        }
        // The model angles are linear in the readings: their mean is the mean's model angles.
        let mean_model = couplings.to_model(&mean);
        for row in self.q.iter() {
            let model = couplings.to_model(row);
            for j in 0..N {
                if j == self.joint || !((model[j] - mean_model[j]).abs() > tol) {
                    continue;
                }
                let dragged = couplings.get(j).is_some_and(|(f, _)| f == self.joint)
                    && !((row[j] - mean[j]).abs() > tol);
                return Err(if dragged {
                    FramesError::CoupledJointMoved(j as u8)
                } else {
                    FramesError::OtherJointMoved(j as u8)
                });
            }
        }
        Ok(mean)
    }

    /// The swept joint's axis (see [`joint_axis`]).
    pub fn axis(&self) -> Result<JointAxis<T>, FramesError> {
        self.check()?;
        let j = self.joint;
        let p = |i: usize| self.points.get(i).copied().unwrap_or_default();
        let q = |i: usize| {
            self.q
                .get(i)
                .and_then(|r| r.get(j))
                .copied()
                .unwrap_or_default()
        };
        axis_with(self.points.len(), p, q)
    }
}

/// The base pose found from a joint-1 and a joint-2 sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseEstimate<T: Real> {
    /// `B`: the robot base in the measurement frame, as the model's `[base]` means it.
    pub base: Frame<T>,
    /// Joint 1's axis, from its sweep.
    pub axis1: JointAxis<T>,
    /// Joint 2's axis, from its sweep.
    pub axis2: JointAxis<T>,
    /// Common normal of the measured axes 1 and 2.
    pub common_normal: CommonNormal<T>,
}

/// Base pose `B` from a sweep of joint 1 (`first.joint == 0`) and one of joint 2
/// (`second.joint == 1`), with the nominal rows of `robot` (its base is ignored). See the
/// module documentation for the definition.
pub fn base_from_sweeps<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    first: &Sweep<'_, T, N>,
    second: &Sweep<'_, T, N>,
) -> Result<BaseEstimate<T>, FramesError> {
    if N < 2 || first.joint != 0 || second.joint != 1 {
        return Err(FramesError::Shape);
    }
    let couplings = robot.couplings();
    first.fixed_readings_coupled(couplings)?;
    let q = second.fixed_readings_coupled(couplings)?;
    let axis1 = first.axis()?;
    let axis2 = second.axis()?;
    let measured = common_normal(&axis1.line, &axis2.line)?;
    if measured.parallel {
        return Err(FramesError::ParallelAxes);
    }

    // Nominal axes at the joint-2 sweep's readings, in the robot base frame.
    let mut fk = ForwardKinematics::<T, N>::new();
    fk.compute(robot, &q);
    let to_base = robot.base().inverse();
    let nominal_line = |k: usize| -> Result<Line<T>, FramesError> {
        let f = fk.frames.get(k).ok_or(FramesError::Shape)?;
        Line::new(to_base.point(&f.o), to_base.direction(&f.z)).ok_or(FramesError::NotFinite)
    };
    let n1 = nominal_line(0)?;
    let n2 = nominal_line(1)?;
    let nominal = common_normal(&n1, &n2)?;
    if nominal.parallel {
        return Err(FramesError::ParallelAxes);
    }

    // Turn about axis 1 that best maps the nominal clues onto the measured ones.
    let scale = axis2.circle.radius.max(T::EPS);
    let clues = |l1: &Line<T>, l2: &Line<T>, c: &CommonNormal<T>| {
        [
            l1.direction.cross(&l2.direction),
            (c.on_second - c.on_first) / scale,
        ]
    };
    let cn = clues(&n1, &n2, &nominal);
    let cm = clues(&axis1.line, &axis2.line, &measured);
    let (e1n, e2n) = basis(&n1.direction);
    let (e1m, e2m) = basis(&axis1.line.direction);
    let (mut sx, mut sy) = (T::zero(), T::zero());
    for (vn, vm) in cn.iter().zip(cm.iter()) {
        let (ax, ay) = (vn.dot(&e1n), vn.dot(&e2n));
        let (bx, by) = (vm.dot(&e1m), vm.dot(&e2m));
        sx += ax * bx + ay * by;
        sy += ax * by - ay * bx;
    }
    if !(sx.abs() + sy.abs() > T::zero()) {
        return Err(FramesError::ParallelAxes);
    }
    let (s, c) = sy.atan2(sx).sincos();
    let z = axis1.line.direction;
    let x = e1m * c + e2m * s;
    let g_meas = Frame {
        x,
        y: z.cross(&x),
        z,
        o: measured.on_first,
    };
    let g_nom = Frame {
        x: e1n,
        y: e2n,
        z: n1.direction,
        o: nominal.on_first,
    };
    let mut base = g_meas.compose(&g_nom.inverse());
    base.orthonormalize();
    if ![base.x, base.y, base.z, base.o]
        .iter()
        .all(|v| v.iter().all(|c| c.finite()))
    {
        return Err(FramesError::NotFinite);
    }
    Ok(BaseEstimate {
        base,
        axis1,
        axis2,
        common_normal: measured,
    })
}

/// How [`ToolEstimate::axial`] was obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxialMethod {
    /// Both axes measured: the flange circle's centre along the flange axis, from the foot
    /// of the common normal with the wrist axis. Exact for any tool point and any angle
    /// between the axes; used when the flange axis's direction is known to 1 mrad.
    FlangeAxis,
    /// The centre of the flange rotation (a point of the flange axis, well determined even
    /// when the tool point is on the axis and does not move) at its distance from the wrist
    /// axis, less the nominal last-row `a` (Pythagoras). Exact when the wrist and flange axes
    /// are perpendicular (alpha_N = ±90°, the usual wrist).
    CentreToWristAxis,
    /// No usable flange sweep: the wrist circle's radius, as in the paper (assumes the point
    /// is on the flange axis).
    WristRadius,
}

/// Tool distances from a wrist sweep (joint N−1, "joint 5") and a flange sweep (joint N).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolEstimate<T: Real> {
    /// Distance of the measured point from the flange axis, `√(tool_x² + tool_y²)` (mm);
    /// `None` without a flange sweep.
    pub radial: Option<T>,
    /// True when the flange sweep moved the point clearly more than the noise, so the flange
    /// circle (and its axis) could be fitted; otherwise `radial` is the noise-level estimate
    /// of the rotation's radius from the joint readings.
    pub radial_resolved: bool,
    /// Position of the point along the flange axis from the foot of the common normal with the
    /// wrist axis: `d_N + tool_z` of the model (mm).
    pub axial: T,
    /// How `axial` was obtained.
    pub method: AxialMethod,
    /// The wrist axis.
    pub wrist: JointAxis<T>,
    /// The flange axis, when resolved.
    pub flange: Option<JointAxis<T>>,
}

/// The tool's radial and axial distances from the last two joints' sweeps.
///
/// `wrist.joint` must be N−2 and `flange.joint` N−1 (0-based). The flange sweep must keep the
/// joints before the wrist where the wrist sweep had them for [`AxialMethod::FlangeAxis`];
/// otherwise the less general methods are used.
pub fn tool_from_sweeps<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    wrist: &Sweep<'_, T, N>,
    flange: Option<&Sweep<'_, T, N>>,
) -> Result<ToolEstimate<T>, FramesError> {
    if N < 2 || wrist.joint != N - 2 || flange.is_some_and(|f| f.joint != N - 1) {
        return Err(FramesError::Shape);
    }
    let couplings = robot.couplings();
    let qw = wrist.fixed_readings_coupled(couplings)?;
    let wax = wrist.axis()?;
    let last = robot.joints().get(N - 1).ok_or(FramesError::Shape)?;
    let a_last = last.a;
    let sign = if last.d + robot.tool().z < T::zero() {
        -T::one()
    } else {
        T::one()
    };
    let from_distance = |d: T| sign * (d * d - a_last * a_last).max(T::zero()).sqrt();

    let Some(fl) = flange else {
        return Ok(ToolEstimate {
            radial: None,
            radial_resolved: false,
            axial: from_distance(wax.circle.radius),
            method: AxialMethod::WristRadius,
            wrist: wax,
            flange: None,
        });
    };
    let qf = fl.fixed_readings_coupled(couplings)?;
    // The same arm pose: the joints before the wrist at the same model angles.
    let (mw, mf) = (couplings.to_model(&qw), couplings.to_model(&qf));
    let same_arm = mw
        .iter()
        .zip(mf.iter())
        .take(N - 2)
        .all(|(a, b)| (*a - *b).abs() <= T::of(FIXED_JOINT_TOLERANCE));
    let rot = rotation_fit(fl)?;
    let resolved = rot.radius > T::of(10.0) * rot.sd_radius;
    let fax = if resolved { fl.axis().ok() } else { None };
    let mut est = ToolEstimate {
        radial: Some(fax.map_or(rot.radius, |a| a.circle.radius)),
        radial_resolved: fax.is_some(),
        axial: from_distance(wax.circle.radius),
        method: AxialMethod::WristRadius,
        wrist: wax,
        flange: fax,
    };
    if !same_arm {
        return Ok(est);
    }
    // The flange axis's direction is good enough when a milliradian tilt costs nothing
    // (it moves the axial distance by s·δ²/2); otherwise the rotation's centre is the better
    // clue, provided the nominal wrist is perpendicular.
    let perpendicular = last.alpha.cos().abs() < T::of(1e-3) && last.beta == T::zero();
    let centre = fax.map_or(rot.centre, |a| a.circle.centre);
    let by_axis = fax.and_then(|fa| {
        let good = fa.circle.sd_normal < T::of(1e-3) || !perpendicular;
        let cn = common_normal(&wax.line, &fa.line)
            .ok()
            .filter(|cn| !cn.parallel)?;
        good.then(|| (fa.circle.centre - cn.on_second).dot(&fa.line.direction))
    });
    match by_axis {
        Some(axial) => {
            est.axial = axial;
            est.method = AxialMethod::FlangeAxis;
        }
        None => {
            est.axial = from_distance(wax.line.distance(&centre));
            est.method = AxialMethod::CentreToWristAxis;
        }
    }
    Ok(est)
}

/// Least-squares fit of `p_i = c + A·cos q_i + B·sin q_i` (known turning angles): linear, so it
/// stays well posed when the rotation's radius is at the noise level.
struct Rotation<T: Real> {
    centre: Vector3<T>,
    radius: T,
    sd_radius: T,
}

fn rotation_fit<T: Real, const N: usize>(s: &Sweep<'_, T, N>) -> Result<Rotation<T>, FramesError> {
    let j = s.joint;
    let n = s.points.len();
    if n < 4 {
        return Err(FramesError::Circle(CircleError::TooFewPoints));
    }
    let q0 =
        s.q.first()
            .and_then(|r| r.get(j))
            .copied()
            .unwrap_or_default();
    let p0 = s.points.first().copied().unwrap_or_default();
    let row = |i: usize| {
        let q =
            s.q.get(i)
                .and_then(|r| r.get(j))
                .copied()
                .unwrap_or_default()
                - q0;
        let (sn, cs) = q.sincos();
        [T::one(), cs, sn]
    };
    let mut m: Square<T, 3> = [[T::zero(); 3]; 3];
    let mut rhs = [[T::zero(); 3]; 3]; // rhs[coordinate][basis]
    for (i, p) in s.points.iter().enumerate() {
        let f = row(i);
        let d = p - p0;
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] += f[r] * f[c];
            }
            for k in 0..3 {
                rhs[k][r] += f[r] * d[k];
            }
        }
    }
    let mut l = m;
    cholesky(&mut l, 3).map_err(|_| FramesError::NoRotation)?;
    for r in rhs.iter_mut() {
        cholesky_solve(&l, 3, r).map_err(|_| FramesError::NoRotation)?;
    }
    let mut sse = T::zero();
    for (i, p) in s.points.iter().enumerate() {
        let f = row(i);
        let d = p - p0;
        for (k, r) in rhs.iter().enumerate() {
            let e = d[k] - (r[0] * f[0] + r[1] * f[1] + r[2] * f[2]);
            sse += e * e;
        }
    }
    let dof = 3 * n - 9;
    let sigma2 = sse / T::of(dof as f64);
    let mut inv = [T::zero(); 2];
    for (k, v) in inv.iter_mut().enumerate() {
        let mut e = [T::zero(); 3];
        e[k + 1] = T::one();
        cholesky_solve(&l, 3, &mut e).map_err(|_| FramesError::NoRotation)?;
        *v = e[k + 1];
    }
    let a = Vector3::new(rhs[0][1], rhs[1][1], rhs[2][1]);
    let b = Vector3::new(rhs[0][2], rhs[1][2], rhs[2][2]);
    let radius = ((a.norm_squared() + b.norm_squared()) * T::of(0.5)).sqrt();
    let sd_radius = (sigma2 * (inv[0] + inv[1]) * T::of(0.5)).sqrt();
    Ok(Rotation {
        centre: p0 + Vector3::new(rhs[0][0], rhs[1][0], rhs[2][0]),
        radius,
        sd_radius,
    })
}
