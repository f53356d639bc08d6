//! The application functions above the reports: each takes what was read (a robot file,
//! measurement sets in mm and degrees, plain options) and returns its typed result and report;
//! the command modules read the files, call them and write what they return, and the Python
//! package calls them on arrays.
//!
//! - [`identify`]: `kinecal identify` on tracker observations.
//! - [`constraints`]: `kinecal identify` on constraint observations (sockets, planes,
//!   distances).
//! - [`constraint_diagnose`]: `kinecal diagnose` on constraint observations.
//! - [`export`]: `kinecal export`'s checks and outputs (URDF, DH table, firmware model).
//! - [`leaving_out`]: what an export that cannot hold a model's effects and couplings gives up.
//! - [`study`]: `kinecal study`, the measurement-planning study over a grid of arms.
//! - [`demo`]: `kinecal demo`, the BPNN-PSO paper's simulation and its four methods.
//! - [`simulate`]: `kinecal simulate`, the true robot and a session measured on it.
//! - [`report`]: `kinecal report`, the calibration report of an identified model.

pub mod constraint_diagnose;
pub mod constraint_report;
pub mod constraints;
pub mod demo;
pub mod export;
pub mod identify;
pub mod leaving_out;
pub mod report;
pub mod simulate;
pub mod study;
