//! Calibration without a tracker (README, "Without a tracker"): constraint sessions simulated from a robot with
//! known geometric errors (`simulate --constraints`), fitted by `identify`, judged against the
//! truth on fresh random poses, with an alignment computed here (Kabsch/Umeyama on the two
//! models' tool points) since constraints cannot see the base (nor, from sockets and planes
//! alone, the overall scale). Refusals of malformed groups and held-out groups.

use crate::common::{data_file, json_of, kinecal, kinecal_ok, s, stderr, write};
use kinecal::ForwardKinematics;
use kinecal_cli::formats::robot_file::load_robot;
use kinecal_host::constraint_reference::aligned_rms;
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

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

/// One row of a hand-made constraint file: kind, group, length_mm.
type Cells<'a> = (&'a str, &'a str, &'a str);

/// A constraint file of the ER20 with `rows` (kind, group, length) at one pose each.
fn file_of(dir: &Path, rows: &[(&str, &str, &str)]) -> PathBuf {
    let mut text = String::from("kind,group,q1,q2,q3,q4,q5,q6,length_mm\n");
    for (k, (kind, group, length)) in rows.iter().enumerate() {
        let q = 10.0 + k as f64;
        text.push_str(&format!(
            "{kind},{group},{q},{q},{q},{q},{q},{q},{length}\n"
        ));
    }
    write(dir, "bad.csv", &text)
}

#[test]
fn malformed_groups_are_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let socket3 = [("socket", "s1", ""); 3];
    let distance3 = [("distance", "d1", "500"); 3];
    let lengths = [("distance", "d1", "500"), ("distance", "d1", "501")];
    let missing = [("distance", "d1", "500"), ("distance", "d1", "")];
    let negative = [("distance", "d1", "-5"), ("distance", "d1", "-5")];
    let unknown = [("sphere", "s1", ""); 4];
    let badname = [("socket", "s 1", ""); 4];
    let cases: [(&[Cells], &str); 7] = [
        (&socket3, "at least 4"),
        (&distance3, "exactly 2"),
        (&lengths, "same length_mm"),
        (&missing, "length_mm on both rows"),
        (&negative, "must be > 0"),
        (&unknown, "unknown"),
        (&badname, "letters, digits"),
    ];
    for (rows, why) in cases {
        let data = file_of(dir.path(), rows);
        let o = kinecal(&[
            "identify",
            "--robot",
            s(&data_file("er20.toml")),
            "--data",
            s(&data),
        ]);
        assert_eq!(o.status.code(), Some(2), "{rows:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(why), "{rows:?}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "one line: {e}");
    }
}

#[test]
fn joint_readings_in_radians_are_read_with_angle_unit() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "distance:40", 9);
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let mut rad = format!("{header}\n");
    for l in lines {
        let cells: Vec<String> = l
            .split(',')
            .enumerate()
            .map(|(k, c)| {
                if (2..8).contains(&k) {
                    format!("{}", c.parse::<f64>().unwrap().to_radians())
                } else {
                    c.to_string()
                }
            })
            .collect();
        rad.push_str(&cells.join(","));
        rad.push('\n');
    }
    let rad_file = write(dir.path(), "rad.csv", &rad);
    let deg = identify(&data, &[]);
    let r = identify(&rad_file, &["--angle-unit", "rad"]);
    let (a, b) = (
        deg["before"]["identification_rms_mm"].as_f64().unwrap(),
        r["before"]["identification_rms_mm"].as_f64().unwrap(),
    );
    assert!((a - b).abs() < 1e-6 * a, "nominal {a} vs {b}");
    // Both fits end at the same minimum to the convergence tolerance; degrees read as radians
    // would put every tool point metres away.
    let (a, b) = (
        deg["after"]["identification_rms_mm"].as_f64().unwrap(),
        r["after"]["identification_rms_mm"].as_f64().unwrap(),
    );
    assert!((a - b).abs() < 0.05 * a, "calibrated {a} vs {b}");
    // Without --angle-unit the radians are refused, and the reason says which flag (not the
    // lengths, which then look 20 times too long).
    for command in ["identify", "diagnose", "check"] {
        let out = kinecal(&[
            command,
            "--robot",
            s(&data_file("er20.toml")),
            "--data",
            s(&rad_file),
        ]);
        assert_eq!(out.status.code(), Some(2), "{command}");
        let e = stderr(&out);
        assert!(
            e.contains("look like radians") && e.contains("--angle-unit rad"),
            "{command}: {e}"
        );
        assert_eq!(e.trim().lines().count(), 1, "{e}");
    }
}

