//! Hardening of the command line: numbers from the user that size work or storage are
//! bounded before anything is allocated, joint numbers are checked against the robot, outputs
//! never replace inputs and are written atomically, implausible files are refused, and no
//! command exits 0 with a non-finite figure (docs/formats.md, "Exit status" and "Limits").

use crate::common::{kinecal, run_on, s, simulate, stderr, ur10_dir, write, ER20_PLACED};
use std::path::{Path, PathBuf};
use std::process::Output;

/// Exit 2 with one line on stderr that names `names`; no panic, no backtrace.
fn assert_refused(out: &Output, names: &str) {
    let e = stderr(out);
    assert_eq!(
        out.status.code(),
        Some(2),
        "expected exit 2 (refused); stderr: {e}"
    );
    assert!(e.contains(names), "the reason names {names}: {e}");
    assert!(e.starts_with("kinecal"), "kinecal: …: {e}");
    assert!(!e.contains("panicked") && !e.contains("backtrace"), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
}

/// A placed ER20 and `n` simulated poses of it (small: the tests refuse before fitting).
fn er20_data(dir: &Path, n: usize) -> (PathBuf, PathBuf) {
    let robot = write(dir, "robot.toml", ER20_PLACED);
    let data = dir.join(format!("data{n}.csv"));
    simulate(&robot, Some(n), Some(0.01), Some(3), &[], &data);
    (robot, data)
}

fn identify(robot: &Path, data: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["identify", "--robot", s(robot), "--data", s(data)];
    args.extend_from_slice(extra);
    kinecal(&args)
}

#[test]
fn joint_table_knot_spacing_is_bounded_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = er20_data(dir.path(), 30);
    // 1e-9° used to ask for terabytes (SIGABRT), 1e-300° wrapped to a 2-knot table (exit 0).
    for spacing in ["1e-9", "1e-300", "0.001", "0", "-3", "nan", "inf", "1e300"] {
        let effect = format!("joint-table:2:{spacing}");
        let out = identify(&robot, &data, &["--effect", &effect]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{effect}: refused; {}",
            stderr(&out)
        );
        assert!(!stderr(&out).contains("panicked"), "{}", stderr(&out));
    }
    // A spacing within bounds that still makes too many knots over the data's range.
    let out = identify(&robot, &data, &["--effect", "joint-table:1:0.1"]);
    assert_refused(&out, "knots");
}

#[test]
fn effects_on_a_joint_the_robot_lacks_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = er20_data(dir.path(), 30);
    for effect in [
        "joint-cyclic:7",
        "joint-cyclic:7:2",
        "joint-scale:9",
        "joint-compliance:7",
        "joint-table:7:5",
        "axis-tilt:7",
    ] {
        let out = identify(&robot, &data, &["--effect", effect]);
        assert_refused(&out, "6 joints");
        assert!(stderr(&out).contains(":7") || stderr(&out).contains(":9"));
    }
    // The cyclic order is bounded too.
    let out = identify(&robot, &data, &["--effect", "joint-cyclic:2:1e9"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    // simulate: the same joint check and bounded values.
    for effect in [
        "joint-cyclic:7:0.001,0.002",
        "joint-scale:2:1e300",
        "joint-cyclic:2:0.001,0.001:100000",
    ] {
        let out = kinecal(&[
            "simulate",
            "--robot",
            s(&robot),
            "--effect",
            effect,
            "--out",
            s(&dir.path().join("x.csv")),
        ]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{effect}: refused; {}",
            stderr(&out)
        );
    }
}

#[test]
fn implausible_robot_file_magnitudes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (_, data) = er20_data(dir.path(), 20);
    for (from, to) in [
        ("a_mm = ", "a_mm = 1e308 + 0 * "),
        ("d_mm = ", "d_mm = -1e9 + 0 * "),
    ] {
        // The first joint's value becomes huge (TOML has no arithmetic: rewrite the number).
        let text = ER20_PLACED.replacen(from, to, 1);
        let text = text
            .lines()
            .map(|l| match l.split_once(" + 0 * ") {
                Some((head, _)) => head.to_string(),
                None => l.to_string(),
            })
            .collect::<Vec<_>>()
            .join("\n");
        let robot = write(dir.path(), "big.toml", &text);
        let out = kinecal(&["check", "--robot", s(&robot), "--data", s(&data)]);
        assert_refused(&out, "implausible");
    }
}

