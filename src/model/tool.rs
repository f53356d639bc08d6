//! The tool beyond its first point: further measured points (several reflectors on one tool,
//! each seen or not in a pose) and the orientation of the measured frame (what a 6-DoF probe
//! reports besides its position).
//!
//! The first point stays in [`Robot::tool`](crate::Robot::tool), where the forward kinematics of
//! every robot reads it; a robot measured at one point with positions only never touches this.

use crate::model::bounds::MAX_LENGTH;
use crate::{Frame, Real};
use nalgebra::Vector3;

/// Most measured points one tool carries (reflectors in one nest), the first included.
pub const MAX_TOOL_POINTS: usize = 4;

/// Tool points after the first, and the measured frame's orientation in the flange frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ToolExtra<T: Real> {
    /// Points `1 .. count` (flange frame, mm); the rest unused (zero).
    pub more: [Vector3<T>; MAX_TOOL_POINTS - 1],
    /// Number of points, the first included (1 ..= [`MAX_TOOL_POINTS`]).
    pub count: u8,
    /// Orientation of the measured frame in the flange frame (origin unused, zero).
    pub axes: Frame<T>,
    /// `axes` is the identity (cached: the usual case skips the rotation).
    pub identity: bool,
}

impl<T: Real> Default for ToolExtra<T> {
    fn default() -> Self {
        Self {
            more: [Vector3::zeros(); MAX_TOOL_POINTS - 1],
            count: 1,
            axes: Frame::identity(),
            identity: true,
        }
    }
}

impl<T: Real> ToolExtra<T> {
    /// `Ok` when every point is finite and within ±[`MAX_LENGTH`] and the axes are a rotation.
    pub fn is_valid(&self) -> bool {
        let bound = T::of(MAX_LENGTH);
        let points_ok = self.more[..(self.count as usize).saturating_sub(1)]
            .iter()
            .all(|p| p.iter().all(|c| c.finite() && c.abs() <= bound));
        let count_ok = (1..=MAX_TOOL_POINTS).contains(&(self.count as usize));
        points_ok && count_ok && self.axes.is_rotation() && self.axes.o == Vector3::zeros()
    }

    /// The same in another scalar type (unchecked: the caller checks the robot).
    pub fn cast<U: Real>(&self) -> ToolExtra<U> {
        let c = |v: &Vector3<T>| {
            Vector3::new(
                U::of(v.x.to_f64()),
                U::of(v.y.to_f64()),
                U::of(v.z.to_f64()),
            )
        };
        ToolExtra {
            more: self.more.map(|p| c(&p)),
            count: self.count,
            axes: self.axes.cast_unchecked(),
            identity: self.identity,
        }
    }
}