#[test]
fn an_effect_requested_on_a_constraint_file_is_estimated_with_the_model() {
    let dir = tempfile::tempdir().unwrap();
    // A cyclic error of joint 2 (a = 0.002 rad, b = −0.001 rad: millimetres at the tool) and
    // no other error.
    let (data, truth) = session_of(
        dir.path(),
        "socket:4x10,distance:40",
        7,
        &["--effect", "joint-cyclic:2:0.002,-0.001:1"],
    );
    let (plain, with) = (dir.path().join("plain.toml"), dir.path().join("with.toml"));
    let v0 = identify(&data, &["--out", s(&plain)]);
    let v1 = identify(&data, &["--effect", "joint-cyclic:2:1", "--out", s(&with)]);
    assert_eq!(v1["converged"], true, "{v1}");
    let estimated = names(&v1["estimated"]);
    for p in ["joint-cyclic2.n1.a", "joint-cyclic2.n1.b"] {
        assert!(
            estimated.contains(&p.to_string()),
            "{p} not estimated: {estimated:?}"
        );
    }
    let (a, b) = (
        v1["parameters"]["joint-cyclic2.n1.a"].as_f64().unwrap(),
        v1["parameters"]["joint-cyclic2.n1.b"].as_f64().unwrap(),
    );
    let nominal = tool_point_rms(&data_file("er20.toml"), &truth, false);
    let (e0, e1) = (
        tool_point_rms(&plain, &truth, false),
        tool_point_rms(&with, &truth, false),
    );
    eprintln!(
        "cyclic error of joint 2 from sockets and distances: tool point RMS {nominal} mm \
         nominal, {e0} mm geometry only, {e1} mm with --effect (a = {a}, b = {b} rad)"
    );
    // The geometry alone cannot follow the cyclic term; with it the model reaches the noise.
    assert!(e1 * 4.0 < e0, "{e1} mm with the effect, {e0} mm without");
    assert!(e1 < 0.05, "{e1} mm");
    assert!(
        (a - 0.002).abs() < 2e-4 && (b + 0.001).abs() < 2e-4,
        "a = {a}, b = {b}"
    );
    let ident = |v: &serde_json::Value| v["after"]["identification_rms_mm"].as_f64().unwrap();
    assert!(ident(&v1) < ident(&v0), "{v0}\n{v1}");
}

#[test]
fn thermal_expansion_on_a_constraint_file_without_temperatures_is_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10", 3);
    let out = kinecal(&[
        "identify",
        "--robot",
        s(&data_file("er20.toml")),
        "--data",
        s(&data),
        "--effect",
        "thermal-expansion",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("no temp_c column"),
        "{}",
        stderr(&out)
    );
}

