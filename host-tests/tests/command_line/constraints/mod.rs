//! Calibration without a tracker (README, "Without a tracker"): constraint sessions simulated from a robot with
//! known geometric errors (`simulate --constraints`), fitted by `identify`, judged against the
//! truth on fresh random poses, with an alignment computed here (Kabsch/Umeyama on the two
//! models' tool points) since constraints cannot see the base (nor, from sockets and planes
//! alone, the overall scale). The sessions and judgements the tests share are here, the tests
//! in one module per topic.

use crate::common::{data_file, json_of, kinecal, kinecal_ok, s, stderr, write};
use kinecal::ForwardKinematics;
use kinecal_cli::formats::robot_file::load_robot;
use kinecal_host::constraint_reference::aligned_rms;
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

mod calibration;
mod check_and_report;
mod effects;
mod outliers;
mod plan_and_diagnose;
mod refusals;
mod session_checks;

/// The base pose names `identify` prints.
const BASE: [&str; 6] = [
    "base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz",
];

/// Simulates a constraint session `spec` of the ER20 with geometric errors; returns the session
/// and the true robot file.
fn session(dir: &Path, spec: &str, seed: u64) -> (PathBuf, PathBuf) {
    session_of(dir, spec, seed, &["--geom-errors"])
}

/// Simulates a constraint session `spec` of the ER20 whose errors `errors` gives (simulate's
/// flags), 0.01 mm noise; returns the session and the true robot file.
fn session_of(dir: &Path, spec: &str, seed: u64, errors: &[&str]) -> (PathBuf, PathBuf) {
    let (data, truth) = (dir.join("session.csv"), dir.join("truth.toml"));
    let (seed, robot) = (seed.to_string(), data_file("er20.toml"));
    let mut args = vec![
        "simulate",
        "--robot",
        s(&robot),
        "--constraints",
        spec,
        "--noise-mm",
        "0.01",
        "--seed",
        &seed,
        "--out",
        s(&data),
        "--truth",
        s(&truth),
    ];
    args.extend_from_slice(errors);
    kinecal_ok(&args);
    (data, truth)
}

/// `COMMAND --robot er20.toml --data DATA --json` (extra flags appended), asserting exit 0.
fn json_on(command: &str, data: &Path, extra: &[&str]) -> serde_json::Value {
    let robot = data_file("er20.toml");
    let mut args = vec![command, "--robot", s(&robot), "--data", s(data), "--json"];
    args.extend_from_slice(extra);
    json_of(&kinecal_ok(&args))
}

/// `identify --json` on `data` (extra flags appended), asserting exit 0.
fn identify(data: &Path, extra: &[&str]) -> serde_json::Value {
    json_on("identify", data, extra)
}

fn names(v: &serde_json::Value) -> Vec<String> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|n| n.as_str().unwrap().to_string())
        .collect()
}

/// RMS distance (mm) between the tool points of `model` and `truth` on 300 random poses, after
/// the rigid transform (and, with `scale`, the uniform scale) that best maps one set on the other.
fn tool_point_rms(model: &Path, truth: &Path, scale: bool) -> f64 {
    let (_, m) = load_robot::<6>(model).unwrap();
    let (_, t) = load_robot::<6>(truth).unwrap();
    let mut rng = kinecal_cli::simulation::Streams::new(1234).configs;
    let qs = kinecal_cli::simulation::random_configurations(&t, 300, &mut rng);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let a: Vec<Vector3<f64>> = qs.iter().map(|q| fk.compute(&m, q)).collect();
    let b: Vec<Vector3<f64>> = qs.iter().map(|q| fk.compute(&t, q)).collect();
    aligned_rms(&a, &b, scale)
}
