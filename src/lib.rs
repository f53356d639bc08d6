//! # kinecal: kinematic calibration of serial robot arms, on the controller and the desktop
//!
//! `#![no_std]`, no allocation, no panics on input reachable through the public API: bad input
//! gets a typed error and valid state stays valid. Every algorithm is generic over the scalar
//! (`f32` on a Cortex-M4F, `f64` on the desktop) and sized by const generics.
//!
//! ## Layers (bottom to top)
//!
//! - **Numbers**: [`Real`] (the scalar), [`trig`] (an `f32` `sin_cos` 30× cheaper than libm's
//!   on an M4F), [`linalg`] (Cholesky, rank-revealing Cholesky, Jacobi eigen on fixed storage).
//! - **Model** (constant description, like Pinocchio's `Model`): [`Frame`], [`Joint`] (modified
//!   DH + Hayati tilt), [`Robot`] (base pose, rows, tool point, [`Effects`] = the non-geometric
//!   joint corrections of interfaces.md §2, [`Couplings`] = joints read relative to another),
//!   [`param`] (named parameters, the identified subset,
//!   updates).
//! - **Kinematics** (scratch workspaces, like Pinocchio's `Data`): [`ForwardKinematics`] with its
//!   derivatives beside it (identification Jacobian, joint Jacobian).
//! - **Data**: [`Measurement`] and the streaming [`csv`] reader over `embedded_io::Read`.
//! - **Identification** (steppers: a bounded slice of work per `step()`, snapshots over
//!   `embedded_io` via [`snapshot`]): [`lm`] (streaming Levenberg–Marquardt with identifiability
//!   analysis; its storage in [`lm_storage`], chosen by the caller; its passes over the data
//!   spread over the caller's workers with [`lm_pass`]), [`fitness`] (the objective of the global searches), [`pso`], [`bpnn`] and
//!   [`bpnn_pso`] (Gao et al. 2018).
//! - **Compensation**: [`compensate`] (damped Newton on the identified model, typed safety errors,
//!   a trajectory tracker).
//! - **Frames from sweeps**: [`circle`] (3-D circle fit) and [`sweep_frames`] (joint axes, base
//!   frame, tool distances; the circle-point method).
//! - **Measurement planning** (Jost et al. 2017): [`information`] (information matrix, parameter
//!   and tool covariance), [`observability`] (O1–O5, A/D/E/KPI criteria), [`capsule`] and
//!   [`scene`] (collision, floor, beam and incidence checks), [`pose_pool`] (feasible candidate
//!   poses), [`planning`] (greedy + exchange selection), [`online_design`] (next best pose).
//!
//! Units: millimetres and radians inside the library; degrees only at file boundaries.

#![no_std]
#![forbid(unsafe_code)]
// Matrix kernels index rows and columns; iterator chains would hide the algebra.
#![allow(clippy::needless_range_loop)]
// `!(x > 0)` is deliberate throughout: a NaN must fail the test, not pass it.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![warn(missing_debug_implementations)]

pub mod bpnn;
pub mod bpnn_pso;
pub mod capsule;
pub mod circle;
pub mod compensate;
pub mod coupling;
pub mod csv;
pub mod effects;
pub mod fitness;
pub mod forward;
pub mod frame;
pub mod information;
pub mod linalg;
pub mod lm;
pub mod lm_pass;
pub mod lm_storage;
pub mod measurement;
pub mod observability;
pub mod online_design;
pub mod param;
pub mod planning;
pub mod pose_pool;
pub mod pso;
pub mod real;
pub mod robot;
pub mod scene;
pub mod snapshot;
pub mod sweep_frames;
pub mod trig;

pub use coupling::{CouplingError, Couplings};
pub use effects::{Effect, EffectKind, Effects};
pub use forward::ForwardKinematics;
pub use frame::Frame;
pub use measurement::Measurement;
pub use param::{Param, ParamSet};
pub use real::Real;
pub use robot::{Joint, Robot, RobotError};
