//! **Data in and out**: one measured pose, the streaming measurement CSV reader over
//! `embedded_io::Read`, and the versioned, checksummed snapshots of the steppers.

pub mod csv;
mod decimal;
pub mod measurement;
pub mod snapshot;
