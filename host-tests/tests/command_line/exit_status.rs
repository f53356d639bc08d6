//! Exit status 2 for every input the user must fix, whichever file it is: a robot, measurement
//! or cell file that cannot be read, and a cell file that is malformed or describes no valid
//! cell (docs/formats.md, "Exit status").

use crate::common::{kinecal, s, stderr, write, ER20_PLACED};
use std::path::Path;

fn assert_refused(out: &std::process::Output, names: &str) {
    assert_eq!(
        out.status.code(),
        Some(2),
        "expected exit 2 (refused); stderr: {}",
        stderr(out)
    );
    let e = stderr(out);
    assert!(e.contains(names), "the reason names {names}: {e}");
    assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
}

#[test]
fn unreadable_inputs_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20_PLACED);
    let missing = dir.path().join("no_such.csv");
    let out = kinecal(&["check", "--robot", s(&robot), "--data", s(&missing)]);
    assert_refused(&out, "no_such.csv");
    assert!(stderr(&out).contains("no such file: check the path"));
    // A folder where a file belongs: named, with what to do.
    for command in ["check", "identify", "diagnose"] {
        let out = kinecal(&[command, "--robot", s(&robot), "--data", s(dir.path())]);
        assert_refused(&out, "a folder: give the file in it");
    }

    let missing_robot = dir.path().join("no_such_robot.toml");
    let out = kinecal(&["check", "--robot", s(&missing_robot), "--data", s(&missing)]);
    assert_refused(&out, "no_such_robot.toml");
}

/// `kinecal plan` with the cell file `scene`.
fn plan_with_scene_file(dir: &Path, scene: &Path) -> std::process::Output {
    let robot = write(dir, "robot.toml", ER20_PLACED);
    let out = dir.join("plan.csv");
    kinecal(&[
        "plan",
        "--robot",
        s(&robot),
        "--scene",
        s(scene),
        "--poses",
        "10",
        "--criterion",
        "d",
        "--work",
        "0,30,10,0,-40,0",
        "--out",
        s(&out),
    ])
}

/// `kinecal plan` with a cell file holding `scene_text`.
fn plan_with_scene(dir: &Path, scene_text: &str) -> std::process::Output {
    plan_with_scene_file(dir, &write(dir, "scene.toml", scene_text))
}

#[test]
fn malformed_or_invalid_cell_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // Not TOML.
    let out = plan_with_scene(dir.path(), "[tracker\nxyz_mm = [1, 2, 3]\n");
    assert_refused(&out, "scene.toml");
    // Valid TOML, impossible tracker.
    let out = plan_with_scene(
        dir.path(),
        "[tracker]\nxyz_mm = [3000.0, 0.0, 500.0]\nmax_incidence_deg = 0.0\nbeam_radius_mm = 5.0\n",
    );
    assert_refused(&out, "max_incidence_deg");
    // Missing file.
    let out = plan_with_scene_file(dir.path(), &dir.path().join("absent_scene.toml"));
    assert_refused(&out, "absent_scene.toml");
}

/// A reader that closes the pipe early (`kinecal check … | head -0`) ends the program quietly
/// with its usual status, text or JSON: no panic message, no backtrace.
#[test]
fn a_closed_stdout_pipe_ends_quietly() {
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20_PLACED);
    let data = dir.path().join("data.csv");
    crate::common::simulate(&robot, Some(30), Some(0.01), Some(1), &[], &data);
    for json in [false, true] {
        let mut cmd = Command::new(crate::common::bin());
        cmd.args(["check", "--robot", s(&robot), "--data", s(&data)]);
        if json {
            cmd.arg("--json");
        }
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take()); // the reader is gone before the report is written
        let out = child.wait_with_output().unwrap();
        let err = stderr(&out);
        assert!(!err.contains("panicked"), "json {json}: {err}");
        assert_eq!(out.status.code(), Some(0), "json {json}: {err}");
    }
}
