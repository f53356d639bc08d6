//! Calibration without a tracker (issue 31; docs/formats.md, "Constraint measurements"):
//! sockets, planes, distances and tracker points in one file, fitted on the host with the
//! library's forward kinematics and identification Jacobian columns.
//!
//! - [`read`]: the file, its rules and units;
//! - [`shapes`]: socket centres and planes fitted to predicted tool points, row errors;
//! - [`system`]: the weighted residuals and Jacobian of a session;
//! - [`fit`]: identifiability and the Levenberg–Marquardt fit;
//! - [`identify`], [`validate`]: the commands on a constraint file;
//! - [`simulate`]: constraint sessions from a robot with known errors;
//! - [`report`]: their reports.

pub mod fit;
pub mod identify;
pub mod read;
pub mod report;
pub mod shapes;
pub mod simulate;
pub mod system;
pub mod validate;
