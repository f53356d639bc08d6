//! Calibrations that hold: judged on poses and sessions they never saw (acceptance on held-out
//! poses, the prior, parameter groups, splits and residuals), one test binary.

#[path = "../common/mod.rs"]
mod common;

mod acceptance;
mod extrapolation;
mod quick_recalibration;
mod ur10;
mod validate;
mod validate_sessions;