/// A warming arm measured with a ball bar: `pairs` distance groups of the ER20 whose lengths
/// expand by `c` per kelvin from 25 °C, the rows' `temp_c` rising from 15 to 35 °C over the
/// session (0.002 mm noise on the lengths); returns the file.
fn warming_distances(dir: &Path, pairs: usize, c: f64, temp_column: bool) -> PathBuf {
    use kinecal::model::effects::EffectKind;
    use rand::{RngExt, SeedableRng};
    let (_, nominal) = load_robot::<6>(&data_file("er20.toml")).unwrap();
    let mut truth = nominal.clone();
    truth
        .effects_mut()
        .push(EffectKind::Thermal, 0, 6, 1, 25.0, 0.0, &[c])
        .unwrap();
    let mut rng = kinecal_cli::simulation::Streams::new(77).configs;
    let qs = kinecal_cli::simulation::random_configurations(&truth, 2 * pairs, &mut rng);
    let mut noise = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(78);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let mut text = String::from("kind,group,q1,q2,q3,q4,q5,q6,length_mm");
    text += if temp_column { ",temp_c\n" } else { "\n" };
    for k in 0..pairs {
        let temp = |i: usize| 15.0 + 20.0 * i as f64 / (2 * pairs - 1) as f64;
        let (a, b) = (2 * k, 2 * k + 1);
        let pa = fk.compute_at(&truth, &qs[a], 0, Some(temp(a))).unwrap();
        let pb = fk.compute_at(&truth, &qs[b], 0, Some(temp(b))).unwrap();
        let length = (pa - pb).norm() + 0.002 * (noise.random::<f64>() - 0.5) * 3.46;
        for i in [a, b] {
            let q: Vec<String> = qs[i].iter().map(|v| v.to_degrees().to_string()).collect();
            text += &format!("distance,bar{k},{},{length}", q.join(","));
            text += &if temp_column {
                format!(",{}\n", temp(i))
            } else {
                "\n".to_string()
            };
        }
    }
    write(dir, "warming.csv", &text)
}

#[test]
fn thermal_expansion_is_fitted_from_a_warming_ball_bar_session() {
    let dir = tempfile::tempdir().unwrap();
    let c = 2.0e-5;
    let data = warming_distances(dir.path(), 120, c, true);
    let plain = identify(&data, &[]);
    let model = dir.path().join("model.toml");
    let v = identify(
        &data,
        &["--effect", "thermal-expansion", "--out", s(&model)],
    );
    assert_eq!(v["converged"], true, "{v}");
    assert!(
        names(&v["estimated"]).contains(&"thermal-expansion1".to_string()),
        "{v}"
    );
    let fitted = v["parameters"]["thermal-expansion1"].as_f64().unwrap();
    let rms = |v: &serde_json::Value| v["after"]["identification_rms_mm"].as_f64().unwrap();
    eprintln!(
        "ball bar, 15 -> 35 °C: c = {fitted:e} per K (truth {c:e}); length RMS {} mm without \
         the term, {} mm with it",
        rms(&plain),
        rms(&v)
    );
    // The expansion is the only error: c comes back within 3 %, and the lengths that the
    // geometry alone cannot follow (up to 0.4 mm over the session) fit to the noise.
    assert!((fitted - c).abs() < 0.03 * c, "c = {fitted}");
    assert!(rms(&v) < 0.003, "{v}");
    assert!(rms(&plain) > 5.0 * rms(&v), "{plain}");
    // The reference is the rows' mean temperature (25 °C, not the file default of 20 °C), and
    // a robot file whose term has no reference_c gets the same when refitted.
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("reference_c = 25"), "{text}");
    let bare: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("reference_c"))
        .map(|l| format!("{l}\n"))
        .collect();
    let bare = write(dir.path(), "bare.toml", &bare);
    let again = dir.path().join("again.toml");
    let v2 = json_of(&kinecal_ok(&[
        "identify",
        "--robot",
        s(&bare),
        "--data",
        s(&data),
        "--json",
        "--out",
        s(&again),
    ]));
    let refitted = v2["parameters"]["thermal-expansion1"].as_f64().unwrap();
    assert!((refitted - c).abs() < 0.03 * c, "c = {refitted}");
    let text = std::fs::read_to_string(&again).unwrap();
    assert!(text.contains("reference_c = 25"), "{text}");
}