#[test]
fn a_non_finite_result_never_exits_0() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = er20_data(dir.path(), 30);
    // One coordinate of 1e308 makes the residuals overflow.
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let x = header.iter().position(|c| *c == "x").unwrap();
    let mut row: Vec<String> = lines[5].split(',').map(str::to_string).collect();
    row[x] = "1e308".into();
    lines[5] = row.join(",");
    let huge = write(dir.path(), "huge.csv", &(lines.join("\n") + "\n"));
    for cmd in ["check", "identify"] {
        let out = kinecal(&[cmd, "--robot", s(&robot), "--data", s(&huge), "--json"]);
        assert_ne!(out.status.code(), Some(0), "{cmd}: {}", stderr(&out));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            !text.contains("null") || text.contains("\"error\""),
            "{text}"
        );
    }
}

#[test]
fn files_without_rows_are_refused_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = er20_data(dir.path(), 30);
    let empty = write(dir.path(), "empty.csv", "q1,q2,q3,q4,q5,q6,x,y,z\n");
    let out = identify(&robot, &data, &["--validate", s(&empty)]);
    assert_refused(&out, "empty.csv");
    for cmd in ["check", "identify", "diagnose"] {
        let out = kinecal(&[cmd, "--robot", s(&robot), "--data", s(&empty)]);
        assert_refused(&out, "empty.csv");
    }
    let out = kinecal(&[
        "diagnose",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--validate",
        s(&empty),
    ]);
    assert_refused(&out, "empty.csv");
}

#[test]
fn too_few_poses_for_the_model_are_refused_for_every_method() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = er20_data(dir.path(), 1);
    for method in ["lm", "pso", "bpnn-pso", "pso+lm"] {
        let out = identify(&robot, &data, &["--method", method]);
        assert_refused(&out, "at least");
    }
}

#[test]
fn compensation_inputs_are_bounded_and_failures_are_not_success() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20_PLACED);
    let targets = dir.path().join("t.csv");
    simulate(&robot, Some(3), Some(0.0), Some(5), &[], &targets);
    let text = std::fs::read_to_string(&targets).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut row: Vec<String> = lines[1].split(',').map(str::to_string).collect();
    row[0] = "1e300".into();
    lines[1] = row.join(",");
    let bad = write(dir.path(), "bad.csv", &(lines.join("\n") + "\n"));
    let out_csv = dir.path().join("q.csv");
    let out = kinecal(&[
        "compensate",
        "--model",
        s(&robot),
        "--targets",
        s(&bad),
        "--out",
        s(&out_csv),
    ]);
    assert_refused(&out, "q1");
    assert!(!out_csv.exists());
    // Unreachable targets (far outside the arm's reach) are not reported as success.
    let mut far: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<&str> = far[0].split(',').collect();
    let x = header.iter().position(|c| *c == "x").unwrap();
    let mut row: Vec<String> = far[1].split(',').map(str::to_string).collect();
    row[x] = "50000".into();
    far[1] = row.join(",");
    let far = write(dir.path(), "far.csv", &(far.join("\n") + "\n"));
    let out = kinecal(&[
        "compensate",
        "--model",
        s(&robot),
        "--targets",
        s(&far),
        "--out",
        s(&out_csv),
    ]);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    for bad_flag in [["--max-step-deg", "nan"], ["--accept-mm", "0"]] {
        let out = kinecal(&[
            "compensate",
            "--model",
            s(&robot),
            "--targets",
            s(&targets),
            "--out",
            s(&out_csv),
            bad_flag[0],
            bad_flag[1],
        ]);
        assert_refused(&out, bad_flag[0]);
    }
}

