//! A step along the rows' order (`cli/src/diagnose/row_step.rs`), against known truth: 300 UR10
//! rows whose second half was measured with the reflector moved on the flange, or with the
//! tracker moved, used to calibrate with exit 0 and a "noise floor" of the step's size, then
//! with exit 0 and a warning. Both commands now refuse the fit (exit 3: it took the mean of two
//! set-ups) naming the rows between which it happened and the frame it is fixed in; a
//! reflector creeping over five parts of the session is told as a creep (a warning); the same
//! robot in both halves draws no word.

use crate::common::*;
use std::path::{Path, PathBuf};

/// A session of `truth` for 150 rows, then of `truth` with `edit` applied to its text.
fn halves(dir: &Path, name: &str, truth: &Path, edit: impl Fn(&str) -> String) -> PathBuf {
    let text = std::fs::read_to_string(truth).unwrap();
    parts(dir, name, &[text.clone(), edit(&text)], 150)
}

/// Sessions of `rows` rows of each robot file text of `truths`, one after the other.
fn parts(dir: &Path, name: &str, truths: &[String], rows: usize) -> PathBuf {
    let mut all = String::new();
    for (k, t) in truths.iter().enumerate() {
        let (robot, data) = (
            dir.join(format!("part{k}.toml")),
            dir.join(format!("part{k}.csv")),
        );
        std::fs::write(&robot, t).unwrap();
        simulate(
            &robot,
            Some(rows),
            Some(0.02),
            Some(31 + k as u64),
            &[],
            &data,
        );
        let text = std::fs::read_to_string(data).unwrap();
        let skip = usize::from(k > 0);
        all.extend(text.lines().skip(skip).map(|l| format!("{l}\n")));
    }
    write(dir, name, &all)
}

/// `text` with the `xyz_mm` line after `[section]` replaced by `xyz`.
fn with_xyz(text: &str, section: &str, xyz: &str) -> String {
    let mut out = String::new();
    let mut inside = false;
    for line in text.lines() {
        if line.starts_with('[') {
            inside = line == section;
        }
        if inside && line.starts_with("xyz_mm") {
            out.push_str(&format!("xyz_mm = {xyz}\n"));
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

#[test]
fn a_moved_reflector_or_tracker_is_named_at_its_row() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let (base, truth) = (dir.path().join("base.csv"), dir.path().join("truth.toml"));
    simulate(
        &robot,
        Some(10),
        Some(0.02),
        Some(30),
        &["--geom-errors", "--truth", s(&truth)],
        &base,
    );
    let text = std::fs::read_to_string(&truth).unwrap();
    assert!(text.contains("[tool]") && text.contains("[base]"), "{text}");
    let tool = |t: &str, f: f64| {
        let line = t.lines().skip_while(|l| *l != "[tool]").nth(1).unwrap();
        let v: Vec<f64> = line
            .trim_start_matches("xyz_mm = [")
            .trim_end_matches(']')
            .split(',')
            .map(|x| x.trim().parse().unwrap())
            .collect();
        format!(
            "[{}, {}, {}]",
            v[0] + 0.8 * f,
            v[1] - 0.6 * f,
            v[2] + 0.5 * f
        )
    };
    let moved = tool(&text, 1.0);
    // A reflector creeping: a quarter of the move in each of five parts.
    let creeping: Vec<String> = (0..5)
        .map(|k| with_xyz(&text, "[tool]", &tool(&text, 0.25 * k as f64)))
        .collect();
    let cases = [
        (
            halves(dir.path(), "reflector.csv", &truth, |t| {
                with_xyz(t, "[tool]", &moved)
            }),
            Some("in the flange's axes: x 0.7"),
        ),
        (
            halves(dir.path(), "tracker.csv", &truth, |t| {
                with_xyz(t, "[base]", "[0.3, -0.2, 0.25]")
            }),
            Some("in the measurement frame: x 0.29"),
        ),
        (
            halves(dir.path(), "still.csv", &truth, str::to_string),
            None,
        ),
        (
            parts(dir.path(), "creeping.csv", &creeping, 60),
            Some("creep along the rows' order"),
        ),
    ];
    for (data, frame) in &cases {
        for command in ["identify", "diagnose"] {
            let out = run_on(command, &robot, data, &[]);
            let err = stderr(&out);
            // A step: the fit took the mean of two set-ups, no calibration (exit 3); a creep
            // and the same set-up throughout calibrate with exit 0.
            let step = frame.is_some_and(|f| !f.starts_with("creep"));
            let code = if step { 3 } else { 0 };
            assert_eq!(out.status.code(), Some(code), "{command}: {err}");
            assert_eq!(
                err.contains("error: the") && err.contains("took the mean of two set-ups"),
                step,
                "{command}: {err}"
            );
            match frame {
                Some(f) if f.starts_with("creep") => assert!(
                    err.contains(f) && err.contains("in the flange's axes: x 0."),
                    "{command}: {err}"
                ),
                Some(f) => assert!(
                    err.contains("the residuals step by")
                        && err.contains("between lines 151 and 152")
                        && err.contains(f),
                    "{command} {}: {err}",
                    data.display()
                ),
                None => assert!(!err.contains("step"), "{command}: {err}"),
            }
        }
    }
}

/// Joint 2 re-mastered by +0.5° after 150 of 300 UR10 rows: no step of one vector in either
/// frame, so nothing was said (identify 3.66 mm RMS at 0.02 mm noise, exit 0; diagnose took
/// what was left for noise). Both name the joint, the change within 5 % and the rows now
/// (`cli/src/diagnose/zero_step.rs`); the same robot in both halves and the real UR10 session
/// draw no such word.
#[test]
fn a_joint_re_mastered_mid_file_is_named_at_its_row() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let (base, truth) = (dir.path().join("base.csv"), dir.path().join("truth.toml"));
    let t = s(&truth);
    simulate(
        &robot,
        Some(10),
        Some(0.02),
        Some(30),
        &["--geom-errors", "--truth", t],
        &base,
    );
    let remaster = |text: &str| {
        let mut f: kinecal_cli::formats::robot_file::RobotFile = toml::from_str(text).unwrap();
        f.joints[1].theta_deg += 0.5;
        toml::to_string(&f).unwrap()
    };
    let remastered = halves(dir.path(), "remastered.csv", &truth, remaster);
    let still = halves(dir.path(), "still.csv", &truth, str::to_string);
    let real = ur10_dir().join("ur10_random_poses.csv");
    for command in ["identify", "diagnose"] {
        let err = stderr(&run_on(command, &robot, &remastered, &[]));
        let named = err
            .lines()
            .find(|l| l.contains("as joint 2's zero changing by"))
            .unwrap_or_else(|| panic!("{command}: {err}"));
        let deg: f64 = named
            .split("changing by ")
            .nth(1)
            .and_then(|r| r.split('°').next())
            .and_then(|v| v.parse().ok())
            .unwrap();
        assert!((deg - 0.5).abs() < 0.025, "{command}: {named}");
        assert!(
            named.contains("between lines 151 and 152"),
            "{command}: {named}"
        );
        for data in [&still, &real] {
            let err = stderr(&run_on(command, &robot, data, &[]));
            assert!(
                !err.contains("zero changing"),
                "{command} {}: {err}",
                data.display()
            );
        }
    }
}

/// Random poses, nothing happening at any row, and an effect the geometry misses (joint 1's
/// error repeating 30 times a turn, ±0.013°, on the KR16 an outside tester imported from its
/// public URDF): the residuals are structured along joint 1's column, and a test that took
/// their scatter from all three coordinates named "joint 1's zero changed between lines 141
/// and 142" at seed 62 (p = 7e-8; the rows shuffled, no word). Judged by the scatter of the
/// projections themselves, no seed of 30 draws a word.
#[test]
fn structured_residuals_of_random_poses_are_no_re_mastering() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = data_file("kr16_urdf.toml");
    let mut named = Vec::new();
    for seed in 60..90 {
        let data = d.join(format!("s{seed}.csv"));
        let cyclic = [
            "--geom-errors",
            "--effect",
            "joint-cyclic:1:0.0002,0.0001:30",
        ];
        simulate(&robot, Some(150), Some(0.01), Some(seed), &cyclic, &data);
        let out = run_on("diagnose", &robot, &data, &["--max-effects", "0"]);
        if stderr(&out).contains("zero changing") {
            named.push(seed);
        }
    }
    assert!(named.is_empty(), "seeds {named:?} named a zero step");
}

