//! Joint couplings (`[[couplings]]`, `docs/formats.md#couplings`): a joint whose controller
//! reading is measured relative to another joint.
//!
//! FANUC arms (and most palletisers) report J3 from the horizontal, so the model angle of the
//! MDH chain is `q3 = reading3 + ratio · reading2` with `ratio = 1`. A [`Couplings`] value holds
//! at most one `(from, ratio)` per joint and maps the controller's readings to the model's
//! angles, back, and carries derivatives from model angles to readings (the chain rule).
//!
//! Chains are refused (a coupled joint cannot be the `from` of another, nor be coupled twice),
//! so every `from` joint's model angle equals its reading and the inverse is one subtraction.
//!
//! Order of operations in [`crate::ForwardKinematics::compute`]: readings `r` → the joint
//! corrections of [`crate::Effects`] act on the readings (the motor side), `r' = r + dq(r)` →
//! couplings map `r'` to model angles → geometry. Joint limits stay on the readings.

use crate::Real;
use core::ops::{AddAssign, Mul};

/// How many couplings one robot can carry (real arms have one to three: J3 from J2, a
/// differential wrist); the storage does not grow with the number of joints.
pub const MAX_COUPLINGS: usize = 4;

/// Largest magnitude of a coupling ratio (rad per rad): real couplings are about 1 (FANUC J3,
/// differential wrists); the bound keeps model angles finite in `f32`.
pub const MAX_RATIO: f64 = 1e3;

/// Why a coupling was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CouplingError {
    /// `joint == from`.
    SameJoint,
    /// `joint` or `from` is not a joint of the robot.
    OutOfRange,
    /// The ratio is NaN, infinite, or beyond ±[`MAX_RATIO`].
    NotFinite,
    /// The joint is already coupled.
    Twice,
    /// A chain: `from` is itself coupled, or `joint` is already the `from` of another coupling.
    Chain,
    /// More than [`MAX_COUPLINGS`] couplings.
    Capacity,
}

/// The couplings of an `N`-joint robot: per joint at most one `(from, ratio)` with
/// `model_joint = reading_joint + ratio · reading_from` (0-based joints, ratio in rad per rad).
///
/// Stored as a short list (at most [`MAX_COUPLINGS`]) sorted by joint: the loops run over the
/// couplings, not over every joint, which keeps code and instruction counts small on a
/// microcontroller, and the size does not depend on `N`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Couplings<T: Real, const N: usize> {
    joint: [u8; MAX_COUPLINGS],
    from: [u8; MAX_COUPLINGS],
    ratio: [T; MAX_COUPLINGS],
    count: u8,
}

impl<T: Real, const N: usize> Default for Couplings<T, N> {
    fn default() -> Self {
        Self {
            joint: [0; MAX_COUPLINGS],
            from: [0; MAX_COUPLINGS],
            ratio: [T::zero(); MAX_COUPLINGS],
            count: 0,
        }
    }
}

impl<T: Real, const N: usize> Couplings<T, N> {
    /// No couplings: readings are model angles.
    pub fn new() -> Self {
        Self::default()
    }

    /// True when no joint is coupled (the forward kinematics then skips all of this).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Number of coupled joints.
    #[inline(always)]
    pub fn len(&self) -> usize {
        (self.count as usize).min(MAX_COUPLINGS)
    }

    /// Coupling number `i` (in joint order) as `(joint, from, ratio)`, both joints `< N`.
    /// (Plain index loops, not iterator chains: they stay small and fast on a Cortex-M4F.)
    #[inline(always)]
    pub(crate) fn entry(&self, i: usize) -> Option<(usize, usize, T)> {
        if i >= self.len() {
            return None;
        }
        let (j, f) = (self.joint[i] as usize, self.from[i] as usize);
        (j < N && f < N).then_some((j, f, self.ratio[i]))
    }

