//! Where the tool should go: a point or a full pose in the measurement frame.

use super::finite::all_finite;
use crate::{Frame, Real};
use nalgebra::Vector3;

/// Targets farther than this many reaches ([`Robot::reach`](crate::Robot::reach)) from the base are
/// refused as invalid input rather than iterated on.
pub const FAR: f64 = 1000.0;

/// Where the tool should go, in the measurement frame (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target<T: Real> {
    /// Only the measured point (3 equations): any robot.
    Point(Vector3<T>),
    /// Point (the frame's origin) and tool orientation (the flange axes, as in
    /// [`ForwardKinematics::tool_pose`](crate::ForwardKinematics::tool_pose)): 6 equations, robots
    /// with six or more joints.
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
