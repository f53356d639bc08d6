//! The discrepancy workflow (`diagnose`): simulated hidden effects, explanations, grids,
//! observation kinds and the real UR10 series.

#[path = "../common/mod.rs"]
mod common;

mod explain;
mod grids;
mod matrix;
mod observations;
mod ur10;
mod workflow;