    /// Every coupling as `(joint, from, ratio)`, in joint order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, usize, T)> + '_ {
        (0..self.len()).filter_map(move |i| self.entry(i))
    }

    /// The coupling of `joint` (0-based): `(from, ratio)`.
    pub fn get(&self, joint: usize) -> Option<(usize, T)> {
        for i in 0..self.len() {
            if let Some((j, f, r)) = self.entry(i) {
                if j == joint {
                    return Some((f, r));
                }
            }
        }
        None
    }

    /// The joints coupled from `from`, with their ratios: `(joint, ratio)`.
    pub fn dependents(&self, from: usize) -> impl Iterator<Item = (usize, T)> + '_ {
        self.iter()
            .filter(move |(_, f, _)| *f == from)
            .map(|(j, _, r)| (j, r))
    }

    /// Couples `joint` to `from` (0-based): `model_joint = reading_joint + ratio · reading_from`.
    /// On error nothing changes.
    pub fn add(&mut self, joint: usize, from: usize, ratio: T) -> Result<(), CouplingError> {
        let n = self.len();
        if joint >= N || from >= N || N > u8::MAX as usize {
            return Err(CouplingError::OutOfRange);
        }
        if joint == from {
            return Err(CouplingError::SameJoint);
        }
        // `!(|r| <= bound)`: NaN fails too.
        if !(ratio.abs() <= T::of(MAX_RATIO)) {
            return Err(CouplingError::NotFinite);
        }
        // One pass: `joint` coupled already, or a chain either way.
        let mut chain = false;
        for i in 0..n {
            if let Some((j, f, _)) = self.entry(i) {
                if j == joint {
                    return Err(CouplingError::Twice);
                }
                chain |= j == from || f == joint;
            }
        }
        if chain {
            return Err(CouplingError::Chain);
        }
        if n >= MAX_COUPLINGS {
            return Err(CouplingError::Capacity);
        }
        // Insert in joint order.
        let mut at = n;
        while at > 0 && self.joint[at - 1] as usize > joint {
            self.joint[at] = self.joint[at - 1];
            self.from[at] = self.from[at - 1];
            self.ratio[at] = self.ratio[at - 1];
            at -= 1;
        }
        self.joint[at] = joint as u8;
        self.from[at] = from as u8;
        self.ratio[at] = ratio;
        self.count += 1;
        Ok(())
    }

    /// Removes the coupling of `joint`, if any.
    pub fn remove(&mut self, joint: usize) {
        let n = self.len();
        let Some(mut at) = (0..n).find(|i| self.joint[*i] as usize == joint) else {
            return;
        };
        while at + 1 < n {
            self.joint[at] = self.joint[at + 1];
            self.from[at] = self.from[at + 1];
            self.ratio[at] = self.ratio[at + 1];
            at += 1;
        }
        // Unused entries stay zero, so equal couplings compare equal.
        self.joint[at] = 0;
        self.from[at] = 0;
        self.ratio[at] = T::zero();
        self.count -= 1;
    }

    /// Removes every coupling.
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Model angles of readings `r`: `q_j = r_j + ratio_j · r_from(j)`.
    #[inline]
    pub fn to_model(&self, r: &[T; N]) -> [T; N] {
        let mut q = *r;
        for i in 0..self.len() {
            if let Some((j, f, ratio)) = self.entry(i) {
                q[j] += ratio * r[f];
            }
        }
        q
    }

    /// Readings of model angles `q` (the inverse of [`Couplings::to_model`]; exact up to one
    /// rounding, since every `from` joint's reading is its model angle).
    pub fn to_readings(&self, q: &[T; N]) -> [T; N] {
        let mut r = *q;
        for i in 0..self.len() {
            if let Some((j, f, ratio)) = self.entry(i) {
                r[j] -= ratio * q[f];
            }
        }
        r
    }

    /// Turns derivatives with respect to model angles (`cols[k] = ∂y/∂q_k`) into derivatives
    /// with respect to readings, in place: `∂y/∂r_j = ∂y/∂q_j + Σ_{k coupled from j} ratio_k ·
    /// ∂y/∂q_k`. (In place is exact: a coupled joint's column is never changed, and only
    /// `from` joints' columns are.)
    pub fn reading_columns<C>(&self, cols: &mut [C; N])
    where
        C: Copy + AddAssign + Mul<T, Output = C>,
    {
        for i in 0..self.len() {
            if let Some((k, f, ratio)) = self.entry(i) {
                let c = cols[k] * ratio;
                cols[f] += c;
            }
        }
    }

    /// The same couplings in another scalar type; [`CouplingError::NotFinite`] when a ratio
    /// is not finite in `U` or beyond ±[`MAX_RATIO`] there.
    pub fn cast<U: Real>(&self) -> Result<Couplings<U, N>, CouplingError> {
        let ratio = self.ratio.map(|r| U::of(r.to_f64()));
        if ratio.iter().any(|r| !(r.abs() <= U::of(MAX_RATIO))) {
            return Err(CouplingError::NotFinite);
        }
        Ok(Couplings {
            joint: self.joint,
            from: self.from,
            ratio,
            count: self.count,
        })
    }
}
