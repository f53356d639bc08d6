//! The identification objective shared by the global searches ([`crate::identify::pso`], BPNN-PSO).
//!
//! A candidate is a vector of parameter *deltas* from a reference robot over a [`ParamSet`]
//! (the paper's 24 MDH errors, or any other set). Its fitness is the paper's objective (§2.3,
//! eq. 10): the **sum** over the poses of the squared position error, in mm²,
//!
//! `f(x) = Σ_k |p_k − FK(reference ⊕ x, q_k)|²`.
//!
//! The sum (not the mean) is used so that a PSO fitness and the Levenberg–Marquardt cost
//! ([`crate::identify::lm::LmProgress::cost`]) are the same number and can share a table; RMS per pose is
//! `sqrt(f / poses)`.
//!
//! **Speed.** A swarm evaluates the same poses thousands of times with different geometry. With
//! a caller-provided [`JointTrig`] buffer ([`PositionFitness::with_cache`]) the sine and cosine of
//! every joint reading are computed once, and each evaluation combines them with the candidate's
//! `theta` by the angle-addition formulas: no trigonometry per pose, which makes an `f64`
//! evaluation several times cheaper. Robots with joint-correction effects (whose joint angles
//! depend on the geometry) always take the general [`ForwardKinematics`] path.
//!
//! ```
//! use kinecal::forward::point;
//! use kinecal::identify::fitness::{Objective, PositionFitness};
//! use kinecal::model::param::{Param, ParamSet};
//! use kinecal::{Frame, Joint, Measurement, Robot};
//! use nalgebra::Vector3;
//!
//! let rows = [
//!     Joint::mdh_deg(0.0, 0.0, 0.0, 400.0),
//!     Joint::mdh_deg(90.0, 100.0, 0.0, 0.0),
//!     Joint::mdh_deg(0.0, 500.0, 0.0, 0.0),
//! ];
//! let nominal: Robot<f64, 3> =
//!     Robot::new(Frame::identity(), rows, Vector3::new(300.0, 0.0, 0.0)).unwrap();
//! // The real arm's first row is 0.5 mm taller: every point sits 0.5 mm higher.
//! let mut real = nominal.clone();
//! let mut row = real.joints()[0];
//! row.d += 0.5;
//! real.set_joint(0, row).unwrap();
//! let data: Vec<Measurement<f64, 3>> = (0..10)
//!     .map(|k| {
//!         let q = [0.3 * k as f64, 0.1 * k as f64, -0.2 * k as f64];
//!         Measurement::new(q, point(&real, &q))
//!     })
//!     .collect();
//!
//! let params: ParamSet<12> = ParamSet::mdh(3).unwrap(); // alpha, a, theta, d per joint
//! let mut f = PositionFitness::new(&nominal, &params, &data).unwrap();
//! let zero = [0.0; 12];
//! assert!((f.fitness(&zero) - 10.0 * 0.25).abs() < 1e-9); // Σ |0.5 mm|² over 10 poses
//!
//! let mut x = [0.0; 12];
//! x[params.position(Param::D(0)).unwrap()] = 0.5; // the candidate: d1 + 0.5 mm
//! assert!(f.fitness(&x) < 1e-18);
//! assert_eq!(f.robot(&x).unwrap().joints()[0].d, 400.5);
//! ```

use crate::identify::lm::observation_cost;
use crate::model::param::{apply_delta, ParamError, ParamSet};
use crate::model::robot::RowTrig;
use crate::ValueStorage;
use crate::{ForwardKinematics, Frame, Joint, Measurement, Real, Robot};

/// `(sin q_j, cos q_j)` of one pose's model angles (the joint readings through the robot's
/// couplings): the per-pose cache of [`PositionFitness`].
pub type JointTrig<T, const N: usize> = [(T, T); N];