#[test]
fn counts_that_size_work_are_capped() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20_PLACED);
    let scene = write(
        dir.path(),
        "scene.toml",
        "[tracker]\nxyz_mm = [3000.0, 0.0, 500.0]\n",
    );
    let out_csv = dir.path().join("p.csv");
    for (flag, v) in [
        ("--poses", "100000"),
        ("--pool", "100000000"),
        ("--noise-mm", "nan"),
    ] {
        let poses = if flag == "--poses" { v } else { "10" };
        let mut args = vec![
            "plan",
            "--robot",
            s(&robot),
            "--scene",
            s(&scene),
            "--poses",
            poses,
            "--criterion",
            "d",
            "--work=0,30,10,0,-40,0",
            "--out",
            s(&out_csv),
        ];
        if flag != "--poses" {
            args.extend([flag, v]);
        }
        let out = kinecal(&args);
        assert_refused(&out, flag);
    }
    for (flag, v) in [
        ("--poses", "2000000"),
        ("--poses", "0"),
        ("--noise-mm", "inf"),
    ] {
        let out = kinecal(&[
            "simulate",
            "--robot",
            s(&robot),
            flag,
            v,
            "--out",
            s(&out_csv),
        ]);
        assert_refused(&out, flag);
    }
    let out = kinecal(&["study", "--upper-arm-mm", "650:1100:1e-300"]);
    assert_refused(&out, "--upper-arm-mm");
    let out = kinecal(&["study", "--poses", "100000"]);
    assert_refused(&out, "--poses");
}

#[test]
fn a_holdout_that_holds_out_nothing_or_a_fraction_of_a_pose_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = er20_data(dir.path(), 60);
    // 1e-300 of 60 poses rounds to none; 0.005 of 60 too; 1.5 poses is no count.
    for (h, names) in [
        ("1e-300", "holds out no pose of 60"),
        ("0.005", "holds out no pose of 60"),
        ("1.5", "whole number"),
        ("60", "leaves no poses to identify from"),
        ("1e300", "leaves no poses to identify from"),
    ] {
        let out = identify(&robot, &data, &["--holdout", h]);
        assert_refused(&out, names);
    }
    // A whole count and a fraction that holds out at least one pose are taken.
    for h in ["2", "2.0", "0.05"] {
        let out = identify(&robot, &data, &["--holdout", h]);
        assert_ne!(
            out.status.code(),
            Some(2),
            "--holdout {h}: {}",
            stderr(&out)
        );
    }
}

#[test]
fn one_pose_repeated_cannot_determine_a_model() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, data) = er20_data(dir.path(), 60);
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines = text.lines();
    let (header, first) = (lines.next().unwrap(), lines.next().unwrap());
    let same = write(
        dir.path(),
        "same.csv",
        &format!("{header}\n{}", format!("{first}\n").repeat(60)),
    );
    // The 59 copies are left out, and named; one pose is refused with its reason.
    let refused = |out: Output, names: &str| {
        let e = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{e}");
        let lines: Vec<&str> = e.trim_end().lines().collect();
        assert_eq!(lines.len(), 2, "{e}");
        assert!(lines[0].starts_with("warning:") && lines[0].contains("59 row(s) repeat"));
        assert!(
            lines[1].starts_with("kinecal:") && lines[1].contains(names),
            "{e}"
        );
    };
    // The base known: one distinct pose.
    refused(identify(&robot, &same, &[]), "1 poses to identify");
    // The base unknown: no placement from one point.
    let unplaced = write(
        dir.path(),
        "unplaced.toml",
        ER20_PLACED.split("[base]").next().unwrap(),
    );
    refused(
        identify(&unplaced, &same, &[]),
        "needs at least 3 points, got 1",
    );
}

