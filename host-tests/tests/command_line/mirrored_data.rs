//! Mirrored data (`cli/src/calibration/check.rs`, `compute/registration.rs` `mirrored_rms`): the
//! `x` and `y` columns exchanged, or `z` negated, left `check` at hundreds of millimetres with
//! exit 0 and no word on the cause. No rigid placement of the nominal robot fits such points, a
//! mirrored one does: `check` says so (stderr hint, JSON `mirrored_rms_mm`); the file as
//! simulated draws no such hint.

use crate::common::*;

#[test]
fn check_names_data_that_fit_only_mirrored() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let clean = dir.path().join("clean.csv");
    simulate(
        &robot,
        Some(200),
        Some(0.02),
        Some(7),
        &["--geom-errors"],
        &clean,
    );
    let text = std::fs::read_to_string(&clean).unwrap();
    let edit = |name: &str, f: &dyn Fn(&mut Vec<String>)| {
        let mut out = String::new();
        for (k, line) in text.lines().enumerate() {
            let mut cells: Vec<String> = line.split(',').map(String::from).collect();
            if k > 0 {
                f(&mut cells);
            }
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        write(dir.path(), name, &out)
    };
    let swapped = edit("swapped.csv", &|c| c.swap(6, 7));
    let flipped = edit("flipped.csv", &|c| {
        c[8] = format!("{:?}", -c[8].parse::<f64>().unwrap());
    });
    let out = run_on("check", &robot, &clean, &["--json"]);
    assert!(!stderr(&out).contains("mirrored"), "{}", stderr(&out));
    assert!(json_of(&out).get("mirrored_rms_mm").is_none());
    for data in [&swapped, &flipped] {
        let out = run_on("check", &robot, data, &["--json"]);
        let err = stderr(&out);
        assert!(
            err.contains("the data fit the nominal robot mirrored"),
            "{err}"
        );
        let v = json_of(&out);
        let (m, rms) = (
            v["mirrored_rms_mm"].as_f64().unwrap(),
            v["nominal_rms_mm"].as_f64().unwrap(),
        );
        assert!(m < 0.2 * rms && rms > 10.0, "{v}");
    }
}