#[test]
fn a_simulated_warming_constraint_session_gives_back_its_expansion() {
    let dir = tempfile::tempdir().unwrap();
    let c = 2.0e-5;
    let (data, truth) = session_of(
        dir.path(),
        "socket:4x10,plane:2x12,distance:40",
        5,
        &[
            "--temperature",
            "15:35",
            "--effect",
            &format!("thermal-expansion:0:{c}"),
        ],
    );
    // The rows are written warming from 15 to 35 °C in their order.
    let text = std::fs::read_to_string(&data).unwrap();
    let temps: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(text.lines().next().unwrap().ends_with(",temp_c"), "{text}");
    assert_eq!((temps[0], temps[temps.len() - 1]), (15.0, 35.0));
    assert!(temps.windows(2).all(|w| w[1] >= w[0]));
    let (plain, with) = (dir.path().join("plain.toml"), dir.path().join("with.toml"));
    let v0 = identify(&data, &["--out", s(&plain)]);
    let v1 = identify(&data, &["--effect", "thermal-expansion", "--out", s(&with)]);
    assert_eq!(v1["converged"], true, "{v1}");
    let fitted = v1["parameters"]["thermal-expansion1"].as_f64().unwrap();
    let rms = |v: &serde_json::Value| v["after"]["identification_rms_mm"].as_f64().unwrap();
    let (e0, e1) = (
        tool_point_rms(&plain, &truth, false),
        tool_point_rms(&with, &truth, false),
    );
    eprintln!(
        "simulated warming session (sockets, planes, distances): c = {fitted:e} per K (truth \
         {c:e}); identification RMS {} -> {} mm, tool point RMS {e0} -> {e1} mm",
        rms(&v0),
        rms(&v1)
    );
    assert!((fitted - c).abs() < 0.05 * c, "c = {fitted}");
    assert!(rms(&v1) * 3.0 < rms(&v0), "{v0}\n{v1}");
    assert!(e1 < 0.05, "{e1} mm");
}

#[test]
fn constraint_temperatures_missing_on_a_row_or_implausible_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = warming_distances(dir.path(), 10, 2.0e-5, true);
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let cut = lines[1].rfind(',').unwrap();
    let (blank, hot) = (
        format!("{},", &lines[1][..cut]),
        format!("{},5000", &lines[1][..cut]),
    );
    for (row, want) in [
        (blank, "temp_c column with the arm's temperature"),
        (hot, "temp_c 5000 is not a temperature"),
    ] {
        lines[1] = row;
        let bad = write(dir.path(), "bad.csv", &(lines.join("\n") + "\n"));
        let out = kinecal(&[
            "identify",
            "--robot",
            s(&data_file("er20.toml")),
            "--data",
            s(&bad),
            "--effect",
            "thermal-expansion",
        ]);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(stderr(&out).contains(want), "{}", stderr(&out));
    }
}

/// `check --json` of `data` on the ER20, asserting exit 0.
fn check(data: &Path) -> serde_json::Value {
    json_on("check", data, &[])
}

#[test]
fn check_reads_a_constraint_session_as_identify_starts_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,plane:3x15,distance:30", 3);
    let c = check(&data);
    assert_eq!(c["count_unit"], "groups");
    assert_eq!(c["groups"], 4 + 3 + 30, "{c}");
    assert_eq!(c["rows"], 40 + 45 + 60, "{c}");
    assert_eq!(c["joint_ranges_deg"].as_array().unwrap().len(), 6);
    // The nominal figures per kind are identify's "before" on the same rows.
    let v = identify(&data, &[]);
    let kinds = c["kinds"].as_array().unwrap();
    let before = v["constraints"]["kinds"].as_array().unwrap();
    assert_eq!(kinds.len(), 3);
    for (k, b) in kinds.iter().zip(before) {
        assert_eq!(k["kind"], b["kind"]);
        assert_eq!(k["groups"], b["groups"]);
        assert_eq!(k["rows"], b["rows"]);
        let (x, y) = (
            k["nominal_rms_mm"].as_f64().unwrap(),
            b["before_rms_mm"].as_f64().unwrap(),
        );
        assert!((x - y).abs() <= 1e-9 * y, "{}: {x} against {y}", k["kind"]);
        assert!(x > 0.1, "{k}: the geometric errors are millimetres");
    }
    let blind = names(&c["cannot_determine"]);
    for b in BASE {
        assert!(blind.contains(&b.to_string()), "{b}: {blind:?}");
    }
    // Identify holds at the end what check found it cannot determine at the start.
    let held = names(&v["unidentifiable"]);
    assert_eq!(
        blind.len(),
        held.len(),
        "check {blind:?}, identify {held:?}"
    );
}

