//! Base and tool frames from single-joint sweeps: circle fit, common normal, joint
//! axes, base pose and tool distances against known truth, and the `frames` subcommand.

use kinecal::frames::circle::{fit_circle, CircleError};
use kinecal::frames::circle_point::{
    base_from_sweeps, common_normal, joint_axis, tool_from_sweeps, AxialMethod, FramesError, Line,
    Sweep,
};
use kinecal::model::frame::orientation_error;
use kinecal::{Frame, Joint, Robot};
use kinecal_cli::formats::measurements;
use kinecal_cli::simulation::sweeps::{default_rest, sweep_data, SweepSet};
use nalgebra::{Rotation3, Unit, Vector3};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

mod base;
mod circle_fit;
mod command;
mod joint_axes;
mod no_panics;
mod sweep_start;
mod tool;

type Rows = [(f64, f64, f64, f64)];

fn robot<const N: usize>(
    rows: &Rows,
    tool: [f64; 3],
    base: Frame<f64>,
) -> Robot<f64, N, kinecal::Inline<0>> {
    let joints: [Joint<f64>; N] = std::array::from_fn(|i| {
        let (al, a, th, d) = rows[i];
        let mut j = Joint::mdh_deg(al, a, th, d);
        j.lower = -2.0 * std::f64::consts::PI;
        j.upper = 2.0 * std::f64::consts::PI;
        j
    });
    Robot::new(base, joints, Vector3::from(tool)).unwrap()
}

/// UR10 of data/ur10/robot.toml (nominal modified DH).
const UR10: [(f64, f64, f64, f64); 6] = [
    (0.0, 0.0, 0.0, 118.0),
    (90.0, 0.0, 180.0, 0.0),
    (0.0, 612.7, 0.0, 0.0),
    (0.0, 571.6, 0.0, 163.9),
    (-90.0, 0.0, 0.0, 115.7),
    (90.0, 0.0, 180.0, 92.2),
];
const UR10_TOOL: [f64; 3] = [0.0, 0.0, 109.0];

/// The ER20-C10 stand-in of the issue.
const ER20: [(f64, f64, f64, f64); 6] = [
    (0.0, 0.0, 0.0, 504.0),
    (-90.0, 170.0, -90.0, 0.0),
    (0.0, 780.0, 0.0, 0.0),
    (-90.0, 140.0, 0.0, 760.0),
    (90.0, 0.0, 0.0, 0.0),
    (-90.0, 0.0, 0.0, 125.0),
];
const ER20_TOOL: [f64; 3] = [0.0, 0.0, 100.0];

/// A first row of the general form (alpha, a, theta ≠ 0) and a negative a1 in row 2.
const GENERAL: [(f64, f64, f64, f64); 6] = [
    (12.0, 40.0, 25.0, 420.0),
    (90.0, -150.0, 10.0, 30.0),
    (0.0, 700.0, -90.0, 0.0),
    (90.0, 120.0, 0.0, 650.0),
    (-90.0, 0.0, 0.0, 0.0),
    (90.0, 0.0, 0.0, 110.0),
];
const GENERAL_TOOL: [f64; 3] = [30.0, -20.0, 80.0];
/// Limits of a real arm for it (degrees): the sweeps of joints 1 and 2 are shortened to them.
const GENERAL_LIMITS: [(f64, f64); 6] = [
    (-170.0, 170.0),
    (-100.0, 150.0),
    (-160.0, 80.0),
    (-180.0, 180.0),
    (-125.0, 125.0),
    (-350.0, 350.0),
];

fn with_limits<const N: usize>(
    mut r: Robot<f64, N, kinecal::Inline<0>>,
    limits: &[(f64, f64)],
) -> Robot<f64, N, kinecal::Inline<0>> {
    for (i, (lo, hi)) in limits.iter().enumerate() {
        let j = Joint {
            lower: lo.to_radians(),
            upper: hi.to_radians(),
            ..r.joints()[i]
        };
        r.set_joint(i, j).unwrap();
    }
    r
}

/// A 7-joint arm (intersecting axes 1 and 2, all a = 0).
const IIWA: [(f64, f64, f64, f64); 7] = [
    (0.0, 0.0, 0.0, 340.0),
    (-90.0, 0.0, 0.0, 0.0),
    (90.0, 0.0, 0.0, 400.0),
    (90.0, 0.0, 0.0, 0.0),
    (-90.0, 0.0, 0.0, 400.0),
    (-90.0, 0.0, 0.0, 0.0),
    (90.0, 0.0, 0.0, 126.0),
];
const IIWA_TOOL: [f64; 3] = [0.0, 0.0, 60.0];

fn random_base(rng: &mut Xoshiro256PlusPlus) -> Frame<f64> {
    let xyz = [
        rng.random_range(-2500.0..2500.0),
        rng.random_range(-2500.0..2500.0),
        rng.random_range(-1500.0..1500.0),
    ];
    let rpy = [
        rng.random_range(-180.0f64..180.0).to_radians(),
        rng.random_range(-89.0f64..89.0).to_radians(),
        rng.random_range(-180.0f64..180.0).to_radians(),
    ];
    Frame::from_xyz_rpy(xyz, rpy)
}

/// Position (mm) and orientation (deg) differences of two frames.
fn frame_error(a: &Frame<f64>, b: &Frame<f64>) -> (f64, f64) {
    (
        (a.o - b.o).norm(),
        orientation_error(a, b).norm().to_degrees(),
    )
}

fn write_robot(dir: &std::path::Path, rows: &Rows, tool: [f64; 3]) -> std::path::PathBuf {
    let mut s = String::from("name = \"test arm\"\n");
    for (al, a, th, d) in rows {
        s += &format!("\n[[joints]]\nalpha_deg = {al}\na_mm = {a}\ntheta_deg = {th}\nd_mm = {d}\nlimits_deg = [-360.0, 360.0]\n");
    }
    s += &format!(
        "\n[tool]\nxyz_mm = [{}, {}, {}]\n",
        tool[0], tool[1], tool[2]
    );
    let p = dir.join("robot.toml");
    std::fs::write(&p, s).unwrap();
    p
}

/// `kinecal frames` without the command line: the application function behind it.
fn find_frames(
    robot: &std::path::Path,
    data: &std::path::Path,
    out: Option<&std::path::Path>,
) -> anyhow::Result<kinecal_cli::reports::FramesReport> {
    kinecal_cli::frames::from_files(robot, data, &Default::default(), out)
}
