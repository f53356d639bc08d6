//! Hardening of the command line (issue 15): numbers from the user that size work or storage are
//! bounded before anything is allocated, joint numbers are checked against the robot, outputs
//! never replace inputs and are written atomically, implausible files are refused, and no
//! command exits 0 with a non-finite figure (docs/formats.md, "Exit status" and "Limits").

mod common;

use common::{kinecal, s, simulate, stderr, write, ER20_PLACED};
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
