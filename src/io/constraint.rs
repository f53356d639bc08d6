//! Measurements without a tracker (docs/formats.md, "Constraint measurements"): rows of joint
//! readings tied into groups by what an artefact says about their tool points.
//!
//! - a **socket** group: the tool point was at one fixed, unknown point in every row;
//! - a **plane** group: the tool point lay on one unknown plane in every row;
//! - a **distance** group: two rows whose tool points were `length_mm` apart (a scale bar,
//!   a ball bar);
//! - a **point** group: one row whose tool point a tracker saw at `at`.
//!
//! The rows live in one caller-owned slice, each group naming its run of rows, so a group of
//! any length costs no storage of its own (firmware keeps both slices in static arrays).
//! [`crate::identify::lm::Levenberg::step_constraints`] calibrates from them.

use crate::Real;
use nalgebra::Vector3;

/// One row of a constraint session: joint readings, the tool point that touched, and the
/// uncertainty of the contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstraintRow<T: Real, const N: usize> {
    /// Joint readings, rad (as the controller reports them, before couplings).
    pub q: [T; N],
    /// Which of the robot's tool points touched (0: [`crate::Robot::tool`]).
    pub tool: u8,
    /// Standard uncertainty of the contact, mm (> 0): the row's residuals are divided by it.
    pub sigma_mm: T,
    /// The arm's temperature (°C), for a model with a thermal-expansion term.
    pub temp_c: Option<T>,
}

impl<T: Real, const N: usize> ConstraintRow<T, N> {
    /// A row of the first tool point with uncertainty `sigma_mm`.
    pub fn new(q: [T; N], sigma_mm: T) -> Self {
        Self {
            q,
            tool: 0,
            sigma_mm,
            temp_c: None,
        }
    }

    /// True when every number is finite and σ is above zero.
    pub fn is_valid(&self) -> bool {
        self.q.iter().all(|v| v.finite())
            && self.sigma_mm.finite()
            && self.sigma_mm > T::zero()
            && self.temp_c.is_none_or(|t| t.finite())
    }
}

/// What a group's rows have in common.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConstraintKind<T: Real> {
    /// One unknown point (at least 2 rows; 3 unknowns).
    Socket,
    /// One unknown plane (at least 4 rows; 3 unknowns).
    Plane,
    /// Two rows whose tool points are `length_mm` apart (exactly 2 rows; σ of the distance is
    /// the first row's).
    Distance {
        /// The artefact's length, mm.
        length_mm: T,
    },
    /// One row whose tool point a tracker saw at `at` (mm, measurement frame).
    Point {
        /// Where the tracker saw the tool point, mm.
        at: Vector3<T>,
    },
}

/// A group: its kind and its run `first..first + len` of the session's rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstraintGroup<T: Real> {
    /// What the rows have in common.
    pub kind: ConstraintKind<T>,
    /// The group's first row in the session's rows.
    pub first: u32,
    /// How many rows the group has.
    pub len: u32,
}

impl<T: Real> ConstraintGroup<T> {
    /// The group's rows of `rows`, when they exist.
    pub fn rows<'r, const N: usize>(
        &self,
        rows: &'r [ConstraintRow<T, N>],
    ) -> Option<&'r [ConstraintRow<T, N>]> {
        let first = self.first as usize;
        rows.get(first..first.checked_add(self.len as usize)?)
    }

    /// True when the group's size suits its kind and its numbers are finite.
    pub fn is_valid(&self) -> bool {
        match self.kind {
            ConstraintKind::Socket => self.len >= 2,
            ConstraintKind::Plane => self.len >= 4,
            ConstraintKind::Distance { length_mm } => {
                self.len == 2 && length_mm.finite() && length_mm > T::zero()
            }
            ConstraintKind::Point { at } => self.len == 1 && at.iter().all(|v| v.finite()),
        }
    }

    /// Weighted residual rows the group contributes.
    pub fn residual_rows(&self) -> usize {
        let len = self.len as usize;
        match self.kind {
            ConstraintKind::Socket | ConstraintKind::Point { .. } => 3 * len,
            ConstraintKind::Plane => len,
            ConstraintKind::Distance { .. } => 1,
        }
    }

    /// Unknowns of the group's own (a socket's centre, a plane's normal and offset).
    pub fn unknowns(&self) -> usize {
        match self.kind {
            ConstraintKind::Socket | ConstraintKind::Plane => 3,
            ConstraintKind::Distance { .. } | ConstraintKind::Point { .. } => 0,
        }
    }
}