#[test]
fn check_names_the_scale_that_sockets_alone_cannot_see() {
    let dir = tempfile::tempdir().unwrap();
    let non_base = |spec: &str| {
        let (data, _) = session(dir.path(), spec, 5);
        let blind = names(&check(&data)["cannot_determine"]);
        for b in BASE {
            assert!(blind.contains(&b.to_string()), "{spec}: {b}: {blind:?}");
        }
        blind.iter().filter(|n| !n.starts_with("base.")).count()
    };
    let (sockets, distances) = (non_base("socket:8x10"), non_base("distance:60"));
    assert_eq!(
        sockets,
        distances + 1,
        "sockets {sockets}, distances {distances}"
    );
}

#[test]
fn commands_that_need_tracker_points_refuse_a_constraint_file_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10", 3);
    let out = kinecal(&[
        "frames",
        "--robot",
        s(&data_file("er20.toml")),
        "--data",
        s(&data),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(
        e.contains("a constraint file (kind column)") && e.contains("tracker points"),
        "{e}"
    );
    assert_eq!(e.trim().lines().count(), 1, "{e}");
}

#[test]
fn residuals_of_a_constraint_fit_add_up_to_its_report() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,plane:3x15,distance:30", 3);
    let table = dir.path().join("residuals.csv");
    let v = identify(
        &data,
        &[
            "--holdout",
            "0.25",
            "--split",
            "random",
            "--residuals",
            s(&table),
        ],
    );
    let text = std::fs::read_to_string(&table).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("set,kind,group,line,nominal_mm,model_mm")
    );
    // (set, group) → the nominal and model values of its rows.
    let mut groups: std::collections::BTreeMap<(String, String), Vec<(f64, f64)>> =
        Default::default();
    let mut ident_rows = Vec::new();
    for l in lines {
        let c: Vec<&str> = l.split(',').collect();
        assert_eq!(c.len(), 6, "{l}");
        let line: usize = c[3].parse().unwrap();
        assert!(line >= 2, "{l}");
        let (a, b): (f64, f64) = (c[4].parse().unwrap(), c[5].parse().unwrap());
        if c[0] == "identification" {
            ident_rows.push((a, b));
        } else {
            assert_eq!(c[0], "held-out", "{l}");
        }
        groups
            .entry((c[0].to_string(), c[2].to_string()))
            .or_default()
            .push((a, b));
    }
    let rms = |e: &[f64]| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 + 1e-5 * y.abs();
    let (before, after) = (&v["before"], &v["after"]);
    let a: Vec<f64> = ident_rows.iter().map(|r| r.0).collect();
    let b: Vec<f64> = ident_rows.iter().map(|r| r.1).collect();
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    assert!(
        close(rms(&a), f(&before["identification_rms_mm"])),
        "{}",
        rms(&a)
    );
    assert!(
        close(rms(&b), f(&after["identification_rms_mm"])),
        "{}",
        rms(&b)
    );
    // A held-out group's residual is the RMS of its rows against its own refitted shape.
    let held: Vec<&Vec<(f64, f64)>> = groups
        .iter()
        .filter(|((set, _), _)| set == "held-out")
        .map(|(_, r)| r)
        .collect();
    assert_eq!(held.len(), v["n_validation"].as_u64().unwrap() as usize);
    let per_group = |k: fn(&(f64, f64)) -> f64| {
        let g: Vec<f64> = held
            .iter()
            .map(|r| rms(&r.iter().map(k).collect::<Vec<_>>()))
            .collect();
        rms(&g)
    };
    assert!(close(per_group(|r| r.0), f(&before["validation_rms_mm"])));
    assert!(close(per_group(|r| r.1), f(&after["validation_rms_mm"])));
    let idg = groups
        .keys()
        .filter(|(set, _)| set == "identification")
        .count();
    assert_eq!(idg, v["n_identification"].as_u64().unwrap() as usize);
}

