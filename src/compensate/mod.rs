//! Online compensation: the joint command that brings the *identified* robot to a target.
//!
//! The controller knows where it wants the tool (a point in the measurement frame, or a full
//! tool pose) and has a joint vector near the answer: its nominal inverse kinematics, or the
//! previous cycle's command. [`compensate`] runs a fixed, small number of damped Newton
//! (Levenberg–Marquardt) steps on the identified model from that seed. Because
//! [`ForwardKinematics::compute`] applies the joint corrections and the joint Jacobian (as
//! [`ForwardKinematics::joint_jacobian`] has it) carries their slope, compliance, cyclic, scale
//! and table effects are inverted along with the geometry.
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

mod config;
mod evaluate;
mod finite;
mod ldlt6;
mod newton;
mod outcome;
mod step;
mod target;
mod tracker;

pub use config::Config;
pub use newton::{compensate, compensate_from};
pub use outcome::{CompensateError, Solution, Status};
pub use target::{Target, FAR};
pub use tracker::Tracker;
