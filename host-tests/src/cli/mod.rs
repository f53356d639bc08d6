//! The `kinecal` subcommands, one module each.

pub mod check;
pub mod compensate;
pub mod demo;
pub mod diagnose;
pub mod frames;
pub mod identify;
pub mod plan;
pub mod simulate;
pub mod study;
