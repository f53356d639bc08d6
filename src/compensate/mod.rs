//! Online compensation: the joint command that brings the *identified* robot to a target.
//!
//! The controller knows where it wants the tool (a point in the measurement frame, or a full tool
//! pose) and has a joint vector near the answer: its nominal inverse kinematics, or the previous
//! cycle's command. [`compensate`] runs a fixed, small number of damped Newton
//! (Levenberg–Marquardt) steps on the identified model from that seed. Because
//! [`ForwardKinematics::compute`](crate::ForwardKinematics::compute) applies the joint corrections
//! and the joint Jacobian (as
//! [`ForwardKinematics::joint_jacobian`](crate::ForwardKinematics::joint_jacobian) has it) carries
//! their slope, compliance, cyclic, scale and table effects are inverted along with the geometry.
//!
//! Seeds, commands and joint limits are the controller's own *readings*: with joint couplings
//! (FANUC J3 read from the horizontal, [`crate::Couplings`]) the forward kinematics maps them
//! to model angles and the joint Jacobian is taken with respect to the readings (chain rule),
//! so the Newton steps, the step box and the limits all live in the controller's coordinates.
//!
//! Safety, in the order a servo loop needs it:
//! - every command stays in the box `|q − seed| ≤ max_step` ∩ joint limits, so the answer is
//!   never a jump, whatever the target;
//! - non-finite inputs are refused before anything is computed ([`CompensateError::InvalidInput`]);
//! - a singular, limited or unreachable target returns a typed error that still carries the best
//!   command found inside the box, so the controller can hold or creep instead of stopping dead.
//!
//! Cost per call: at most `iterations + 1` forward kinematics (with their joint Jacobians, read
//! off the same pass) plus one or two ≤ 6×6 LDLᵀ solves per step and one for the conditioning,
//! in straight-line code, no allocation; once the residual reaches the scalar type's rounding
//! level one more step is taken and the iteration stops, so `f32` does not spend its budget
//! wandering in the noise. [`Tracker`] is the streaming form for trajectories: it keeps the
//! previous correction and starts the next cycle from it (usually one or two steps then
//! suffice).
//!
//! ```
//! use kinecal::compensate::{compensate, Config, Status, Target};
//! use kinecal::forward::point;
//! use kinecal::{Frame, Joint, Robot};
//! use nalgebra::Vector3;
//!
//! let rows = [
//!     Joint::mdh_deg(0.0, 0.0, 0.0, 400.0),
//!     Joint::mdh_deg(90.0, 100.0, 0.0, 0.0),
//!     Joint::mdh_deg(0.0, 500.0, 0.0, 0.0),
//! ];
//! // The identified model: joint 2 is 0.3° off its nominal zero.
//! let mut rows_real = rows;
//! rows_real[1].theta += 0.3f64.to_radians();
//! let tool = Vector3::new(300.0, 0.0, 0.0);
//! let identified: Robot<f64, 3> = Robot::new(Frame::identity(), rows_real, tool).unwrap();
//! let nominal: Robot<f64, 3> = Robot::new(Frame::identity(), rows, tool).unwrap();
//!
//! // The controller's command for a target, by its nominal model (its own IK, say).
//! let q_nominal = [0.2, 0.6, -0.9];
//! let target = Target::Point(point(&nominal, &q_nominal));
//! // Sent as is, the identified robot misses the target by about 4 mm.
//! assert!((point(&identified, &q_nominal) - target.point()).norm() > 2.0);
//!
//! // The corrected command, seeded with the nominal one.
//! let r = compensate(&identified, &target, &q_nominal, &Config::default());
//! assert_eq!(Status::of(&r), Status::Ok);
//! let sol = r.unwrap();
//! assert!(sol.position_error < 1e-3); // mm
//! assert!((point(&identified, &sol.q) - target.point()).norm() < 1e-3);
//! // Here the correction is the offset itself: joint 2 turns 0.3° less.
//! assert!((sol.q[1] - (q_nominal[1] - 0.3f64.to_radians())).abs() < 1e-6);
//! ```

/// `$body` for `$j` = 0, …, 5: the firmware's unroll threshold keeps LLVM from unrolling an
/// outer loop whose inner loops' bounds depend on it; written out, every bound is a constant
/// and every index of the packed triangle one.
macro_rules! for_0_to_5 {
    ($j:ident => $body:block) => {{
        let $j: usize = 0;
        $body
        let $j: usize = 1;
        $body
        let $j: usize = 2;
        $body
        let $j: usize = 3;
        $body
        let $j: usize = 4;
        $body
        let $j: usize = 5;
        $body
    }};
}

mod cartesian;
mod config;
mod evaluate;
mod finite;
mod ldlt6;
mod newton;
mod outcome;
mod step;
mod target;
mod tracker;

pub use cartesian::{nominal_reach, nominal_target};
pub use config::{Config, MAX_TEMP_C, MIN_TEMP_C};
pub use newton::{compensate, compensate_from};
pub use outcome::{CompensateError, Solution, Status};
pub use target::{Target, FAR};
pub use tracker::Tracker;
