//! # kinecal: kinematic calibration of serial robot arms, on the controller and the desktop
//!
//! `#![no_std]`, no allocation, no panics on input reachable through the public API: bad input
//! gets a typed error and valid state stays valid. Every algorithm is generic over the scalar
//! (`f32` on a Cortex-M4F, `f64` on the desktop) and sized by const generics.
//!
//! ## Layers (bottom to top), one folder each
//!
//! - [`num`] — **numbers**: [`Real`] (the scalar), [`num::trig`] (an `f32` `sin_cos` 30× cheaper
//!   than libm's on an M4F), [`num::linalg`] (Cholesky, rank-revealing Cholesky, Jacobi eigen on
//!   fixed storage).
//! - [`model`] — **the constant description** (Pinocchio's `Model`): [`Frame`], [`Joint`] (modified
//!   DH + Hayati tilt), [`Robot`] (base pose, rows, tool points and the measured frame's orientation
//!   ([`model::tool`]), [`Effects`] = the non-geometric
//!   joint corrections of `docs/formats.md#effects`, [`Couplings`] = joints read relative to
//!   another),
//!   [`model::param`] (named parameters, the identified subset, updates).
//! - [`forward`] — **kinematics** (the scratch workspace, Pinocchio's `Data`): [`ForwardKinematics`]
//!   with its derivatives beside it (identification Jacobian, joint Jacobian).
//! - [`io`] — **data**: [`Measurement`] (a point, its weights, optionally the tool frame's
//!   orientation and which reflector; the [`Observation`] trait lets a caller keep a smaller
//!   type), the streaming [`io::csv`] reader over
//!   `embedded_io::Read`, and [`io::snapshot`] (stepper state over `embedded_io`).
//! - [`identify`] — **identification** (steppers: a bounded slice of work per `step()`,
//!   snapshot/resume): [`identify::lm`] (streaming Levenberg–Marquardt with identifiability
//!   analysis; its storage chosen by the caller, its passes over the data spread over the
//!   caller's workers, all under this one path), [`identify::fitness`] (the
//!   objective of the global searches), [`identify::pso`], [`identify::bpnn`] and
//!   [`identify::bpnn_pso`] (Gao et al. 2018).
//! - [`compensate`] — **compensation**: damped Newton on the identified model, typed safety errors,
//!   a trajectory tracker.
//! - [`frames`] — **frames from sweeps**: [`frames::circle`] (3-D circle fit) and
//!   [`frames::circle_point`] (joint axes, base frame, tool distances; the circle-point method).
//! - [`planning`] — **measurement planning** (Jost et al. 2017): [`planning::information`]
//!   (information matrix, parameter and tool covariance), [`planning::observability`] (O1–O5,
//!   A/D/E/KPI criteria), [`planning::capsule`] and [`planning::cell`] (collision, floor, beam and
//!   incidence checks), [`planning::pose_pool`] (feasible candidate poses),
//!   [`planning::selection`] (greedy + exchange selection), [`planning::online_design`] (next best
//!   pose).
//!
//! Each layer uses only the layers listed before it (`scripts/module_graph.py` checks this).
//!
//! Units: millimetres and radians inside the library; degrees only at file boundaries.
//!
//! File formats, the command line and a walkthrough on real UR10 data are in the repository's
//! `docs/` folder (`docs/README.md`; `docs/formats.md`, `docs/walkthrough.md`,
//! `docs/architecture.md`).

#![no_std]
#![forbid(unsafe_code)]
// Matrix kernels index rows and columns; iterator chains would hide the algebra.
#![allow(clippy::needless_range_loop)]
// `!(x > 0)` is deliberate throughout: a NaN must fail the test, not pass it.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![warn(missing_debug_implementations)]
#![warn(missing_docs)]

pub mod compensate;
pub mod forward;
pub mod frames;
pub mod identify;
pub mod io;
pub mod model;
pub mod num;
pub mod planning;

pub use forward::{Conditions, ForwardKinematics};
pub use io::measurement::{Measurement, Observation};
pub use model::coupling::{CouplingError, Couplings};
pub use model::effects::{Effect, EffectKind, Effects};
pub use model::frame::Frame;
pub use model::param::{Param, ParamSet};
pub use model::robot::{Joint, Robot, RobotError};
pub use model::value_storage::{Inline, ValueBuffer, ValueStorage};
pub use num::real::Real;
