//! What `diagnose` refuses to call a calibration, against known truth
//! (`cli/src/diagnose/refusal.rs`, `cli/src/diagnose/choice.rs`, the checks it shares with
//! `identify`). Each of these used to exit 0 with a model written:
//! - joint 6 logged with the other sign, the reflector 3 mm off its axis: the 371° table that
//!   would explain it was refused as implausible, and the 3.3 mm it left was called the noise
//!   floor under "nothing significant is missing";
//! - a tracker drifting 12.6 mm an hour: refused as implausible, the same headline;
//! - rows of another robot among the held-out poses (identify exits 3 on them);
//! - a `[base]` turned 2° from where the tracker stands (identify exits 3 naming the base).

use crate::common::*;
use std::path::{Path, PathBuf};

/// A UR10 standing in a tracker's frame with its reflector `tool_x` mm off the flange axis.
fn ur10_placed(dir: &Path, tool_x: f64) -> PathBuf {
    let text = std::fs::read_to_string(ur10_dir().join("robot.toml")).unwrap();
    let text = text.replace(
        "xyz_mm = [0.0, 0.0, 109.0]",
        &format!("xyz_mm = [{tool_x}, 0.0, 109.0]"),
    );
    assert!(text.contains(&format!("[{tool_x}, 0.0, 109.0]")), "{text}");
    write(
        dir,
        "ur10_placed.toml",
        &format!("{text}\n[base]\nxyz_mm = [400.0, -3000.0, 100.0]\nrpy_deg = [0.2, 0.1, -60.0]\n"),
    )
}

/// 300 poses of the ER20 placed in the tracker's frame with geometric errors, at 0.02 mm noise.
fn er20_session(dir: &Path, name: &str, seed: u64) -> PathBuf {
    let data = dir.join(name);
    let placed = data_file("er20_placed.toml");
    simulate(
        &placed,
        Some(300),
        Some(0.02),
        Some(seed),
        &["--geom-errors"],
        &data,
    );
    data
}

