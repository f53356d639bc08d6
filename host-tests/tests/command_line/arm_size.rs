//! A length unit given explicitly is never replaced, but a fit that had to stretch or shrink
//! the arm to meet the points is no calibration (`cli/src/calibration/arm_size.rs`): the real
//! UR10 rows with their points in metres or centimetres, declared millimetres (by the flag or
//! by a map), give exit 3 from `identify` and `diagnose`, naming the size change and what to
//! do, where they used to "calibrate" the arm to 0.0005 mm and exit 0. In millimetres they are
//! a calibration.

use crate::common::*;
use std::path::{Path, PathBuf};

/// The first 400 rows of the UR10 series C file, their points divided by `per_mm`.
fn rows_in(dir: &Path, name: &str, per_mm: f64) -> PathBuf {
    let text = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv")).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for l in lines.take(400) {
        let mut cells: Vec<String> = l.split(',').map(String::from).collect();
        for c in &mut cells[6..9] {
            *c = format!("{:?}", c.parse::<f64>().unwrap() / per_mm);
        }
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    write(dir, name, &out)
}

#[test]
fn points_in_another_unit_than_declared_are_no_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let mm = rows_in(dir.path(), "mm.csv", 1.0);
    let out = run_on("identify", &robot, &mm, &["--length-unit", "mm"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let map = write(
        dir.path(),
        "mm.map.toml",
        "[columns]\nx = \"x\"\n[units]\nlength = \"mm\"\n",
    );
    for (name, per_mm) in [("m.csv", 1000.0), ("cm.csv", 10.0)] {
        let data = rows_in(dir.path(), name, per_mm);
        // The reason is in the report too (the JSON that Python and scripts read).
        let out = run_on(
            "diagnose",
            &robot,
            &data,
            &["--json", "--length-unit", "mm"],
        );
        assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(
            v["converged"] == false
                && v["resized"]
                    .as_str()
                    .is_some_and(|r| r.contains("made the arm's links")),
            "{v}"
        );
        for (command, extra) in [
            ("identify", ["--length-unit", "mm"]),
            ("identify", ["--map", s(&map)]),
            ("diagnose", ["--length-unit", "mm"]),
        ] {
            let out = run_on(command, &robot, &data, &extra);
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(3), "{command} {name}: {err}");
            let line = err
                .lines()
                .find(|l| l.starts_with("error:"))
                .unwrap_or_else(|| panic!("{command} {name}: {err}"));
            assert!(
                line.contains("made the arm's links")
                    && line.contains("times as long as the robot file says")
                    && line.contains("give --length-unit"),
                "{command} {name}: {line}"
            );
        }
    }
}
