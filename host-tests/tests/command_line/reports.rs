//! The typed reports (`kinecal_cli::reports`): the JSON a command prints is its report's
//! serialisation, the text and the JSON of one report show the same numbers, and a failing
//! command prints `{"error": …}` with `--json`, with the exit status of the failure.

use kinecal_cli::compensation::{self, Job};
use kinecal_cli::diagnose::{diagnose, Config};
use kinecal_cli::formats::measurements;
use kinecal_cli::formats::robot_file::load_robot;
use kinecal_cli::frames;
use kinecal_cli::output::numfmt::sig;
use kinecal_cli::reports::{DiagnoseReport, Report};
use kinecal_cli::simulation::sweeps::sweep_data;
use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common::{data_file, kinecal, s, simulate, stderr};

/// The keys whose values are wall-clock times.
const TIMES: [&str; 3] = ["seconds", "geometry_seconds", "microseconds_per_target"];

/// `a` and `b` have the same keys, arrays, strings and flags at every depth, and the same
/// numbers to the last few bits: the binary and this test are compiled separately, and a value
/// can differ in its last bit between the two builds. Times are not compared.
fn assert_same_report(a: &serde_json::Value, b: &serde_json::Value, at: &str) {
    use serde_json::Value::*;
    match (a, b) {
        (Object(x), Object(y)) => {
            let (kx, ky): (Vec<_>, Vec<_>) = (x.keys().collect(), y.keys().collect());
            assert_eq!(kx, ky, "keys at {at}");
            for (k, v) in x {
                if !TIMES.contains(&k.as_str()) {
                    assert_same_report(v, &y[k], &format!("{at}/{k}"));
                }
            }
        }
        (Array(x), Array(y)) => {
            assert_eq!(x.len(), y.len(), "length at {at}");
            for (i, (u, w)) in x.iter().zip(y).enumerate() {
                assert_same_report(u, w, &format!("{at}/{i}"));
            }
        }
        (Number(x), Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(y.abs()).max(1e-300),
                "{at}: {x} vs {y}"
            );
        }
        _ => assert_eq!(a, b, "at {at}"),
    }
}

/// Stdout as exactly one JSON object.
fn one_object(out: &Output) -> serde_json::Value {
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("stdout is one JSON object ({e}): {text}"));
    assert!(v.is_object(), "{text}");
    v
}

/// 60 noisy poses of the placed ER20 with geometric errors and a compliant joint 2, and the
/// true model.
fn simulated(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let robot = data_file("er20_placed.toml");
    let data = dir.join("d.csv");
    let truth = dir.join("t.toml");
    simulate(
        &robot,
        Some(60),
        Some(0.02),
        Some(3),
        &[
            "--geom-errors",
            "--effect",
            "joint-compliance:2:2e-4",
            "--truth",
            s(&truth),
        ],
        &data,
    );
    (robot, data, truth)
}

#[test]
fn json_errors_are_one_object_with_the_reason_and_the_status() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data, _) = simulated(dir.path());
    let missing = dir.path().join("missing.csv");
    let unwritable = dir.path().join("no-such-dir").join("m.toml");
    // (arguments, exit status): refused input, an unreadable file (refused: the user must fix
    // it), an option value outside its range (refused, like clap's own usage errors), and an
    // error that is not the input's (an output that cannot be written: exit 1).
    let cases: [(Vec<&str>, i32); 4] = [
        (
            vec![
                "identify",
                "--robot",
                s(&robot),
                "--data",
                s(&data),
                "--fix",
                "nonsense",
            ],
            2,
        ),
        (
            vec!["check", "--robot", s(&robot), "--data", s(&missing)],
            2,
        ),
        (
            vec![
                "identify",
                "--robot",
                s(&robot),
                "--data",
                s(&data),
                "--holdout",
                "500",
            ],
            2,
        ),
        (
            vec![
                "identify",
                "--robot",
                s(&robot),
                "--data",
                s(&data),
                "--out",
                s(&unwritable),
            ],
            1,
        ),
    ];
    for (args, status) in cases {
        let text = kinecal(&args);
        let json = kinecal(&[&args[..], &["--json"]].concat());
        assert_eq!(
            text.status.code(),
            Some(status),
            "{args:?}: {}",
            stderr(&text)
        );
        assert_eq!(json.status.code(), Some(status), "{args:?} --json");
        // Text mode: nothing on stdout; both: the one `kinecal: …` line on stderr.
        assert!(text.stdout.is_empty(), "{args:?}");
        assert_eq!(stderr(&text), stderr(&json));
        let line = stderr(&json);
        let lines: Vec<&str> = line.lines().collect();
        assert_eq!(lines.len(), 1, "{line}");
        let v = one_object(&json);
        assert_eq!(v.as_object().unwrap().len(), 1, "{v}");
        assert_eq!(
            Some(v["error"].as_str().unwrap()),
            lines[0].strip_prefix("kinecal: "),
            "{v}"
        );
    }
    // The missing file is named.
    let v = one_object(&kinecal(&[
        "check",
        "--robot",
        s(&robot),
        "--data",
        s(&missing),
        "--json",
    ]));
    assert!(v["error"].as_str().unwrap().contains("missing.csv"), "{v}");
}

#[test]
fn not_converged_prints_the_report_and_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data, _) = simulated(dir.path());
    let args = [
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--stall-rms-mm",
        "0.0001",
        "--json",
    ];
    let out = kinecal(&args);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let v = one_object(&out);
    assert_eq!(v["converged"], false);
    assert!(v.get("error").is_none());
    let text = kinecal(&args[..args.len() - 1]);
    assert_eq!(text.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&text.stdout).starts_with("method lm:"));
}