/// A function to minimise over `dimension()` real variables; lower is better.
///
/// Non-finite values mark infeasible candidates: searches treat them as +∞.
pub trait Objective<T: Real> {
    /// Number of variables.
    fn dimension(&self) -> usize;
    /// Fitness of `x` (`x.len() == dimension()`).
    fn fitness(&mut self, x: &[T]) -> T;
}

/// Why a [`PositionFitness`] could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FitnessError {
    /// No measurements.
    NoMeasurements,
    /// A measurement holds NaN or infinity.
    NonFiniteMeasurement,
    /// The parameter set does not fit the robot.
    Params(ParamError),
    /// The trigonometry cache has fewer entries than there are measurements.
    CacheTooSmall,
    /// A measurement names a tool point the robot does not have.
    UnknownToolPoint,
}

/// Sum of squared position errors (mm²) of `reference ⊕ x` over a set of measurements.
///
/// Holds the scratch robot and forward-kinematics workspace, so one evaluation allocates
/// nothing: it copies the reference, applies `x` with [`apply_delta`] and runs the chain once
/// per pose.
#[derive(Clone, Debug)]
pub struct PositionFitness<'a, T: Real, const N: usize, V: ValueStorage, const P: usize> {
    reference: &'a Robot<T, N, V>,
    params: &'a ParamSet<P>,
    data: &'a [Measurement<T, N>],
    work: Robot<T, N, V>,
    fk: ForwardKinematics<T, N>,
    /// Per-pose joint trigonometry (fast path), `None` for the general path.
    cache: Option<&'a [JointTrig<T, N>]>,
}

impl<'a, T: Real, const N: usize, V: ValueStorage, const P: usize> PositionFitness<'a, T, N, V, P> {
    /// The objective for deltas over `params` from `reference`, fitted to `data`.
    pub fn new(
        reference: &'a Robot<T, N, V>,
        params: &'a ParamSet<P>,
        data: &'a [Measurement<T, N>],
    ) -> Result<Self, FitnessError> {
        params.check(reference).map_err(FitnessError::Params)?;
        if data.is_empty() {
            return Err(FitnessError::NoMeasurements);
        }
        if data.iter().any(|m| !m.is_finite()) {
            return Err(FitnessError::NonFiniteMeasurement);
        }
        if data
            .iter()
            .any(|m| m.tool as usize >= reference.tool_point_count())
        {
            return Err(FitnessError::UnknownToolPoint);
        }
        Ok(Self {
            reference,
            params,
            data,
            work: reference.clone(),
            fk: ForwardKinematics::new(),
            cache: None,
        })
    }

    /// As [`PositionFitness::new`], filling `cache` (at least one entry per measurement) with
    /// the sine and cosine of the readings' model angles (through `reference`'s couplings) so
    /// that evaluations need no trigonometry. The cache is used only when `reference` has no
    /// joint-correction effects.
    pub fn with_cache(
        reference: &'a Robot<T, N, V>,
        params: &'a ParamSet<P>,
        data: &'a [Measurement<T, N>],
        cache: &'a mut [JointTrig<T, N>],
    ) -> Result<Self, FitnessError> {
        let mut f = Self::new(reference, params, data)?;
        let cache = cache
            .get_mut(..data.len())
            .ok_or(FitnessError::CacheTooSmall)?;
        // The model angles of the readings: couplings are part of the reference and constant
        // over the search (without effects nothing else moves them).
        let couplings = reference.couplings();
        for (c, m) in cache.iter_mut().zip(data) {
            let q = couplings.to_model(&m.q);
            for (cj, q) in c.iter_mut().zip(q.iter()) {
                *cj = q.sincos();
            }
        }
        // The fast path computes the first point's position: plain observations only.
        let plain = data
            .iter()
            .all(|m| m.tool == 0 && m.orientation.is_none() && m.unweighted());
        if reference.effects().is_empty() && plain {
            f.cache = Some(cache);
        }
        Ok(f)
    }

