//! **Model**: the constant robot description (Pinocchio's `Model`): frames, MDH rows with tilt,
//! the non-geometric joint corrections, joint couplings and the named parameters identification
//! changes. Per-evaluation scratch lives in [`crate::forward`].
//!
//! A robot is built from its modified DH rows (`alpha`, `a`, `theta`, `d`: degrees and millimetres
//! in [`Joint::mdh_deg`](robot::Joint::mdh_deg), radians inside), its base pose in the measurement
//! frame and the measured point in the flange frame. Non-finite numbers are refused, never stored:
//!
//! ```
//! use kinecal::{Frame, Joint, Robot, RobotError};
//! use nalgebra::Vector3;
//!
//! // A 3-joint arm: a vertical first axis, then two parallel horizontal ones.
//! let rows = [
//!     Joint::mdh_deg(0.0, 0.0, 0.0, 400.0),  // alpha_deg, a_mm, theta_deg, d_mm
//!     Joint::mdh_deg(90.0, 100.0, 0.0, 0.0),
//!     Joint::mdh_deg(0.0, 500.0, 0.0, 0.0),
//! ];
//! let tool = Vector3::new(300.0, 0.0, 0.0); // mm, flange frame
//! let robot: Robot<f64, 3> = Robot::new(Frame::identity(), rows, tool).unwrap();
//! assert_eq!(robot.joints()[1].alpha, 90f64.to_radians());
//! assert_eq!(robot.joints()[1].lower, -core::f64::consts::PI); // mdh rows: ±180° limits
//! // Reach: Σ(|a| + |d|) + |tool|, the length scale of angle parameters.
//! assert_eq!(robot.reach(), 400.0 + 100.0 + 500.0 + 300.0);
//!
//! // A joint read relative to another (FANUC J3 from the horizontal): q3 = r3 + 1.0 · r2.
//! let mut fanuc = robot.clone();
//! fanuc.set_coupling(2, 1, 1.0).unwrap();
//! assert_eq!(fanuc.couplings().get(2), Some((1, 1.0)));
//!
//! // A NaN row is refused.
//! let bad = [rows[0], rows[1], Joint::mdh_deg(0.0, f64::NAN, 0.0, 0.0)];
//! assert_eq!(
//!     Robot::<f64, 3>::new(Frame::identity(), bad, tool).unwrap_err(),
//!     RobotError::NotFinite
//! );
//! ```

pub mod bounds;
pub mod coupling;
pub mod effects;
pub mod frame;
pub mod param;
pub mod robot;
pub mod tool;
pub mod value_storage;
