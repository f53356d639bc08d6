//! Gross outliers (`cli/src/calibration/outliers.rs`): a point more than ten times the median
//! distance from the fitted model (and more than 1 mm) makes `identify` and `diagnose` exit 3,
//! naming its line; they used to exit 0 with a model one wrong row had pulled (600 UR10 rows with
//! one `x` 100 mm off: 4.1 mm RMS "converged", and `diagnose` took that for the noise floor).

use crate::common::*;
use std::path::{Path, PathBuf};

/// The first `n` rows of the UR10 series C file with `dx` mm added to the `x` of the rows at
/// the given 0-based indices (line = index + 2).
fn rows_with(dir: &Path, name: &str, n: usize, off: &[(usize, f64)]) -> PathBuf {
    ur10_rows(dir, name, n, |i, cells| {
        if let Some((_, dx)) = off.iter().find(|(k, _)| *k == i) {
            cells[6] = format!("{:?}", cells[6].parse::<f64>().unwrap() + dx);
        }
    })
}

#[test]
fn a_few_wrong_rows_are_named_and_no_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let cases = [
        (
            rows_with(dir.path(), "one.csv", 600, &[(123, 100.0)]),
            1,
            "line 125 ",
        ),
        (
            rows_with(
                dir.path(),
                "five.csv",
                400,
                &[
                    (10, 10.0),
                    (50, -10.0),
                    (123, 10.0),
                    (200, 10.0),
                    (300, -10.0),
                ],
            ),
            5,
            "2 more",
        ),
    ];
    for (data, count, named) in &cases {
        for command in ["identify", "diagnose"] {
            let line = no_calibration(command, &robot, data);
            assert!(
                line.contains(&format!("leaves {count} point(s) far from the model"))
                    && line.contains(named)
                    && line.contains("delete those rows or measure them again"),
                "{command}: {line}"
            );
        }
    }
    // The same rows as recorded: a calibration, and `diagnose` names effects.
    let clean = rows_with(dir.path(), "clean.csv", 600, &[]);
    let out = run_on("identify", &robot, &clean, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v = json_of(&run_on("diagnose", &robot, &clean, &["--json"]));
    assert_eq!(v["converged"], true);
    assert!(!v["found"].as_array().unwrap().is_empty(), "{v}");
}