    /// The robot the deltas are applied to.
    pub fn reference(&self) -> &Robot<T, N, V> {
        self.reference
    }
    /// The parameters the candidate's components change, in order.
    pub fn params(&self) -> &ParamSet<P> {
        self.params
    }
    /// The poses the fitness sums over.
    pub fn measurements(&self) -> &[Measurement<T, N>] {
        self.data
    }

    /// The robot a candidate describes: `reference ⊕ x`.
    pub fn robot(&self, x: &[T]) -> Result<Robot<T, N, V>, ParamError> {
        let mut r = self.reference.clone();
        apply_delta(&mut r, self.params, x)?;
        Ok(r)
    }

    /// Sum of squared (weighted) residuals of `robot` over the measurements: mm² for plain
    /// position data, the Levenberg–Marquardt cost in general.
    pub fn of_robot(&mut self, robot: &Robot<T, N, V>) -> T {
        cost(&mut self.fk, robot, self.data)
    }
}

impl<T: Real, const N: usize, V: ValueStorage, const P: usize> Objective<T>
    for PositionFitness<'_, T, N, V, P>
{
    fn dimension(&self) -> usize {
        self.params.len()
    }

    /// `+∞` when `x` has the wrong length or is not finite.
    fn fitness(&mut self, x: &[T]) -> T {
        self.work.clone_from(self.reference);
        if apply_delta(&mut self.work, self.params, x).is_err() {
            return T::of(f64::INFINITY);
        }
        if let Some(cache) = self.cache {
            return sum_cached(&self.work, self.data, cache);
        }
        cost(&mut self.fk, &self.work, self.data)
    }
}

/// Σ of the observations' weighted squared residuals ([`observation_cost`]).
fn cost<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    data: &[Measurement<T, N>],
) -> T {
    let mut s = T::zero();
    for m in data {
        // Tool points were checked at construction.
        s += observation_cost(fk, robot, m).unwrap_or(T::of(f64::INFINITY));
    }
    s
}

/// The fast path: forward kinematics of the measured point only, with the joint angle's sine
/// and cosine from `sin(θ + q)`, `cos(θ + q)` by angle addition. Same arithmetic as
/// [`ForwardKinematics::compute`] otherwise (tested against it).
fn sum_cached<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    data: &[Measurement<T, N>],
    cache: &[JointTrig<T, N>],
) -> T {
    let joints = robot.joints();
    let rows = robot.trig();
    let mut theta = [(T::zero(), T::one()); N];
    for (t, j) in theta.iter_mut().zip(joints.iter()) {
        *t = j.theta.sincos();
    }
    let mut s = T::zero();
    for (m, qt) in data.iter().zip(cache) {
        let mut f = *robot.base();
        for i in 0..N {
            let (st, ct) = theta[i];
            let (sq, cq) = qt[i];
            f = advance(
                &f,
                &joints[i],
                &rows[i],
                st * cq + ct * sq,
                ct * cq - st * sq,
            );
        }
        let p = if N > 0 {
            f.point(robot.tool())
        } else {
            robot.base().o
        };
        s += (m.point - p).norm_squared();
    }
    s
}

/// `F · Rx(α)·Tx(a)·Ry(β)·Rz(θ+q)·Tz(d)` with `(s, c) = sin/cos(θ+q)` given.
#[inline(always)]
fn advance<T: Real>(f: &Frame<T>, j: &Joint<T>, t: &RowTrig<T>, s: T, c: T) -> Frame<T> {
    let mut x = f.x;
    let mut y = f.y * t.ca + f.z * t.sa;
    let mut z = f.z * t.ca - f.y * t.sa;
    let o = f.o + f.x * j.a;
    if t.tilted {
        let nx = x * t.cb - z * t.sb;
        z = x * t.sb + z * t.cb;
        x = nx;
    }
    let nx = x * c + y * s;
    y = y * c - x * s;
    x = nx;
    Frame {
        x,
        y,
        z,
        o: o + z * j.d,
    }
}
