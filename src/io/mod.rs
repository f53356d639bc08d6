//! **Data in and out**: one measured pose, the streaming measurement CSV reader over
//! `embedded_io::Read`, the versioned, checksummed snapshots of the steppers, and the binary
//! model (`.kcm`) that firmware loads.

pub mod constraint;
pub mod csv;
mod decimal;
pub mod measurement;
pub mod model_blob;
pub mod snapshot;
