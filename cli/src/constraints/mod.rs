//! Calibration without a tracker (docs/formats.md, "Constraint measurements"):
//! sockets, planes, distances and tracker points in one file, fitted on the host with the
//! library's forward kinematics and identification Jacobian columns.
//!
//! - [`read`]: the file, its rules and units;
//! - [`bar_scale`]: an arm scaled as a whole by bar lengths off by one factor;
//! - [`bar_offset`]: bar lengths off by one constant, which the fit cannot meet;
//! - [`check`]: what a session holds and how far the nominal model is from it (`check`);
//! - [`shapes`]: socket centres and planes fitted to predicted tool points, row errors;
//! - [`system`]: the weighted residuals and Jacobian of a session;
//! - [`fit`]: identifiability and the Levenberg–Marquardt fit;
//! - [`outliers`]: rows far from their constraints, χ² of the stated σ;
//! - [`diagnose`]: the discrepancy search on cross-validated groups;
//! - [`diagnose_report`]: its report (`diagnose` on a constraint file);
//! - [`effects`]: `--effect` requests on a session (its joint ranges, its temperatures);
//! - [`simulate`]: constraint sessions from a robot with known errors (or measured at a plan);
//! - [`plan`]: which rows to measure (`plan --constraints`);
//! - [`residual_table`]: what `identify --residuals` writes for a constraint file;
//! - [`recalibration`]: whether the robot changed since a model's calibration (`validate`);
//! - [`report`]: the reports of `check`, `identify` and `validate` on a constraint file (which
//!   `commands::constraint_check`, `commands::constraint_identify` and
//!   `commands::constraint_validate` run).

pub mod bar_offset;
pub mod bar_scale;
pub mod check;
pub mod diagnose;
pub mod diagnose_report;
pub mod effects;
pub mod far_rows;
pub mod fit;
pub mod outliers;
pub mod plan;
pub mod read;
pub mod recalibration;
pub mod report;
pub mod residual_table;
pub mod shapes;
pub mod simulate;
pub mod system;
