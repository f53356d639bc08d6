//! `identify --effect base-drift` on a tracker file with a `t_s` column: a simulated session of
//! an hour whose tracker drifts (0.22 mm per hour) gives the drift back, the held-out poses
//! reach the noise floor with the term and stay well above it without, and the model written
//! leaves the drift out (it is the session's, not the arm's). What cannot be right is refused.

use crate::common::*;

/// The true drift, mm per second along the measurement frame's x, y, z.
const DRIFT: [f64; 3] = [5e-5, -3e-5, 2e-5];

fn drifting_session(dir: &std::path::Path, robot: &std::path::Path) -> std::path::PathBuf {
    let data = dir.join("drift.csv");
    kinecal_ok(&[
        "simulate",
        "--robot",
        s(robot),
        "--poses",
        "400",
        "--noise-mm",
        "0.01",
        "--seed",
        "23",
        "--geom-errors",
        "--session-s",
        "3600",
        "--effect",
        &format!("base-drift:0:{},{},{}", DRIFT[0], DRIFT[1], DRIFT[2]),
        "--out",
        s(&data),
    ]);
    data
}

#[test]
fn a_drifting_tracker_is_fitted_from_the_rows_times_and_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = drifting_session(dir.path(), &robot);
    let text = std::fs::read_to_string(&data).unwrap();
    assert!(text.lines().next().unwrap().ends_with(",t_s"), "{text}");
    assert!(text.lines().last().unwrap().ends_with(",3600"), "{text}");
    // Every 5th pose held out: the session's times on both sides.
    let split = ["--json", "--holdout", "0.2", "--split", "every:5"];
    let plain = json_of(&run_on("identify", &robot, &data, &split));
    let model = dir.path().join("model.toml");
    let mut with_term = split.to_vec();
    with_term.extend(["--effect", "base-drift", "--out", s(&model)]);
    let v = json_of(&run_on("identify", &robot, &data, &with_term));
    assert_eq!(v["converged"], true, "{v}");
    let fitted: Vec<f64> = ["vx", "vy", "vz"]
        .iter()
        .map(|a| v["parameters"][format!("base-drift.{a}")].as_f64().unwrap())
        .collect();
    let held = |v: &serde_json::Value| v["after"]["validation_rms_mm"].as_f64().unwrap();
    let floor = 0.01 * 3f64.sqrt();
    eprintln!(
        "tracker drifting {DRIFT:?} mm/s: fitted {fitted:?}; held-out RMS {} mm without the \
         term, {} mm with it (floor {floor:.4})",
        held(&plain),
        held(&v)
    );
    // The session's 3,600 s tell the velocity within 2 % (0.01 mm noise over 400 poses).
    let err: f64 = fitted
        .iter()
        .zip(DRIFT)
        .map(|(f, t)| (f - t).powi(2))
        .sum::<f64>()
        .sqrt();
    let speed: f64 = DRIFT.iter().map(|t| t * t).sum::<f64>().sqrt();
    assert!(err < 0.02 * speed, "{fitted:?} vs {DRIFT:?}");
    let unidentifiable = v["unidentifiable"].as_array().unwrap();
    assert!(
        !unidentifiable
            .iter()
            .any(|n| n.as_str().unwrap().starts_with("base-drift")),
        "{v}"
    );
    assert!(held(&v) < 1.2 * floor, "{v}");
    assert!(held(&plain) > 2.0 * held(&v), "{plain}");
    // The model written has no drift, and reads back.
    let written = std::fs::read_to_string(&model).unwrap();
    assert!(!written.contains("base-drift"), "{written}");
    let back = run_on("check", &model, &data, &[]);
    assert!(back.status.success(), "{}", stderr(&back));
}

