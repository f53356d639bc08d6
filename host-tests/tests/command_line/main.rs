//! The `kinecal` command line end to end: files, units, URDF, couplings, frames, reports,
//! atomic writes, exit statuses and hostile input.

#[path = "../common/mod.rs"]
mod common;

mod arm_size;
mod atomic_out;
mod cartesian;
mod cli_check_simulate;
mod cli_hardening;
mod constraint_reference;
mod constraints;
mod couplings;
mod csv_hardening;
mod dated_times;
mod documented_examples;
mod drifting_tracker;
mod effect_requests;
mod exit_status;
mod frames;
mod hardening_surfaces;
mod host_values;
mod identify_start;
mod internals;
mod map_everywhere;
mod mirrored_data;
mod named_reflectors;
mod observations_cli;
mod one_reflector;
mod outliers;
mod report;
mod report_verdicts;
mod reports;
mod robot_file;
mod rounded_points;
mod stale_readings;
mod suspicious_readings;
mod thermal_tracker;
mod thin_data;
mod units;
mod unknown_tool;
mod ur10_distances;
mod ur10_series;
mod urdf;
mod urdf_tracker_frame;
mod vendor_files;