/// The number in `text` between `before` and `after`.
fn number_between(text: &str, before: &str, after: &str) -> f64 {
    text.split(before)
        .nth(1)
        .and_then(|r| r.split(after).next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no number after {before:?}: {text}"))
}

/// `diagnose --json` on `data` with `extra`: its exit status, JSON and stderr.
fn diagnose(robot: &Path, data: &Path, extra: &[&str]) -> (Option<i32>, serde_json::Value, String) {
    let mut args = vec!["--json"];
    args.extend_from_slice(extra);
    let out = run_on("diagnose", robot, data, &args);
    let v = serde_json::from_slice(&out.stdout).unwrap_or(serde_json::Value::Null);
    (out.status.code(), v, stderr(&out))
}

#[test]
fn a_joint_logged_with_the_other_sign_is_no_noise_floor() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let clean = dir.path().join("clean.csv");
    simulate(
        &ur10_placed(dir.path(), 3.0),
        Some(300),
        Some(0.02),
        Some(2),
        &["--geom-errors"],
        &clean,
    );
    let text = std::fs::read_to_string(&clean).unwrap();
    let flipped = write(
        dir.path(),
        "q6_flipped.csv",
        &edit_rows(&text, |c| {
            c[5] = (-c[5].parse::<f64>().unwrap()).to_string();
        }),
    );
    let out = dir.path().join("M.toml");
    let (code, v, err) = diagnose(&robot, &flipped, &["--holdout", "0.3", "--out", s(&out)]);
    assert_eq!(code, Some(3), "{err}");
    let why = v["unexplained"].as_str().unwrap_or_else(|| panic!("{v}"));
    assert!(why.contains("joint 6's readings do not follow"), "{why}");
    assert!(err.contains("error: ") && err.contains("joint 6"), "{err}");
    let summary = v["summary"].as_str().unwrap();
    assert!(!summary.contains("Nothing significant"), "{summary}");
    // The floor is bounded by what the refused finding reached on unseen poses (the 3.3 mm the
    // geometry leaves is no floor).
    let floor = v["noise_floor_mm"].as_f64().unwrap();
    let refused_rms = v["rounds"]
        .as_array()
        .unwrap()
        .iter()
        .find_map(|r| {
            let name = r["refused"]["candidate"].as_str()?;
            r["refitted"].as_array()?.iter().find_map(|t| {
                (t["candidate"] == name).then(|| t["validation_rms_mm"].as_f64().unwrap())
            })
        })
        .unwrap_or_else(|| panic!("no refused candidate: {v}"));
    assert!(
        floor <= refused_rms,
        "floor {floor} mm, refused {refused_rms} mm"
    );
    assert!(!out.exists(), "a model was written on exit 3");
    // The same session with the sign right is diagnosed as before.
    let (code, v, err) = diagnose(&robot, &clean, &["--holdout", "0.3"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(v.get("unexplained").is_none(), "{v}");
}

#[test]
fn a_drift_no_tracker_has_is_refused_in_the_headline() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let data = dir.path().join("drift.csv");
    simulate(
        &robot,
        Some(400),
        Some(0.01),
        Some(2),
        &[
            "--geom-errors",
            "--session-s",
            "3600",
            "--effect",
            "base-drift:0:3.5e-3,0,0",
        ],
        &data,
    );
    let (code, v, err) = diagnose(&robot, &data, &[]);
    assert_eq!(code, Some(3), "{err}");
    let why = v["unexplained"].as_str().unwrap_or_else(|| panic!("{v}"));
    assert!(why.contains("mm per hour"), "{why}");
    let summary = v["summary"].as_str().unwrap();
    assert!(
        summary.starts_with("No plausible effect explains"),
        "{summary}"
    );
    // 0.01 mm per axis: √3 · 0.01 in the held-out sense, not the drift's millimetres.
    let floor = v["noise_floor_mm"].as_f64().unwrap();
    assert!(floor < 0.1, "floor {floor} mm");
}

#[test]
fn rows_of_another_robot_among_the_held_out_poses_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let placed = data_file("er20_placed.toml");
    let text = std::fs::read_to_string(&placed).unwrap();
    let base = "[base]\nxyz_mm = [2500.0, -1200.0, -300.0]\nrpy_deg = [0.7, -1.3, 155.0]\n";
    assert!(text.contains(base), "{text}");
    let robot = write(dir.path(), "unplaced.toml", &text.replace(base, ""));
    let (a, b) = (
        er20_session(dir.path(), "a.csv", 1),
        er20_session(dir.path(), "b.csv", 11),
    );
    let (a, b) = (
        std::fs::read_to_string(&a).unwrap(),
        std::fs::read_to_string(&b).unwrap(),
    );
    let mixed: String = a
        .lines()
        .take(271)
        .chain(b.lines().skip(271))
        .map(|l| format!("{l}\n"))
        .collect();
    let mixed = write(dir.path(), "mixed.csv", &mixed);
    for command in ["identify", "diagnose"] {
        let out = run_on(command, &robot, &mixed, &["--holdout", "0.3"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(3), "{command}: {err}");
        assert!(
            err.contains("held-out point(s) far from the model"),
            "{command}: {err}"
        );
    }
    // All rows of one robot: diagnosed.
    let one = write(dir.path(), "one.csv", &a);
    let out = run_on("diagnose", &robot, &one, &["--holdout", "0.3"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

#[test]
fn a_stated_base_the_tracker_moved_from_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let placed = data_file("er20_placed.toml");
    let data = er20_session(dir.path(), "d.csv", 1);
    let text = std::fs::read_to_string(&placed).unwrap();
    let turned = text.replace(
        "rpy_deg = [0.7, -1.3, 155.0]",
        "rpy_deg = [0.7, -1.3, 157.0]",
    );
    assert_ne!(turned, text);
    let turned = write(dir.path(), "turned.toml", &turned);
    for command in ["identify", "diagnose"] {
        let out = run_on(command, &turned, &data, &[]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(3), "{command}: {err}");
        assert!(
            err.contains("[base]") && err.contains("estimate the base"),
            "{command}: {err}"
        );
    }
    // Turned 10°: the data are in another frame (exit 2), said with the points' RMS distance
    // and the turn (it quoted the centroids' 1.9 mm, "0.00187 m").
    let far = text.replace(
        "rpy_deg = [0.7, -1.3, 155.0]",
        "rpy_deg = [0.7, -1.3, 165.0]",
    );
    let far = write(dir.path(), "far.toml", &far);
    let out = run_on("identify", &far, &data, &[]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let turned = number_between(&err, "which turns it ", "°");
    assert!((turned - 10.0).abs() < 0.5, "{err}");
    assert!(err.contains(" mm from the model (RMS"), "{err}");
    // The base where the tracker stands: diagnosed.
    let out = run_on("diagnose", &placed, &data, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

/// The UR10 file with every joint limited to `span` degrees around one pose.
fn ur10_around_one_pose(dir: &Path, span: f64) -> PathBuf {
    let text = std::fs::read_to_string(ur10_dir().join("robot.toml")).unwrap();
    let centre = [-180.0, -100.0, 90.0, -80.0, -90.0, 0.0];
    let parts: Vec<&str> = text.split("limits_deg = [-360.0, 360.0]").collect();
    assert_eq!(parts.len(), 7, "{text}");
    let mut out = parts[0].to_string();
    for (c, rest) in centre.iter().zip(&parts[1..]) {
        out.push_str(&format!("limits_deg = [{}, {}]{rest}", c - span, c + span));
    }
    write(dir, &format!("around_{span}.toml"), &out)
}

/// 500 poses of the UR10 within `span` degrees of one pose (with geometric errors, 0.01 mm
/// noise), warming from 15 to 35 °C over `session_s` seconds with the effect `truth`: the robot
/// file and the data.
fn warm_up(dir: &Path, span: f64, session_s: &str, truth: &str) -> (PathBuf, PathBuf) {
    let robot = ur10_around_one_pose(dir, span);
    let data = dir.join("warm.csv");
    let args = [
        "--geom-errors",
        "--temperature",
        "15:35",
        "--session-s",
        session_s,
    ];
    let effect = ["--effect", truth];
    let extra: Vec<&str> = args.iter().chain(&effect).copied().collect();
    simulate(&robot, Some(500), Some(0.01), Some(1), &extra, &data);
    (robot, data)
}

/// A warm-up (15 → 35 °C over an hour) measured in one small region: an arm that expands
/// 12 ppm/K and a tracker drifting along the region's position vector move the points alike
/// there. Within ±1.5° a drift was named `thermal-expansion` and written to the model with
/// exit 0; now neither is named and the diagnosis is no calibration (exit 3). Within ±8° each
/// truth is named as itself.
#[test]
fn an_arm_warming_and_a_tracker_drifting_are_told_apart_or_neither_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let drift = "base-drift:0:3.815e-05,1.093e-05,4.13e-05";
    let thermal = "thermal-expansion:0:1.2e-5";
    for (span, truth, named) in [
        (1.5, drift, None),
        (1.5, thermal, None),
        (8.0, drift, Some("base-drift")),
        (8.0, thermal, Some("thermal-expansion")),
    ] {
        let (robot, data) = warm_up(dir.path(), span, "3600", truth);
        let (code, v, err) = diagnose(&robot, &data, &[]);
        let found: Vec<&str> = v["found"]
            .as_array()
            .unwrap_or_else(|| panic!("{err}"))
            .iter()
            .map(|f| f["effect"].as_str().unwrap())
            .collect();
        match named {
            None => {
                assert_eq!(code, Some(3), "±{span}°, {truth}: {err}");
                assert!(found.is_empty(), "±{span}°, {truth}: {found:?}");
                let why = v["unexplained"].as_str().unwrap_or_else(|| panic!("{v}"));
                assert!(
                    why.contains("the data cannot tell it from")
                        && why.contains("hold the temperature"),
                    "{why}"
                );
                let summary = v["summary"].as_str().unwrap();
                assert!(
                    summary.starts_with("No effect is named: the data cannot tell two causes"),
                    "{summary}"
                );
            }
            Some(effect) => {
                assert_eq!(code, Some(0), "±{span}°, {truth}: {err}");
                assert_eq!(found, [effect], "±{span}°, {truth}");
            }
        }
    }
}

/// The warm-up of the test above within ±1.5° but over 40 s: the tracker's drift that would
/// move the points alike is 18.6 mm per hour as identify fits it, beyond the 10 mm per hour of
/// a working tracker (70 s: 10.6, 80 s: 9.30 mm per hour), so it does not veto the warming
/// arm, which is named (`cli/src/diagnose/mod.rs`: only a plausible twin vetoes).
#[test]
fn a_drift_no_tracker_has_does_not_veto_a_warming_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = warm_up(dir.path(), 1.5, "40", "thermal-expansion:0:1.2e-5");
    let out = run_on("identify", &robot, &data, &["--effect", "base-drift:0"]);
    let report = String::from_utf8_lossy(&out.stdout);
    let per_h = number_between(&report, "appeared to move by ", " mm per hour");
    eprintln!("the twin drift: {per_h} mm per hour");
    assert!(per_h > 10.0, "{report}");
    let (code, v, err) = diagnose(&robot, &data, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(v["found"][0]["effect"], "thermal-expansion", "{v}");
    assert!(v["unexplained"].is_null(), "{v}");
}

/// σ that differ between the axes weigh the search's figures: the headline says they are no
/// position RMS, as it says for 6-D rows.
#[test]
fn sigma_weighted_figures_are_said_to_be_weighted() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let data = dir.path().join("d.csv");
    simulate(
        &robot,
        Some(200),
        Some(0.01),
        Some(3),
        &["--geom-errors"],
        &data,
    );
    let text = std::fs::read_to_string(&data).unwrap();
    let with_sigma = |name: &str, sigma: &str| {
        let mut lines = text.lines();
        let mut out = format!("{},sx_mm,sy_mm,sz_mm\n", lines.next().unwrap());
        for l in lines {
            out.push_str(&format!("{l},{sigma}\n"));
        }
        write(dir.path(), name, &out)
    };
    let weighted = with_sigma("sigma.csv", "0.01,0.01,0.3");
    let (code, v, err) = diagnose(&robot, &weighted, &[]);
    assert_eq!(code, Some(0), "{err}");
    let summary = v["summary"].as_str().unwrap();
    assert!(summary.contains("weighted by the stated σ"), "{summary}");
    assert_eq!(v["figures_sigma_weighted"], true, "{v}");
    // Equal σ everywhere, stated or not: plain distances, nothing said.
    for plain in [data.clone(), with_sigma("equal.csv", "0.05,0.05,0.05")] {
        let (code, v, err) = diagnose(&robot, &plain, &[]);
        assert_eq!(code, Some(0), "{err}");
        assert!(!v["summary"].as_str().unwrap().contains("weighted"), "{v}");
        assert_eq!(v["figures_sigma_weighted"], false, "{v}");
    }
}

/// Joint 4 read 1 % off in every row: identify's geometry took up little of it and was
/// "predicted better than by the starting model" at 3.1 mm (0.02 mm noise), exit 0; it now
/// exits 3 naming the joint's scale (`cli/src/calibration/joint_scale.rs`), and diagnose names
/// the same. The clean session is calibrated as before.
#[test]
fn a_joint_read_one_percent_off_is_named_by_its_scale() {
    let dir = tempfile::tempdir().unwrap();
    let placed = data_file("er20_placed.toml");
    let data = er20_session(dir.path(), "d.csv", 1);
    // Joint 4's readings 1 % off in the file at `from`, written to `name`.
    let q4_off = |from: &Path, name: &str| {
        let text = std::fs::read_to_string(from).unwrap();
        let edited = edit_rows(&text, |c| {
            c[3] = (c[3].parse::<f64>().unwrap() * 1.01).to_string();
        });
        write(dir.path(), name, &edited)
    };
    let scaled = q4_off(&data, "q4_scaled.csv");
    let out = run_on("identify", &placed, &scaled, &["--holdout", "0.3"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("with a scale on joint 4's readings too")
            && err.contains("--effect joint-scale:4"),
        "{err}"
    );
    // 1/1.01: 9901 ppm less.
    let ppm = number_between(&err, "joint 4 turns ", " ppm less");
    eprintln!("1 % off: {err}");
    assert!((ppm - 9901.0).abs() < 200.0, "{err}");
    // A robot as its file gives it, with joint 4 read 1 % off, calibrated with --only holding
    // joint 4's zero: the check frees it, and says so.
    let clean = dir.path().join("clean.csv");
    simulate(&placed, Some(300), Some(0.02), Some(1), &[], &clean);
    let clean_scaled = q4_off(&clean, "clean_q4_scaled.csv");
    let only = ["--only", "base,tool"];
    let out = run_on("identify", &placed, &clean_scaled, &only);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("with joint 4's zero free (theta4, held by --only)")
            && err.contains("--effect joint-scale:4 and theta4 among --only"),
        "{err}"
    );
    let out = run_on("identify", &placed, &data, &["--holdout", "0.3"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let (code, v, err) = diagnose(&placed, &scaled, &[]);
    assert_eq!(code, Some(0), "{err}");
    let found: Vec<(&str, u64)> = v["found"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| (f["effect"].as_str().unwrap(), f["joint"].as_u64().unwrap()))
        .collect();
    assert_eq!(found.first(), Some(&("joint-scale", 4)), "{found:?}");
}

/// A once-per-turn error of joint 2 (0.064°) that a scale on its readings stands in for over
/// its range: no readings' scale (a few hundred ppm), so identify's geometric fit is kept with a
/// warning that points to diagnose, which names the cyclic error.
#[test]
fn a_joint_effect_a_small_scale_stands_in_for_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let placed = data_file("er20_placed.toml");
    let data = dir.path().join("d.csv");
    simulate(
        &placed,
        Some(300),
        Some(0.01),
        Some(7),
        &["--effect", "joint-cyclic:2:0.001,0.0005"],
        &data,
    );
    let out = run_on("identify", &placed, &data, &["--holdout", "0.3"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains("warning: the fit leaves")
            && err.contains("joint 2's readings carry")
            && err.contains("kinecal diagnose names it"),
        "{err}"
    );
    let (code, v, err) = diagnose(&placed, &data, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(v["found"][0]["effect"], "joint-cyclic", "{v}");
}

/// Joint 2's zero 0.2° off in every row, over a range that keeps away from zero (40° to 80°),
/// calibrated with `--only` parameters that hold that zero: a scale on joint 2's readings
/// stands in for most of a zero error there (2.986 mm left, 0.5576 mm with a scale), and
/// identify warned that joint 2's readings carry a scale of 3208 ppm. The check frees the
/// joint's zero in both its fits, so a zero error is no scale: the fit that held the zero is
/// refused for the geometry it held (~3 mm left where a new calibration leaves ~0.03 mm:
/// `cli/src/calibration/held_geometry.rs`), with no word of a scale; with the zero free the
/// session calibrates as before.
#[test]
fn a_zero_error_held_by_only_is_no_scale() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data_file("er20_placed.toml")).unwrap();
    let narrow = text.replacen("[-150.0, 90.0]", "[40.0, 80.0]", 1);
    assert_ne!(narrow, text);
    let placed = write(dir.path(), "er20_narrow.toml", &narrow);
    let data = dir.path().join("d.csv");
    simulate(&placed, Some(300), Some(0.02), Some(3), &[], &data);
    let text = std::fs::read_to_string(&data).unwrap();
    let shifted = write(
        dir.path(),
        "q2_zero.csv",
        &edit_rows(&text, |c| {
            c[1] = (c[1].parse::<f64>().unwrap() + 0.2).to_string();
        }),
    );
    let held = ["--only", "base,tool,d2,a2,a3,d4"];
    let out = run_on("identify", &placed, &shifted, &held);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("held the robot file's geometry") && !err.contains("scale on joint"),
        "{err}"
    );
    let out = run_on("identify", &placed, &shifted, &["--holdout", "0.3"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("scale on joint"), "{err}");
}
