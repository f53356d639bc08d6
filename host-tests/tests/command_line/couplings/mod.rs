//! Joint couplings (`[[couplings]]`, docs/formats.md) honoured everywhere: forward kinematics
//! against the uncoupled model at converted angles and against the independent reference,
//! effect and joint Jacobians against central differences, the PSO fitness, the LM and its
//! snapshot, planning, frames from sweeps, the robot file, and the command line (`identify`
//! on coupled vs pre-converted data, `compensate` in readings, refused couplings, the `check`
//! hint).

use kinecal::compensate::{compensate, Config, Target};
use kinecal::forward::ForwardKinematics;
use kinecal::frames::circle_point::{base_from_sweeps, FramesError};
use kinecal::identify::fitness::{JointTrig, Objective, PositionFitness};
use kinecal::identify::lm::{FixedLevenberg, Levenberg, LmConfig};
use kinecal::model::coupling::{CouplingError, Couplings};
use kinecal::model::param::{Param, ParamSet};
use kinecal::planning::cell::{Scene, Tracker};
use kinecal::planning::information::{scaled_rows, PoseRows};
use kinecal::{Measurement, Robot, RobotError};
use kinecal_cli::formats::measurements::{self, Dataset};
use kinecal_cli::formats::robot_file::{deg_exact, RobotFile};
use kinecal_cli::simulation::sweeps::{sweep_data, SweepSet};
use kinecal_cli::HostValues;
use kinecal_host::reference::RefRobot;
use nalgebra::{Matrix3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::{Path, PathBuf};

use crate::common::{f64s, json_of, kinecal, location, run_on, s, simulate, ur10_dir, write};

mod compensate_cli;
mod frames;
mod identification;
mod identify_cli;
mod kinematics;
mod missing_coupling;
mod planning;
mod robot_file;

/// A FANUC-like 6R arm whose J3 is read from the horizontal: q3 = J3 + J2.
const FANUC: &str = include_str!("../../data/fanuc_j3_horizontal.toml");

const FANUC_COUPLING: &str = "[[couplings]]\njoint = 3\nfrom = 2\nratio = 1.0\n";

/// A 7R arm with two couplings of other ratios and pairs: q4 = r4 − 1.3·r2, q7 = r7 + 0.25·r6.
const ARM7: &str = include_str!("../../data/arm7_coupled.toml");

fn fanuc_text() -> String {
    format!("{FANUC}{FANUC_COUPLING}")
}

fn parse(text: &str) -> RobotFile {
    RobotFile::parse(text, "test.toml").unwrap()
}

/// The same file without its couplings.
fn uncoupled(f: &RobotFile) -> RobotFile {
    let mut u = f.clone();
    u.couplings.clear();
    u
}

/// Model angles of readings, written independently of the library: q_j += ratio · r_from.
fn to_model(f: &RobotFile, r: &[f64]) -> Vec<f64> {
    let mut q = r.to_vec();
    for c in &f.couplings {
        q[c.joint - 1] += c.ratio * r[c.from - 1];
    }
    q
}

/// Random readings (rad) within the file's limits.
fn readings(f: &RobotFile, rng: &mut Xoshiro256PlusPlus) -> Vec<f64> {
    (0..f.joint_count())
        .map(|j| {
            let [lo, hi] = f.limits_deg(j);
            rng.random_range(lo..hi).to_radians()
        })
        .collect()
}

fn arr<const N: usize>(q: &[f64]) -> [f64; N] {
    std::array::from_fn(|i| q[i])
}

fn rotation(f: &kinecal::Frame<f64>) -> Matrix3<f64> {
    f.rotation()
}
