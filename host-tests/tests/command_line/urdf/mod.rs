//! URDF import and export against an independent URDF forward kinematics: the files
//! are read with `urdf-rs` (not the command line's `roxmltree` reader) and each joint is
//! composed as origin·Rot(axis, q) with its own matrices.
//!
//! `cargo test -p kinecal-host --test command_line urdf:: -- --nocapture` prints the worst differences.

use crate::common::{kinecal, kinecal_ok, s, stderr};
use kinecal::ForwardKinematics;
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::with_joints;
use nalgebra::{Matrix3, Matrix4, Rotation3, Unit, Vector3, Vector4};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::{Path, PathBuf};

mod dh_table;
mod export;
mod import;
mod reference;
mod refusals;

use reference::{angle_between, origin, point_of, rotation_of, RefChain};

/// The five public URDFs: (folder, file, import options).
const URDFS: [(&str, &str, &[&str]); 5] = [
    ("abb_irb140", "irb140.urdf", &[]),
    ("kuka_kr16_2", "kr16_2.urdf", &[]),
    ("kuka_lbr_iiwa_14", "lbr_iiwa_14_r820.urdf", &[]),
    ("franka_panda", "panda_arm.urdf", &[]),
    ("ur10", "ur10_robot.urdf", &["--tip-link", "tool0"]),
];

fn urdf_path(dir: &str, file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/urdf")
        .join(dir)
        .join(file)
}

/// The library's (f64) point and frame orientation (flange · tool rpy) at `q` (radians).
fn library_pose(file: &RobotFile, q: &[f64]) -> (Vector3<f64>, Matrix3<f64>) {
    let r: anyhow::Result<(Vector3<f64>, Matrix3<f64>)> = with_joints!(file.joints.len(), N => {
        let robot = file.to_robot::<N>().unwrap();
        let mut qa = [0.0; N];
        qa.copy_from_slice(q);
        let mut fk = ForwardKinematics::<f64, N>::new();
        let p = fk.compute(&robot, &qa);
        // The robot carries `[tool] rpy_deg` as its tool axes.
        let frame = fk.tool_pose(&robot);
        Ok((p, frame.rotation()))
    });
    r.unwrap()
}

fn random_q(rng: &mut Xoshiro256PlusPlus, limits: &[[f64; 2]]) -> Vec<f64> {
    limits
        .iter()
        .map(|[lo, hi]| rng.random_range(*lo..=*hi))
        .collect()
}

/// `kinecal import --urdf F --with-base --out DIR/robot.toml EXTRA…` (the URDF's base link
/// is the frame these tests measure in), read back.
fn import(dir: &Path, urdf: &Path, extra: &[&str]) -> (PathBuf, RobotFile) {
    let out = dir.join("robot.toml");
    let mut args = vec!["import", "--urdf", s(urdf), "--with-base", "--out", s(&out)];
    args.extend_from_slice(extra);
    kinecal_ok(&args);
    let f = RobotFile::load(&out).unwrap();
    (out, f)
}

/// `kinecal export --model MODEL --urdf URDF --out OUT EXTRA…`, which must succeed.
fn export_urdf(model: &Path, urdf: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "export",
        "--model",
        s(model),
        "--urdf",
        s(urdf),
        "--out",
        s(out),
    ];
    args.extend_from_slice(extra);
    kinecal_ok(&args);
}

/// The chain's end links the import chose (from its JSON report).
fn chain_links(urdf: &Path, dir: &Path, extra: &[&str]) -> (String, String) {
    let out = dir.join("links.toml");
    let mut args = vec!["import", "--urdf", s(urdf), "--out", s(&out), "--json"];
    args.extend_from_slice(extra);
    let o = kinecal_ok(&args);
    let v = crate::common::json_of(&o);
    (
        v["base_link"].as_str().unwrap().to_string(),
        v["tip_link"].as_str().unwrap().to_string(),
    )
}
