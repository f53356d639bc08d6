//! What the decimals of a measurement file say (cli/src/formats/computed_points.rs): points that
//! are the robot file's own model at every pose (a controller's TCP columns mapped as the
//! tracker's) are refused by every command that reads measurements, and joints written with
//! too few decimals are warned about, or refused when the rounding rivals the nominal model's
//! own error. Both used to "calibrate" with exit 0 (the computed points to nanometres, the
//! rounded joints to a noise floor of millimetres).

use crate::common::*;
use std::path::Path;

/// The rows of `csv` (kinecal's layout) with each joint reading rewritten by `q` and each
/// coordinate by `xyz`.
fn rewritten(csv: &Path, q: impl Fn(f64) -> String, xyz: impl Fn(f64) -> String) -> String {
    let text = std::fs::read_to_string(csv).unwrap();
    edit_rows(&text, |cells| {
        for (k, c) in cells.iter_mut().enumerate().take(9) {
            let v: f64 = c.parse().unwrap();
            *c = if k < 6 { q(v) } else { xyz(v) };
        }
    })
}

#[test]
fn points_computed_from_the_joints_are_refused_by_every_command_that_reads_measurements() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    // No errors, no noise: x, y, z are the robot file's own forward kinematics.
    let fk = dir.path().join("fk.csv");
    simulate(&robot, Some(40), Some(0.0), Some(3), &[], &fk);
    // As a controller writes its TCP: millimetres with 3 decimals, joints with 4.
    let tcp = write(
        dir.path(),
        "tcp.csv",
        &rewritten(&fk, |v| format!("{v:.4}"), |v| format!("{v:.3}")),
    );
    for data in [&fk, &tcp] {
        for command in ["check", "identify", "diagnose", "validate"] {
            let mut extra = vec![];
            if command == "validate" {
                extra.extend(["--model", s(&robot)]);
            }
            let out = run_on(command, &robot, data, &extra);
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(2), "{command} {data:?}: {err}");
            assert!(
                err.contains("the robot file's own model at every one of the 40 poses")
                    && err.contains("computed from the joints")
                    && err.contains("--map"),
                "{command} {data:?}: {err}"
            );
        }
    }
    // Measured points of the same poses: noise of 0.01 mm (below any real tracker's and
    // robot's repeatability) is no longer the model's own, and passes.
    let measured = dir.path().join("measured.csv");
    simulate(&robot, Some(40), Some(0.01), Some(3), &[], &measured);
    let out = run_on("check", &robot, &measured, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

/// A file longer than the rounding door reads (4,096 poses, evenly spaced) is judged on those
/// poses and says so: computed points are refused, measured ones pass.
#[test]
fn a_long_file_is_judged_on_evenly_spaced_poses_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let fk = dir.path().join("fk.csv");
    simulate(&robot, Some(5000), Some(0.0), Some(8), &[], &fk);
    let out = run_on("check", &robot, &fk, &[]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("at every one of the 4096 poses read (evenly spaced, of 5000)"),
        "{err}"
    );
    // The same poses measured (0.01 mm of noise) pass.
    let measured = dir.path().join("measured.csv");
    simulate(&robot, Some(5000), Some(0.01), Some(8), &[], &measured);
    let out = run_on("check", &robot, &measured, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

#[test]
fn joints_written_with_too_few_decimals_are_warned_about_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let sim = dir.path().join("sim.csv");
    simulate(
        &robot,
        Some(80),
        Some(0.02),
        Some(5),
        &["--geom-errors"],
        &sim,
    );
    let in_rad = |decimals: usize| {
        let name = format!("rad{decimals}.csv");
        let text = rewritten(
            &sim,
            |v| format!("{:.*}", decimals, v.to_radians()),
            |v| format!("{v}"),
        );
        write(dir.path(), &name, &text)
    };
    let identify =
        |data: &Path| run_on("identify", &robot, data, &["--angle-unit", "rad", "--json"]);

    // Steps of 0.01 rad (0.57°): the rounding rivals what a calibration finds.
    let out = identify(&in_rad(2));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("written with 2 decimals")
            && err.contains("0.57°")
            && err.contains("more decimals"),
        "{err}"
    );

    // Steps of 0.001 rad: warned, with the RMS the rounding adds, which the fit's own
    // cross-validated residual confirms (the simulation's noise is 0.02 mm per axis).
    let out = identify(&in_rad(3));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("written with 3 decimals"))
        .unwrap_or_else(|| panic!("{err}"));
    let said: f64 = line
        .split("moves the tool by ~")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    let v = json_of(&out);
    let fitted = v["after"]["identification_rms_mm"]
        .as_f64()
        .unwrap_or_else(|| panic!("{v}"));
    eprintln!(
        "joints in radians with 3 decimals: rounding said {said} mm, the fit left {fitted} mm"
    );
    assert!(
        said > 0.5 * fitted && said < 1.5 * fitted,
        "rounding said {said} mm, the fit left {fitted} mm"
    );

    // Six decimals: nothing said.
    let out = identify(&in_rad(6));
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(!stderr(&out).contains("decimals"), "{}", stderr(&out));
}