/// A short file: 40 KR16 rows, joint 2 re-mastered by 0.2° after row 20. The projections'
/// own scatter with the step in it capped the test's statistic near the rows' count, and no
/// step could be named in a file this short (the newcomer's review); with the zero and its
/// change fitted first, identify and diagnose name joint 2 and a change within 15 % of the
/// reading's (the geometry takes a share of it on 40 poses).
#[test]
fn a_re_mastering_in_a_short_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = data_file("kr16_urdf.toml");
    let data = d.join("b40.csv");
    simulate(
        &robot,
        Some(40),
        Some(0.02),
        Some(3),
        &["--geom-errors"],
        &data,
    );
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines = text.lines();
    let head = lines.next().unwrap();
    let q2 = head.split(',').position(|c| c == "q2").unwrap();
    let mut out = String::from(head) + "\n";
    for (k, line) in lines.enumerate() {
        let mut cells: Vec<String> = line.split(',').map(String::from).collect();
        if k >= 20 {
            cells[q2] = format!("{}", cells[q2].parse::<f64>().unwrap() + 0.2);
        }
        out.push_str(&(cells.join(",") + "\n"));
    }
    let stepped = write(d, "rm40.csv", &out);
    for command in ["identify", "diagnose"] {
        let err = stderr(&run_on(command, &robot, &stepped, &[]));
        let at = err.find("joint 2's zero changing by ").expect(&err);
        let size: f64 = err[at + 27..].split('°').next().unwrap().parse().unwrap();
        assert!(
            (size.abs() / 0.2 - 1.0).abs() < 0.15,
            "{command}: {size}: {err}"
        );
        assert!(err.contains("between lines 21 and 22"), "{command}: {err}");
    }
}

/// A tracker drifting along z (the measurement frame) over 600 rows of the UR10 series C, whose
/// tool orientations vary little: projected into the flange's axes the drift also trends, and
/// `diagnose` called it a creeping reflector ("the measured point moves on the arm") although
/// the measurement frame explains more of it. It is now told as the drift it is; the same rows
/// without the added drift keep the series' own, smaller drift (also the measurement frame's).
#[test]
fn a_drifting_tracker_is_not_called_a_creeping_reflector() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let n = 600;
    for drift_mm in [0.0, 1.0] {
        let data = ur10_rows(dir.path(), "drift.csv", n, |i, cells| {
            let z: f64 = cells[8].parse().unwrap();
            cells[8] = format!("{:.5}", z + drift_mm * i as f64 / (n - 1) as f64);
        });
        let err = stderr(&run_on("diagnose", &robot, &data, &[]));
        assert!(
            err.contains("the residuals drift along the rows' order")
                && err.contains("a tracker or a base that moved")
                && !err.contains("creep along"),
            "{drift_mm} mm: {err}"
        );
    }
}
