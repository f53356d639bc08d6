//! Measurement design (`plan`): geometry, information, f32, Monte Carlo and the study.

#[path = "../common/mod.rs"]
mod common;

mod command;
mod f32;
mod geometry;
mod information;
mod montecarlo;
mod study;
