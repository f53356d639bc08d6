//! One observation of the tool: joint readings and what the tracker saw — a point, and with a
//! 6-DoF probe the orientation too, each with the weight its uncertainty gives it.
//!
//! Identification minimises the sum over observations of
//! `|w ⊙ (p_measured − p(q))|² + (w_rot · |log(R_measured · R(q)ᵀ)|)²`:
//! the position residual (mm) weighted per coordinate by `w` (1 each, or 1/σ), the
//! orientation residual (the rotation vector of the orientation error, rad) by `w_rot`. With
//! unit weights and no orientation this is the plain sum of squared distances. With several
//! reflectors on one tool, each reflector seen in a pose is one observation naming its point.

use crate::{Frame, Real};
use nalgebra::Vector3;

/// What identification reads of one observation. [`Measurement`] is the general one; a caller
/// storing many plain position readings (firmware RAM, a C array) may keep a smaller type and
/// implement this with the defaults: first tool point, unweighted, position only.
pub trait Observation<T: Real, const N: usize> {
    /// Joint readings, rad.
    fn q(&self) -> &[T; N];
    /// Measured point, mm, measurement frame.
    fn point(&self) -> Vector3<T>;
    /// Which of the robot's tool points was measured (0: [`crate::Robot::tool`]).
    #[inline(always)]
    fn tool(&self) -> usize {
        0
    }
    /// Per-coordinate weights of the point's residual; `None`: unweighted (residual in mm).
    #[inline(always)]
    fn weight(&self) -> Option<Vector3<T>> {
        None
    }
    /// Measured tool-frame orientation and the weight of its residual, for a 6-D observation.
    #[inline(always)]
    fn orientation(&self) -> Option<(&Frame<T>, T)> {
        None
    }
    /// The arm's temperature when the observation was taken (°C), for a model with a
    /// thermal-expansion term; `None`: at the term's reference temperature.
    #[inline(always)]
    fn temperature(&self) -> Option<T> {
        None
    }
    /// When the observation was taken (s, the session's clock), for a model with a base-drift
    /// term; `None`: at the term's reference time.
    #[inline(always)]
    fn time(&self) -> Option<T> {
        None
    }
    /// The temperature and time the model is evaluated at for this observation.
    #[inline(always)]
    fn conditions(&self) -> crate::Conditions<T> {
        crate::Conditions {
            temp_c: self.temperature(),
            time_s: self.time(),
        }
    }
    /// True when every number is finite (weights not negative, the orientation a rotation).
    fn is_valid(&self) -> bool;
}

/// Joint readings `q` (rad) and the measured point (mm, measurement frame), with the point's
/// weights, the tool point it is, and optionally the measured orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement<T: Real, const N: usize> {
    /// Joint readings, rad (as the controller reports them, before couplings).
    pub q: [T; N],
    /// Measured point, mm, in the measurement frame.
    pub point: Vector3<T>,
    /// Which of the robot's tool points was measured (0: [`crate::Robot::tool`]).
    pub tool: u8,
    /// Weight of each coordinate's residual (1/σ for σ in mm; 1 = unweighted, residuals in mm).
    pub weight: Vector3<T>,
    /// Measured orientation of the tool frame (the flange axes times
    /// [`crate::Robot::tool_axes`]) in the measurement frame, for a 6-D observation; its
    /// origin is unused.
    pub orientation: Option<Frame<T>>,
    /// Weight of the orientation residual, per rad (mm per rad to compare with unweighted
    /// millimetres, or 1/σ for σ in rad).
    pub orientation_weight: T,
    /// The arm's temperature (°C, a data file's `temp_c`), for a model with a
    /// thermal-expansion term; `None`: at the term's reference temperature.
    pub temp_c: Option<T>,
    /// When it was taken (s, a data file's `t_s`), for a model with a base-drift term; `None`:
    /// at the term's reference time.
    pub time_s: Option<T>,
}

impl<T: Real, const N: usize> Default for Measurement<T, N> {
    fn default() -> Self {
        Self::new([T::zero(); N], Vector3::zeros())
    }
}

impl<T: Real, const N: usize> Measurement<T, N> {
    /// A position observation of the first tool point with unit weights.
    pub fn new(q: [T; N], point: Vector3<T>) -> Self {
        Self {
            q,
            point,
            tool: 0,
            weight: Vector3::repeat(T::one()),
            orientation: None,
            orientation_weight: T::zero(),
            temp_c: None,
            time_s: None,
        }
    }

    /// From file units: joint readings in degrees, point in millimetres.
    pub fn from_deg(q_deg: &[f64; N], xyz: &[f64; 3]) -> Self {
        Self::new(
            q_deg.map(|d| T::of(d.to_radians())),
            Vector3::new(T::of(xyz[0]), T::of(xyz[1]), T::of(xyz[2])),
        )
    }

    /// True when the position weights are all one (the plain, unweighted residual).
    #[inline(always)]
    pub fn unweighted(&self) -> bool {
        self.weight.iter().all(|w| *w == T::one())
    }

    /// True when every number is finite, the weights are not negative and the orientation
    /// (if any) is a rotation (and the temperature and time, if any, finite).
    pub fn is_finite(&self) -> bool {
        let w_ok = self.weight.iter().all(|w| w.finite() && *w >= T::zero());
        let o_ok = match &self.orientation {
            None => true,
            Some(f) => {
                f.is_rotation()
                    && self.orientation_weight.finite()
                    && self.orientation_weight >= T::zero()
            }
        };
        self.q.iter().all(|v| v.finite())
            && self.point.iter().all(|v| v.finite())
            && w_ok
            && o_ok
            && self.temp_c.is_none_or(|t| t.finite())
            && self.time_s.is_none_or(|t| t.finite())
    }

    /// The temperature and time the model is evaluated at for this observation
    /// ([`Observation::conditions`], without importing the trait).
    #[inline(always)]
    pub fn conditions(&self) -> crate::Conditions<T> {
        Observation::conditions(self)
    }
}

impl<T: Real, const N: usize> Observation<T, N> for Measurement<T, N> {
    #[inline(always)]
    fn q(&self) -> &[T; N] {
        &self.q
    }
    #[inline(always)]
    fn point(&self) -> Vector3<T> {
        self.point
    }
    #[inline(always)]
    fn tool(&self) -> usize {
        self.tool as usize
    }
    #[inline(always)]
    fn weight(&self) -> Option<Vector3<T>> {
        (!self.unweighted()).then_some(self.weight)
    }
    #[inline(always)]
    fn orientation(&self) -> Option<(&Frame<T>, T)> {
        self.orientation
            .as_ref()
            .map(|o| (o, self.orientation_weight))
    }
    #[inline(always)]
    fn temperature(&self) -> Option<T> {
        self.temp_c
    }
    #[inline(always)]
    fn time(&self) -> Option<T> {
        self.time_s
    }
    fn is_valid(&self) -> bool {
        self.is_finite()
    }
}
