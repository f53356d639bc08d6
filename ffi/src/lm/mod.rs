//! Identification: the Levenberg–Marquardt stepper (`kc_lm`: `Levenberg<f32, 6 or 7, Inline<0>,
//! FixedLm<f32, 24>>`), its snapshots, and the RMS error of a model over measurements.

// In the header's order (one group each: rustfmt sorts `mod` items within a group).
mod measurement;

mod config;

mod progress;

mod solver;

mod stepping;

mod snapshot;

mod abi;

// The feature `lm-full`'s: its `#![cfg]` is inside, so that the header keeps one condition per item.
mod full;

mod rms;

pub use abi::*;
pub use config::*;
#[cfg(feature = "lm-full")]
pub use full::*;
pub use measurement::*;
pub use progress::*;
pub use rms::*;
pub use solver::*;
