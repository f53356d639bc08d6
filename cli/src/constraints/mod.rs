//! Calibration without a tracker (issue 31; docs/formats.md, "Constraint measurements"):
//! sockets, planes, distances and tracker points in one file, fitted on the host with the
//! library's forward kinematics and identification Jacobian columns.
//!
//! - [`read`]: the file, its rules and units;
//! - [`shapes`]: socket centres and planes fitted to predicted tool points, row errors;
//! - [`system`]: the weighted residuals and Jacobian of a session;
//! - [`fit`]: identifiability and the Levenberg–Marquardt fit;
//! - [`simulate`]: constraint sessions from a robot with known errors;
//! - [`report`]: the reports of `identify` and `validate` on a constraint file (which
//!   `commands::constraint_identify` and `commands::constraint_validate` run).

pub mod fit;
pub mod read;
pub mod report;
pub mod shapes;
pub mod simulate;
pub mod system;
