//! The `kinecal` subcommands, one module each.

pub mod check;
pub mod demo;
pub mod simulate;
pub mod identify;
pub mod diagnose;
pub mod frames;
pub mod compensate;
pub mod plan;
pub mod study;
