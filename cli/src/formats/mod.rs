//! The files users bring and get, each with its schema and unit checks: the robot description
//! (TOML), measurements (CSV), the measurement cell of `plan` (TOML) and the units at the door.

pub mod cell_file;
pub mod dh_table;
pub mod measurements;
pub mod observations;
pub mod prior;
pub mod robot_file;
pub mod units;
pub mod urdf;