#[test]
fn messages_escape_control_characters_and_stay_short() {
    let dir = tempfile::tempdir().unwrap();
    // A file name with an escape sequence and a carriage return, and one 5,000 characters long
    // (the messages quote both).
    let hostile = dir.path().join("robot\u{1b}[31mred\rover.toml");
    let out = kinecal(&["check", "--robot", s(&hostile), "--data", "nothing.csv"]);
    let e = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(
        !e.contains('\u{1b}') && !e.contains('\r'),
        "raw control bytes: {e:?}"
    );
    assert!(e.contains("\\u{1b}[31mred\\u{d}over.toml"), "escaped: {e}");
    let long = format!("{}.toml", "n".repeat(5000));
    let out = kinecal(&["check", "--robot", &long, "--data", "nothing.csv", "--json"]);
    let e = stderr(&out);
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(e.chars().count() < 1100, "{} characters", e.chars().count());
    assert!(e.contains("more characters"), "{e}");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(json["error"].as_str().unwrap().chars().count() < 1100);
}

#[test]
fn malformed_sweeps_and_working_configurations_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20_PLACED);
    // Two points cannot give a circle: a data problem (exit 2), not an internal error.
    let sweeps = write(
        dir.path(),
        "sweeps.csv",
        "q1,q2,q3,q4,q5,q6,x,y,z,sweep\n0,0,0,0,0,0,1,2,3,1\n1,0,0,0,0,0,1,2,3,1\n",
    );
    let out = kinecal(&["frames", "--robot", s(&robot), "--data", s(&sweeps)]);
    assert_refused(&out, "at least 4 per sweep");
    let no_column = write(
        dir.path(),
        "plain.csv",
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n",
    );
    let out = kinecal(&["frames", "--robot", s(&robot), "--data", s(&no_column)]);
    assert_refused(&out, "no `sweep` column");
    let out_csv = dir.path().join("plan.csv");
    for (work, names) in [
        ("1e308,0,0,0,0,0", "no joint angle"),
        ("0,0,0", "expected 6"),
        ("nan,0,0,0,0,0", "no joint angle"),
        ("x,0,0,0,0,0", "not a number"),
    ] {
        let out = kinecal(&[
            "plan",
            "--robot",
            s(&robot),
            "--poses",
            "30",
            "--criterion",
            "d",
            &format!("--work={work}"),
            "--out",
            s(&out_csv),
        ]);
        assert_refused(&out, names);
    }
}