/// `identify`'s text shows the RMS figures of its JSON (to four significant digits).
#[test]
fn identify_text_and_json_agree_on_the_rms() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data, _) = simulated(dir.path());
    let args = [
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--holdout",
        "15",
    ];
    let text = kinecal(&args);
    assert!(text.status.success(), "{}", stderr(&text));
    let text = String::from_utf8(text.stdout).unwrap();
    let v = one_object(&kinecal(&[&args[..], &["--json"]].concat()));
    for k in ["before", "after"] {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(k))
            .unwrap_or_else(|| panic!("no {k} line in:\n{text}"));
        let cells: Vec<&str> = line.split_whitespace().collect();
        let o = &v[k];
        let want: Vec<String> = [
            "identification_rms_mm",
            "validation_rms_mm",
            "validation_mean_mm",
            "validation_max_mm",
        ]
        .iter()
        .map(|key| sig(o[key].as_f64().unwrap(), 4))
        .collect();
        assert_eq!(cells[1..], want[..], "{line} vs {o}");
    }
    assert_eq!(v["n_validation"], 15);
}

/// Sweeps of joints 1, 2, 5 and 6 of the robot file `robot`, written to `dir/sw.csv`.
fn write_sweeps(robot: &std::path::Path, dir: &std::path::Path) -> std::path::PathBuf {
    let (_, nominal) = load_robot::<6>(robot).unwrap();
    let sweeps = sweep_data(
        &nominal,
        &[20.0, 10.0, -10.0, 0.0, 20.0, 0.0],
        &[1, 2, 5, 6],
        24,
        360.0,
        0.002,
        3,
    )
    .unwrap();
    let csv = dir.join("sw.csv");
    measurements::write(&csv, &sweeps).unwrap();
    csv
}

/// The same report, in-process: `frames`' text shows the base and tool of its JSON.
#[test]
fn frames_text_and_json_are_the_same_report() {
    let dir = tempfile::tempdir().unwrap();
    let robot_path = data_file("er20_placed.toml");
    let csv = write_sweeps(&robot_path, dir.path());
    let r = frames::from_files(&robot_path, &csv, &Default::default(), None).unwrap();
    let text = r.to_string();
    let json = r.to_json();
    let four = |v: &serde_json::Value| {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| format!("{:.4}", x.as_f64().unwrap()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    assert!(text.contains(&format!("xyz_mm = [{}]", four(&json["base"]["xyz_mm"]))));
    assert!(text.contains(&format!("rpy_deg = [{}]", four(&json["base"]["rpy_deg"]))));
    let axial = json["tool_axial_mm"].as_f64().unwrap();
    assert_eq!(axial, r.tool_axial_mm.unwrap());
    assert!(
        text.contains(&format!("axial (d_N + tool z) {axial:.3} mm")),
        "{text}"
    );
    assert_eq!(json["circles"].as_array().unwrap().len(), r.circles.len());
}

/// The JSON `kinecal frames`, `compensate` and `diagnose` print is the serialisation of the
/// typed report the application functions return (times aside), key for key.
#[test]
fn command_json_is_the_typed_report() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data, truth) = simulated(dir.path());

    // frames
    let csv = write_sweeps(&robot, dir.path());
    let typed = frames::from_files(&robot, &csv, &Default::default(), None).unwrap();
    let cli = one_object(&kinecal(&[
        "frames",
        "--robot",
        s(&robot),
        "--data",
        s(&csv),
        "--json",
    ]));
    assert_same_report(&cli, &serde_json::to_value(&typed).unwrap(), "frames");

    // compensate
    let out = dir.path().join("q.csv");
    let typed = compensation::run(&Job::new(&truth, &data, &out)).unwrap();
    let cli = one_object(&kinecal(&[
        "compensate",
        "--model",
        s(&truth),
        "--targets",
        s(&data),
        "--out",
        s(&out),
        "--json",
    ]));
    assert_same_report(&cli, &typed.to_json(), "compensate");
    assert!(cli.get("status").unwrap().is_object());

    // diagnose: the report of the application's diagnosis with the command's defaults
    let (file, nominal) = load_robot::<6>(&robot).unwrap();
    let ds = measurements::load::<6>(&data)
        .unwrap()
        .measurements::<f64>();
    let d = diagnose(
        &nominal,
        file.base_known(),
        &file.tilt_joints(),
        &ds,
        &Config::default(),
    )
    .unwrap();
    let typed = DiagnoseReport::of(&d).with_explanations(&d, &ds);
    let cli = one_object(&kinecal(&[
        "diagnose",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--json",
    ]));
    assert_same_report(&cli, &typed.to_json(), "diagnose");
    for key in [
        "baseline_validation_rms_mm",
        "found",
        "final_validation_rms_mm",
        "noise_floor_mm",
    ] {
        assert!(cli.get(key).is_some(), "missing {key}");
    }
    assert_eq!(typed.found.len(), 1);
    assert_eq!(typed.found[0].effect, "joint-compliance");
    // Each finding explained in words (the `explanation` object).
    let e = &cli["found"][0]["explanation"];
    for key in [
        "peak_to_peak_deg",
        "amplitude_deg",
        "tool_rms_mm",
        "tool_max_mm",
        "period_deg",
        "most_affected_poses",
        "most_affected_range_deg",
        "gap_closed",
        "text",
    ] {
        assert!(e.get(key).is_some(), "missing explanation.{key}");
    }
    assert!(e["period_deg"].is_null());
}
