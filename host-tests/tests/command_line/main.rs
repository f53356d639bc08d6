//! The `kinecal` command line end to end: files, units, URDF, couplings, frames, reports,
//! atomic writes, exit statuses and hostile input.

#[path = "../common/mod.rs"]
mod common;

mod atomic_out;
mod cartesian;
mod cli_check_simulate;
mod cli_hardening;
mod couplings;
mod csv_hardening;
mod exit_status;
mod frames;
mod hardening_surfaces;
mod identify_start;
mod observations_cli;
mod report;
mod reports;
mod robot_file;
mod units;
mod urdf;
mod vendor_files;
