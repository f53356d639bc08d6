//! The magnitudes a robot model accepts: what no robot can have is refused at construction
//! ([`crate::RobotError::OutOfRange`]), so every accepted model evaluates to finite numbers.
//! Couplings ([`crate::model::coupling::MAX_RATIO`]) and base rotations
//! ([`crate::model::frame::ROTATION_TOLERANCE`]) keep their bounds beside them.

/// Largest magnitude of a length a robot model accepts (mm): 1 km. Applies to the rows' `a` and
/// `d`, the tool point and the base origin (each coordinate).
pub const MAX_LENGTH: f64 = 1e6;

/// Largest magnitude of an angle a robot model accepts (rad): about 1,600 turns, where the `f32`
/// joint trigonometry is still exact in its range reduction. Applies to `alpha`, `theta`,
/// `beta` and the joint limits, to effect values and table knots
/// ([`crate::Effects::push`]); forward kinematics clamps finite readings beyond it.
pub const MAX_ANGLE: f64 = 1e4;
