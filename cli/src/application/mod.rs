//! The application functions above the reports: each takes what was read (a robot file,
//! measurement sets in mm and degrees, plain options) and returns its typed result and report;
//! the command modules read the files, call them and write what they return, and the Python
//! package calls them on arrays.
//!
//! - [`identify`]: `kinecal identify` on tracker observations.

pub mod identify;
