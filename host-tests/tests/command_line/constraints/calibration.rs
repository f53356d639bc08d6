//! Sessions of one kind or mixed calibrate the shape (README, "Without a tracker"), and held-out
//! groups are predicted better than by the nominal robot.

use super::*;

/// Parameters `identify` holds on tracker points of the same robot (the model's own
/// redundancies, which constraints share).
fn held_with_points(dir: &Path) -> Vec<String> {
    let data = dir.join("points.csv");
    crate::common::simulate(
        &data_file("er20.toml"),
        Some(60),
        Some(0.01),
        Some(3),
        &["--geom-errors"],
        &data,
    );
    names(&identify(&data, &[])["unidentifiable"])
}

/// Fits `spec` and checks: converged, the base held and named, `extra` more non-base parameters
/// held than with tracker points, and the tool-point error on fresh poses (aligned) at most a
/// fifth of the nominal robot's.
fn calibrates(spec: &str, seed: u64, extra: usize, scale_blind: bool) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let (data, truth) = session(dir.path(), spec, seed);
    let model = dir.path().join("model.toml");
    let v = identify(&data, &["--out", s(&model)]);
    assert_eq!(v["converged"], true, "{spec}: {v}");
    assert_eq!(v["method"], "lm");
    let held = names(&v["unidentifiable"]);
    for b in BASE {
        assert!(
            held.contains(&b.to_string()),
            "{spec}: {b} not held: {held:?}"
        );
    }
    let model_held = held.iter().filter(|n| !n.starts_with("base.")).count();
    let points = held_with_points(dir.path());
    assert_eq!(
        model_held,
        points.len() + extra,
        "{spec}: held {held:?}, with tracker points {points:?}"
    );
    let after = tool_point_rms(&model, &truth, scale_blind);
    let before = tool_point_rms(&data_file("er20.toml"), &truth, scale_blind);
    eprintln!("{spec}: tool point RMS on fresh poses {before} mm nominal, {after} mm calibrated");
    assert!(
        after * 5.0 < before,
        "{spec}: tool point RMS {after} mm calibrated against {before} mm nominal"
    );
    assert!(
        v["after"]["identification_rms_mm"].as_f64().unwrap()
            < v["before"]["identification_rms_mm"].as_f64().unwrap() / 5.0,
        "{v}"
    );
    v
}

#[test]
fn sockets_alone_calibrate_the_shape_and_hold_the_base_and_a_scale() {
    let v = calibrates("socket:8x10", 5, 1, true);
    let sockets = v["constraints"]["sockets"].as_array().unwrap();
    assert_eq!(sockets.len(), 8);
}

#[test]
fn planes_alone_calibrate_the_shape_and_hold_the_base_and_a_scale() {
    let v = calibrates("plane:6x12", 5, 1, true);
    for p in v["constraints"]["planes"].as_array().unwrap() {
        let n: Vec<f64> = p["normal"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let norm = n.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((norm - 1.0).abs() < 1e-9, "{p}");
    }
}

#[test]
fn distances_alone_calibrate_the_size_too_and_hold_only_the_base() {
    calibrates("distance:60", 5, 0, false);
}

#[test]
fn a_mixed_session_calibrates_and_reports_each_kind() {
    let v = calibrates("socket:4x10,plane:3x15,distance:30", 3, 0, false);
    let kinds: Vec<&str> = v["constraints"]["kinds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["socket", "plane", "distance"]);
    for k in v["constraints"]["kinds"].as_array().unwrap() {
        assert!(k["after_rms_mm"].as_f64().unwrap() < k["before_rms_mm"].as_f64().unwrap());
    }
}

#[test]
fn held_out_groups_are_predicted_better_than_by_the_nominal_robot() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:6x10,distance:40", 7);
    let v = identify(&data, &["--holdout", "0.25", "--split", "random"]);
    assert_eq!(v["count_unit"], "groups");
    let (ni, nv) = (
        v["n_identification"].as_u64().unwrap(),
        v["n_validation"].as_u64().unwrap(),
    );
    assert_eq!(ni + nv, 46, "{v}");
    assert!(nv >= 10, "{v}");
    let before = v["before"]["validation_rms_mm"].as_f64().unwrap();
    let after = v["after"]["validation_rms_mm"].as_f64().unwrap();
    assert!(
        after * 5.0 < before,
        "held out {after} mm against {before} mm nominal"
    );
    assert!(v["after"]["validation_max_mm"].as_f64().unwrap() >= after);
    assert_eq!(v["held_out_worse"], false);
    // A second session as the validation file: the same figures, counted in its groups.
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let (valid, _) = session(&other, "socket:3x8", 7);
    // The same true robot: the seed gives the geometric errors, whatever the session.
    let w = identify(&data, &["--validate", s(&valid)]);
    assert_eq!(w["n_validation"], 3);
    assert!(
        w["after"]["validation_rms_mm"].as_f64().unwrap() * 5.0
            < w["before"]["validation_rms_mm"].as_f64().unwrap(),
        "{w}"
    );
}

/// A base the constraints cannot see is not written as if measured: the UR10's file has no
/// `[base]`, and neither has the model of its ball-bar session (it used to get `[base]` of
/// zeros, which `compensate` took for the measurement frame's); the ER20's file has one, and the
/// model keeps it as the file gives it.
#[test]
fn an_unseen_base_is_written_only_as_the_robot_file_gives_it() {
    let dir = tempfile::tempdir().unwrap();
    for (robot, with_base) in [
        (crate::common::ur10_dir().join("robot.toml"), false),
        (data_file("er20.toml"), true),
    ] {
        let (data, model) = (dir.path().join("bars.csv"), dir.path().join("model.toml"));
        kinecal_ok(&[
            "simulate",
            "--robot",
            s(&robot),
            "--constraints",
            "distance:40",
            "--geom-errors",
            "--noise-mm",
            "0.01",
            "--seed",
            "5",
            "--out",
            s(&data),
        ]);
        for command in ["identify", "diagnose"] {
            let _ = std::fs::remove_file(&model);
            kinecal_ok(&[
                command,
                "--robot",
                s(&robot),
                "--data",
                s(&data),
                "--out",
                s(&model),
            ]);
            let text = std::fs::read_to_string(&model).unwrap();
            assert_eq!(
                text.contains("[base]"),
                with_base,
                "{command} {}: {text}",
                robot.display()
            );
            if with_base {
                let (_, written) = load_robot::<6>(&model).unwrap();
                let (_, given) = load_robot::<6>(&robot).unwrap();
                let (w, g) = (written.base(), given.base());
                assert!(
                    (w.o - g.o).norm() < 1e-9 && (w.z - g.z).norm() < 1e-12,
                    "{text}"
                );
            }
        }
    }
}