#[test]
fn a_misstated_unit_on_a_constraint_file_is_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,distance:20", 3);
    let robot = data_file("er20.toml");
    let run = |cmd: &str, flag: &str, value: &str| {
        let mut args = vec![cmd, "--robot", s(&robot), "--data", s(&data), flag, value];
        if cmd == "validate" {
            args.extend(["--model", s(&robot)]);
        }
        kinecal(&args)
    };
    for cmd in ["check", "identify", "validate"] {
        // Degrees read as radians.
        let out = run(cmd, "--angle-unit", "rad");
        assert_eq!(out.status.code(), Some(2), "{cmd}: {}", stderr(&out));
        assert!(
            stderr(&out).contains("look like degrees; leave --angle-unit rad out"),
            "{cmd}: {}",
            stderr(&out)
        );
        // Millimetre lengths read as metres.
        let out = run(cmd, "--length-unit", "m");
        assert_eq!(out.status.code(), Some(2), "{cmd}: {}", stderr(&out));
        assert!(
            stderr(&out)
                .contains("look like millimetres read as metres; leave --length-unit m out"),
            "{cmd}: {}",
            stderr(&out)
        );
    }
}

#[test]
fn report_on_a_constraint_session_shows_each_kind_as_identify_judged_it() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,plane:3x15,distance:30", 3);
    let robot = data_file("er20.toml");
    let (model, page) = (dir.path().join("model.toml"), dir.path().join("page.html"));
    let split = ["--holdout", "0.25", "--split", "random", "--seed", "4"];
    let mut args = vec!["--out", s(&model)];
    args.extend_from_slice(&split);
    let v = identify(&data, &args);
    let report = |model: &Path, page: &Path| {
        let mut a = vec![
            "report",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--model",
            s(model),
            "--out",
            s(page),
            "--json",
        ];
        a.extend_from_slice(&split);
        kinecal(&a)
    };
    let out = report(&model, &page);
    assert!(out.status.success(), "{}", stderr(&out));
    let r = json_of(&out);
    // The page's figures are identify's: the same split, the same model.
    let close = |a: &serde_json::Value, b: &serde_json::Value| {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        (a - b).abs() <= 1e-9 * b.abs().max(1.0)
    };
    for set in ["before", "after"] {
        for key in [
            "identification_rms_mm",
            "validation_rms_mm",
            "validation_max_mm",
        ] {
            assert!(close(&r[set][key], &v[set][key]), "{set}.{key}: {r} vs {v}");
        }
    }
    for key in ["n_identification", "n_validation", "n_identification_rows"] {
        assert_eq!(r[key], v[key], "{key}");
    }
    let kinds = r["constraints"]["kinds"].as_array().unwrap();
    let want = v["constraints"]["kinds"].as_array().unwrap();
    assert_eq!(kinds.len(), 3);
    for (a, b) in kinds.iter().zip(want) {
        assert_eq!(a["kind"], b["kind"]);
        assert!(close(&a["after_rms_mm"], &b["after_rms_mm"]), "{a} vs {b}");
    }
    // Held out per kind: the groups add up, and the calibrated model is better on each kind.
    let held = r["held_out"].as_array().unwrap();
    let groups: u64 = held.iter().map(|k| k["groups"].as_u64().unwrap()).sum();
    assert_eq!(groups, v["n_validation"].as_u64().unwrap());
    for k in held {
        assert!(
            k["after_rms_mm"].as_f64().unwrap() * 3.0 < k["before_rms_mm"].as_f64().unwrap(),
            "{k}"
        );
    }
    assert_eq!(r["converged"], true);
    let base: Vec<String> = r["cannot_determine"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap().to_string())
        .collect();
    for b in BASE {
        assert!(base.contains(&b.to_string()), "{b}: {base:?}");
    }
    assert!(!r["changed"].as_array().unwrap().is_empty());
    let html = std::fs::read_to_string(&page).unwrap();
    assert_eq!(r["bytes"].as_u64().unwrap() as usize, html.len());
    for needle in ["Held-out", "socket", "plane", "distance", "<svg", "base.x"] {
        assert!(html.contains(needle), "{needle} not on the page");
    }
    // Another robot's truth as the "model": worse than the nominal robot on the held-out
    // groups, exit 3, and the page says so.
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let (_, wrong) = session(&other, "socket:2x4", 11);
    let bad_page = dir.path().join("bad.html");
    let out = report(&wrong, &bad_page);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["held_out_worse"], true, "{r}");
    let html = std::fs::read_to_string(&bad_page).unwrap();
    assert!(
        html.contains("Not a calibration"),
        "the page hides the verdict"
    );
    // Flags that belong to tracker sessions are refused in one line.
    let out = kinecal(&[
        "report",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--model",
        s(&model),
        "--out",
        s(&dir.path().join("x.html")),
        "--validate",
        s(&data),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(stderr(&out).trim().lines().count(), 1, "{}", stderr(&out));
}

/// `plan --constraints SPEC --criterion CRITERION` of the ER20 into `out`, its JSON.
fn plan_session(out: &Path, spec: &str, criterion: &str, extra: &[&str]) -> serde_json::Value {
    let robot = data_file("er20.toml");
    let mut args = vec![
        "plan",
        "--robot",
        s(&robot),
        "--constraints",
        spec,
        "--criterion",
        criterion,
        "--out",
        s(out),
        "--json",
    ];
    args.extend_from_slice(extra);
    json_of(&kinecal_ok(&args))
}

#[test]
fn a_planned_socket_session_calibrates_better_than_a_random_one_as_predicted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let spec = "socket:4x8,distance:16";
    let (planned, random) = (d.join("plan.csv"), d.join("random.csv"));
    let p = plan_session(&planned, spec, "d", &[]);
    let r = plan_session(&random, spec, "random", &[]);
    assert_eq!(p["rows"], 64);
    assert_eq!(p["pool_rows"], 256);
    let (p_sigma, r_sigma) = (
        p["predicted_tool_mm"].as_f64().unwrap(),
        r["predicted_tool_mm"].as_f64().unwrap(),
    );
    // The same candidates: the random plan is the planner's starting point.
    assert_eq!(p["random_tool_mm"], r["predicted_tool_mm"]);
    assert!(p_sigma < 0.8 * r_sigma, "{p_sigma} vs {r_sigma}");
    for b in BASE {
        assert!(
            names(&p["cannot_determine"]).contains(&b.to_string()),
            "{b}: {p}"
        );
    }
    // Each plan measured on three robots with different errors, identified, and judged on
    // fresh poses against the truth (aligned: the base is not seen).
    let robot = data_file("er20.toml");
    let mut realised = [0.0f64; 2];
    for seed in 1..=3u64 {
        for (k, plan) in [&planned, &random].into_iter().enumerate() {
            let (data, truth, model) = (
                d.join(format!("s{k}{seed}.csv")),
                d.join(format!("t{k}{seed}.toml")),
                d.join(format!("m{k}{seed}.toml")),
            );
            let seed_text = seed.to_string();
            kinecal_ok(&[
                "simulate",
                "--robot",
                s(&robot),
                "--plan",
                s(plan),
                "--geom-errors",
                "--noise-mm",
                "0.01",
                "--seed",
                &seed_text,
                "--out",
                s(&data),
                "--truth",
                s(&truth),
            ]);
            identify(&data, &["--out", s(&model)]);
            let e = tool_point_rms(&model, &truth, false);
            println!("seed {seed}: {} plan: {e:.5} mm", ["planned", "random"][k]);
            realised[k] += e * e / 3.0;
        }
    }
    let (pe, re) = (realised[0].sqrt(), realised[1].sqrt());
    println!(
        "planned: predicted {p_sigma:.5} mm, realised {pe:.5} mm; random: predicted {r_sigma:.5} \
         mm, realised {re:.5} mm"
    );
    assert!(pe < re, "planned {pe} mm, random {re} mm");
    for (what, predicted, got) in [("planned", p_sigma, pe), ("random", r_sigma, re)] {
        assert!(
            got > 0.4 * predicted && got < 2.5 * predicted,
            "{what}: realised {got} mm, predicted {predicted} mm"
        );
    }
    // The accuracy a user asks for: how many times the groups it takes, planned.
    let a = plan_session(&d.join("more.csv"), spec, "d", &["--accuracy-mm", "0.006"]);
    let need = &a["accuracy"];
    assert_eq!(need["reached"], true, "{a}");
    assert!(need["times_the_groups"].as_u64().unwrap() >= 2, "{a}");
    assert!(need["predicted_tool_mm"].as_f64().unwrap() <= 0.006, "{a}");
}