/// `text` with every length of the robot file (`a_mm`, `d_mm`, `xyz_mm` of `[tool]` and
/// `[base]`) divided by 1000: the file a user wrote in metres.
fn in_metres(text: &str) -> String {
    let metres = |v: &str| (v.trim().parse::<f64>().unwrap() / 1000.0).to_string();
    text.lines()
        .map(|l| {
            let (key, value) = match l.split_once(" = ") {
                Some(kv) => kv,
                None => return l.to_string(),
            };
            match key.trim() {
                "a_mm" | "d_mm" => format!("{key} = {}", metres(value)),
                "xyz_mm" => {
                    let inner = value.trim().trim_start_matches('[').trim_end_matches(']');
                    let v: Vec<String> = inner.split(',').map(metres).collect();
                    format!("{key} = [{}]", v.join(", "))
                }
                _ => l.to_string(),
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_robot_file_in_metres_is_refused_by_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    let (mm, data) = er20_data(dir.path(), 30);
    let text = in_metres(ER20_PLACED);
    assert!(text.contains("d_mm = 0.504"), "{text}");
    let robot = write(dir.path(), "metres.toml", &text);
    // check and identify exited 0 (a tolerance warning at most) on a robot 1000× too small.
    for args in [
        vec!["check", "--robot", s(&robot), "--data", s(&data)],
        vec!["identify", "--robot", s(&robot), "--data", s(&data)],
        vec!["diagnose", "--robot", s(&robot), "--data", s(&data)],
        vec![
            "validate",
            "--robot",
            s(&mm),
            "--model",
            s(&robot),
            "--data",
            s(&data),
        ],
    ] {
        let out = kinecal(&args);
        assert_refused(&out, "metres");
        assert!(stderr(&out).contains("multiply"), "{}", stderr(&out));
    }
    // The same file in millimetres is read.
    let out = kinecal(&["check", "--robot", s(&mm), "--data", s(&data)]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

/// `diagnose` on too few poses for its folds' geometric fits: one line, exit 2, saying how many
/// it needs (it said `--folds 5: must be 2 to 3` to a user who gave no `--folds`, or exited 1
/// with `identification: TooFewMeasurements`).
#[test]
fn diagnose_on_too_few_poses_says_how_many_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv")).unwrap();
    let robot = ur10_dir().join("robot.toml");
    for n in [3, 10, 14] {
        let rows: Vec<&str> = text.lines().take(n + 1).collect();
        let data = write(dir.path(), &format!("n{n}.csv"), &(rows.join("\n") + "\n"));
        let out = run_on("diagnose", &robot, &data, &[]);
        assert_refused(&out, &format!("{n} poses are too few for diagnose"));
        assert!(stderr(&out).contains("at least 15"), "{}", stderr(&out));
    }
    // With the base in the robot file its 6 parameters are not fitted: 13 poses suffice.
    let placed = write(dir.path(), "placed.toml", ER20_PLACED);
    let d12 = dir.path().join("d12.csv");
    simulate(&placed, Some(12), Some(0.01), Some(1), &[], &d12);
    let out = run_on("diagnose", &placed, &d12, &[]);
    assert_refused(&out, "12 poses are too few for diagnose");
    assert!(stderr(&out).contains("at least 13"), "{}", stderr(&out));
    let rows: Vec<&str> = text.lines().take(41).collect();
    let data = write(dir.path(), "n40.csv", &(rows.join("\n") + "\n"));
    let out = run_on("diagnose", &robot, &data, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

/// Files a spreadsheet or an old tool writes, refused (exit 2) with what to do: lines ending
/// in a carriage return alone (was "line longer than 4096 bytes"), UTF-16 (was "line is not
/// UTF-8 text"), quoted numbers (was "not a number … '\"-179.999848\"'"), and no header line
/// (was "duplicate column in column -90.000210").
#[test]
fn files_in_a_form_kinecal_does_not_read_say_what_to_change() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = crate::common::ur10_dir().join("robot.toml");
    let clean =
        std::fs::read_to_string(crate::common::ur10_rows(d, "clean.csv", 300, |_, _| {})).unwrap();
    let utf16: Vec<u8> = [0xFF, 0xFE]
        .into_iter()
        .chain(clean.encode_utf16().flat_map(u16::to_le_bytes))
        .collect();
    let quoted: String = clean
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                format!("{l}\n")
            } else {
                let cells: Vec<String> = l.split(',').map(|c| format!("\"{c}\"")).collect();
                format!("{}\n", cells.join(","))
            }
        })
        .collect();
    let headless: String = clean.lines().skip(1).map(|l| format!("{l}\n")).collect();
    let cases: [(&str, Vec<u8>, &str); 4] = [
        (
            "cr.csv",
            clean.replace('\n', "\r").into_bytes(),
            "carriage return alone",
        ),
        ("utf16.csv", utf16, "save it as UTF-8"),
        (
            "quoted.csv",
            quoted.into_bytes(),
            "write the numbers without quotes",
        ),
        (
            "headless.csv",
            headless.into_bytes(),
            "the first line is numbers, not a header",
        ),
    ];
    for (name, bytes, says) in cases {
        let path = d.join(name);
        std::fs::write(&path, bytes).unwrap();
        let out = crate::common::run_on("check", &robot, &path, &[]);
        let err = crate::common::stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(err.contains(says), "{name}: {err}");
    }
}