#[test]
fn a_drift_that_cannot_be_right_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    // No t_s column: nothing to fit a drift to.
    let still = dir.path().join("still.csv");
    kinecal_ok(&[
        "simulate",
        "--robot",
        s(&robot),
        "--poses",
        "60",
        "--seed",
        "2",
        "--noise-mm",
        "0.02",
        "--out",
        s(&still),
    ]);
    let out = run_on("identify", &robot, &still, &["--effect", "base-drift"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("t_s"), "{}", stderr(&out));
    // On a joint, or with an argument.
    for bad in ["base-drift:2", "base-drift:0:5"] {
        let out = run_on("identify", &robot, &still, &["--effect", bad]);
        assert_eq!(out.status.code(), Some(2), "{bad}: {}", stderr(&out));
    }
    // A robot file that carries a drift: it belongs to a session, not to a robot.
    let text = std::fs::read_to_string(&robot).unwrap();
    let drifting = dir.path().join("drifting.toml");
    std::fs::write(
        &drifting,
        format!(
            "{text}\n[[effects]]\nkind = \"base-drift\"\njoint = 0\nvalues = [0.0, 0.0, 0.0]\n"
        ),
    )
    .unwrap();
    let out = run_on("check", &drifting, &still, &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--effect base-drift"),
        "{}",
        stderr(&out)
    );
    // A simulated drift needs the rows' times.
    let out = kinecal(&[
        "simulate",
        "--robot",
        s(&robot),
        "--poses",
        "10",
        "--effect",
        "base-drift:0:1e-5,0,0",
        "--out",
        s(&dir.path().join("x.csv")),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    // A time cell that is no time.
    let mut rows: Vec<String> = std::fs::read_to_string(drifting_session(dir.path(), &robot))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    let last = rows.len() - 1;
    rows[last] = format!("{},1e300", rows[last].rsplit_once(',').unwrap().0);
    let broken = dir.path().join("broken.csv");
    std::fs::write(&broken, rows.join("\n")).unwrap();
    let out = run_on("identify", &robot, &broken, &["--effect", "base-drift"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("t_s"), "{}", stderr(&out));
}

/// A `--validate` file is another session with its own clock: the drift fitted to this
/// session is not applied to it (the times would otherwise put it hours away from this
/// session's reference time).
#[test]
fn the_drift_is_not_carried_to_another_session() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let session = |name: &str, seed: &str, effect: Option<String>| {
        let path = dir.path().join(name);
        let mut args = vec![
            "simulate",
            "--robot",
            s(&robot),
            "--poses",
            "300",
            "--noise-mm",
            "0.01",
            "--seed",
            seed,
            "--session-s",
            "3600",
            // The same arm in both sessions (not seed-dependent): a joint-2 cyclic error.
            "--effect",
            "joint-cyclic:2:0.0004,-0.0002",
            "--out",
            s(&path),
        ];
        let effect = effect.unwrap_or_default();
        if !effect.is_empty() {
            args.extend(["--effect", effect.as_str()]);
        }
        kinecal_ok(&args);
        path
    };
    let drift = format!("base-drift:0:{},{},{}", DRIFT[0], DRIFT[1], DRIFT[2]);
    let first = session("first.csv", "5", Some(drift));
    let next = session("next.csv", "6", None);
    let v = json_of(&run_on(
        "identify",
        &robot,
        &first,
        &[
            "--json",
            "--effect",
            "base-drift",
            "--effect",
            "joint-cyclic:2",
            "--validate",
            s(&next),
        ],
    ));
    let held = v["after"]["validation_rms_mm"].as_f64().unwrap();
    let floor = 0.01 * 3f64.sqrt();
    eprintln!("next session: held-out RMS {held} mm (floor {floor:.4})");
    // The fitted drift applied at the next session's times (0 … 3,600 s from a reference of
    // 1,800 s) would move its poses by up to 0.11 mm.
    assert!(held < 1.2 * floor, "{v}");
}

/// `--fix base-drift` holds the whole term (the group has no joint number).
#[test]
fn the_drift_is_a_parameter_group() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = drifting_session(dir.path(), &robot);
    let v = json_of(&run_on(
        "identify",
        &robot,
        &data,
        &["--json", "--effect", "base-drift", "--fix", "base-drift"],
    ));
    for a in ["vx", "vy", "vz"] {
        assert_eq!(v["parameters"][format!("base-drift.{a}")], 0.0, "{v}");
    }
}

/// `diagnose` on the command line names the drift of a tracker from the rows' times and exits
/// 0: the finding turns no joint (`explanation.peak_to_peak_deg` null), its size is at the tool.
#[test]
fn diagnose_names_the_drift_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = drifting_session(dir.path(), &robot);
    // "The tracker drifted …" begins the finding's sentence.
    assert_diagnose_names_without_angle(&robot, &data, "base-drift", "racker drifted against");
}

/// `t_s` in milliseconds, hours or minutes read as seconds: the drift came out 1000× too small
/// or 3600× or 60× too large with exit 0 and no word. The rows' pace (400 poses over 41 days,
/// over a second, or 0.15 s from one pose of the arm to the next) is now warned about, naming
/// the unit; the session as simulated (9 s a pose) is not.
#[test]
fn a_time_column_in_another_unit_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = drifting_session(dir.path(), &robot);
    let text = std::fs::read_to_string(&data).unwrap();
    let scaled = |name: &str, factor: f64| {
        let mut out = String::new();
        for (i, l) in text.lines().enumerate() {
            let (rest, t) = l.rsplit_once(',').unwrap();
            let t = if i == 0 {
                t.to_string()
            } else {
                format!("{}", t.parse::<f64>().unwrap() * factor)
            };
            out += &format!("{rest},{t}\n");
        }
        write(dir.path(), name, &out)
    };
    let drift = ["--effect", "base-drift"];
    let right = run_on("identify", &robot, &data, &drift);
    assert_eq!(right.status.code(), Some(0), "{}", stderr(&right));
    assert!(
        !stderr(&right).contains("t_s advances"),
        "{}",
        stderr(&right)
    );
    for (name, factor, unit) in [
        ("ms.csv", 1000.0, "milliseconds"),
        ("hours.csv", 1.0 / 3600.0, "hours"),
        ("minutes.csv", 1.0 / 60.0, "minutes"),
        // A pose every 27 s logged in minutes: 0.45 "s" apart over 3 "minutes".
        ("slow_minutes.csv", 3.0 / 60.0, "minutes"),
        // A pose every 96 s (300 poses over eight hours) logged in minutes: 1.6 "s" apart,
        // which passed as seconds.
        ("slower_minutes.csv", 96.0 / 9.0 / 60.0, "minutes"),
    ] {
        let out = run_on("identify", &robot, &scaled(name, factor), &drift);
        let err = stderr(&out);
        assert!(
            err.contains("t_s advances a median of") && err.contains(unit),
            "{name}: {err}"
        );
    }
}
