//! The search reads orientations: an effect only the orientation of 6-D observations shows
//! (a joint-6 angle error that varies with joint 6, the measured point on the flange axis, so
//! no position moves) is named and removed to the tracker's noise, and clean 6-D data give no
//! finding.

use super::observations::{deviations, load, robot_text};
use crate::common::{json_of, run_on, stderr, write};
use kinecal::forward::ForwardKinematics;
use kinecal::Frame;
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// A once-per-turn error of joint 6 of 0.05° amplitude.
const JOINT6_CYCLIC: &str =
    "[[effects]]\nkind = \"joint-cyclic\"\njoint = 6\nvalues = [0.000872665, 0.0]\n";

/// Tracker σ: mm per coordinate, degrees per orientation component.
const SIGMA: (f64, f64) = (0.01, 0.002);

/// `diagnose --holdout 100 --json` on 400 6-D poses (σ columns) of a robot with `hidden`
/// effects, rows off by up to 0.5 mm and 0.05°, a turned tool frame and the measured point on
/// the flange axis; returns the JSON.
fn diagnose_six_d(seed: u64, hidden: &str) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let tool = [("", [0.0, 0.0, 110.0])];
    let (nominal_path, _) = load(
        &robot_text(&[[0.0; 4]; 6], &tool, [0.0; 3], ""),
        dir.path(),
        "robot.toml",
    );
    let dev = deviations(&mut rng);
    let (_, truth) = load(
        &robot_text(&dev, &tool, [0.2, -0.15, 0.4], hidden),
        dir.path(),
        "truth.toml",
    );
    let (sp, sr) = SIGMA;
    let np = Normal::new(0.0, sp).unwrap();
    let nr = Normal::new(0.0, sr.to_radians()).unwrap();
    let mut csv =
        String::from("q1,q2,q3,q4,q5,q6,x,y,z,rx_deg,ry_deg,rz_deg,sx_mm,sy_mm,sz_mm,srot_deg\n");
    let mut fk = ForwardKinematics::<f64, 6>::new();
    for _ in 0..400 {
        let q: [f64; 6] = std::array::from_fn(|_| rng.random_range(-170.0f64..170.0));
        let p = fk.compute(&truth, &q.map(f64::to_radians))
            + Vector3::from_fn(|_, _| np.sample(&mut rng));
        let mut frame: Frame<f64> = fk.tool_pose(&truth);
        frame.rotate_in_parent(&Vector3::from_fn(|_, _| nr.sample(&mut rng)));
        let rpy = frame.rpy().map(f64::to_degrees);
        csv += &format!(
            "{},{:.6},{:.6},{:.6},{:.8},{:.8},{:.8},{sp},{sp},{sp},{sr}\n",
            q.map(|v| format!("{v:.6}")).join(","),
            p.x,
            p.y,
            p.z,
            rpy[0],
            rpy[1],
            rpy[2]
        );
    }
    let out = run_on(
        "diagnose",
        &nominal_path,
        &write(dir.path(), "data.csv", &csv),
        &["--holdout", "100", "--json"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    json_of(&out)
}

/// The held-out orientation RMS (°) of the geometry and of the extended model.
fn held_out_deg(j: &serde_json::Value) -> (f64, f64) {
    let o = &j["observations"];
    let v = |side: &str| o[side]["validation_rms_deg"].as_f64().unwrap();
    (v("before"), v("after"))
}

/// A 0.05° once-per-turn error of joint 6, invisible in positions: the search names it from
/// the orientations, and the held-out orientation RMS falls to the tracker's floor (√3 σ).
#[test]
fn an_orientation_only_error_is_named_and_removed() {
    let j = diagnose_six_d(3401, JOINT6_CYCLIC);
    let found = j["found"].as_array().unwrap();
    let (before, after) = held_out_deg(&j);
    let floor = 3f64.sqrt() * SIGMA.1;
    eprintln!(
        "found {:?}; held-out orientation {before:.5}° → {after:.5}° (floor {floor:.5}°)",
        found
            .iter()
            .map(|f| format!("{} {}", f["effect"], f["joint"]))
            .collect::<Vec<_>>()
    );
    assert!(
        found
            .iter()
            .any(|f| f["effect"] == "joint-cyclic" && f["joint"] == 6),
        "{found:?}"
    );
    // Sized by the turn it gives the tool frame, not by a point move of 1e-7 mm.
    let text = found[0]["explanation"]["text"].as_str().unwrap();
    assert!(
        text.contains("turns the tool frame only") && !text.contains("e-"),
        "{text}"
    );
    assert!(before > 5.0 * floor, "{before}°: the geometry explains it");
    assert!(after < 1.25 * floor, "{after}° against a floor of {floor}°");
}

/// The same 6-D data without the error: nothing is named.
#[test]
fn clean_six_d_data_give_no_finding() {
    let j = diagnose_six_d(3402, "");
    let found = j["found"].as_array().unwrap();
    let (before, after) = held_out_deg(&j);
    eprintln!("found {found:?}; held-out orientation {before:.5}° → {after:.5}°");
    assert!(found.is_empty(), "{found:?}");
}
