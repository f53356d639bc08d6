//! The discrepancy workflow (`diagnose`): simulated hidden effects, explanations, grids,
//! observation kinds, the evidence a finding needs (thermal expansion, plausibility) and the real
//! UR10 series.

#[path = "../common/mod.rs"]
mod common;

mod drift;
mod evidence;
mod explain;
mod grids;
mod matrix;
mod observations;
mod orientation;
mod refusals;
mod row_step;
mod ur10;
mod workflow;
