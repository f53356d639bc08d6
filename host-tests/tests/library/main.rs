//! The library against an independent f64 reference and known truth: kinematics, LM, PSO,
//! BPNN, snapshots, compensation, observations, the CSV reader, hardening and the C ABI.

#[path = "../common/mod.rs"]
mod common;
mod pso_sim;

mod bpnn;
mod c_abi;
mod compensate;
mod constraint_lm;
mod csv_parse;
mod fuzz_corpus;
mod hardening;
mod lm;
mod lm_pass;
mod lm_penalty;
mod lm_seed;
mod model_blob;
mod model_blob_records;
mod observations;
mod pso;
mod reference_fk;
mod snapshot;