/// `diagnose --json` on the constraint session `data` (extra flags appended), asserting exit 0.
fn diagnose(data: &Path, extra: &[&str]) -> serde_json::Value {
    json_on("diagnose", data, extra)
}

#[test]
fn diagnose_finds_a_cyclic_error_in_a_socket_session_and_nothing_in_a_geometric_one() {
    let dir = tempfile::tempdir().unwrap();
    let split = ["--holdout", "0.25", "--split", "random"];
    // Joint 2's cyclic error (a = 0.002, b = -0.001 rad) and no other error.
    let cyclic = dir.path().join("cyclic");
    std::fs::create_dir(&cyclic).unwrap();
    let (data, _) = session_of(
        &cyclic,
        "socket:4x10,distance:40",
        7,
        &["--effect", "joint-cyclic:2:0.002,-0.001:1"],
    );
    let model = dir.path().join("model.toml");
    let mut args = split.to_vec();
    args.extend_from_slice(&["--out", s(&model)]);
    let v = diagnose(&data, &args);
    println!("{v}");
    assert_eq!(v["count_unit"], "groups");
    // The keys of diagnose on tracker points: found in the order added, each with its
    // effect, joint, values and validation RMS.
    let found = v["found"].as_array().unwrap();
    assert_eq!(found.len(), 1, "{v}");
    assert_eq!(found[0]["effect"], "joint-cyclic");
    assert_eq!(found[0]["joint"], 2);
    assert_eq!(found[0]["request"], "joint-cyclic:2:1");
    let (a, b) = (
        found[0]["values"]["joint-cyclic2.n1.a"].as_f64().unwrap(),
        found[0]["values"]["joint-cyclic2.n1.b"].as_f64().unwrap(),
    );
    assert!(
        (a - 0.002).abs() < 2e-4 && (b + 0.001).abs() < 2e-4,
        "a = {a}, b = {b}"
    );
    // The held-out groups' gap shrinks to the noise (0.01 mm per contact).
    let h = &v["held_out"];
    let (geometric, extended) = (
        h["geometric_mm"].as_f64().unwrap(),
        h["extended_mm"].as_f64().unwrap(),
    );
    assert!(extended * 10.0 < geometric, "{h}");
    assert!(extended < 0.03, "{h}");
    assert_eq!(v["validation"], "held-out groups");
    assert_eq!(v["baseline_validation_rms_mm"], h["geometric_mm"]);
    assert_eq!(v["final_validation_rms_mm"], h["extended_mm"]);
    // Down to what the stated σ leaves.
    let floor = v["noise_floor_mm"].as_f64().unwrap();
    assert!(
        extended < 2.0 * floor && floor > 0.005,
        "{extended} mm, floor {floor} mm"
    );
    assert_eq!(v["held_out_worse"], false);
    // The model written carries the effect: identify on it starts at the noise.
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("joint-cyclic"), "{text}");
    // Geometry alone: nothing is found, the best candidate is named and refused.
    let plain = dir.path().join("plain");
    std::fs::create_dir(&plain).unwrap();
    let (data, _) = session(&plain, "socket:4x10,distance:40", 7);
    let w = diagnose(&data, &split);
    assert!(w["found"].as_array().unwrap().is_empty(), "{w}");
    let rounds = w["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 1, "{w}");
    assert_eq!(rounds[0]["accepted"], false);
    // Flags of tracker sessions are refused in one line.
    let out = kinecal(&[
        "diagnose",
        "--robot",
        s(&data_file("er20.toml")),
        "--data",
        s(&data),
        "--plots",
        s(dir.path()),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(stderr(&out).trim().lines().count(), 1, "{}", stderr(&out));
}
