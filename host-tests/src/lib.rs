//! Host-side companion of the `kinecal` library: file formats (TOML robots, CSV measurements),
//! an independent `f64` reference implementation for cross-checks, and the `kinecal` command line.

pub mod candidates;
pub mod cli;
pub mod cross_validation;
pub mod data;
pub mod diagnose;
pub mod global;
pub mod identify;
pub mod penalised_fit;
pub mod plots;
pub mod reference;
pub mod registration;
pub mod residual_plots;
pub mod robot_file;
pub mod scene;
pub mod significance;
pub mod sim;
pub mod study_figure;
pub mod sweeps;

/// Effect-value capacity of host-side models: room for per-joint tables on every joint.
pub const VCAP: usize = 2048;

/// Runs `$body` with a const `N` equal to the runtime joint count `$n` (2..=8 supported),
/// or evaluates to an error for other counts.
#[macro_export]
macro_rules! with_joints {
    ($n:expr, $N:ident => $body:expr) => {
        match $n {
            2 => {
                const $N: usize = 2;
                $body
            }
            3 => {
                const $N: usize = 3;
                $body
            }
            4 => {
                const $N: usize = 4;
                $body
            }
            5 => {
                const $N: usize = 5;
                $body
            }
            6 => {
                const $N: usize = 6;
                $body
            }
            7 => {
                const $N: usize = 7;
                $body
            }
            8 => {
                const $N: usize = 8;
                $body
            }
            n => Err(anyhow::anyhow!(
                "robots with {} joints are not supported (2 to 8)",
                n
            )),
        }
    };
}
