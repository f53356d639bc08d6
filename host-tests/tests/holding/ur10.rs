//! The same on the real UR10 series C (`data/ur10`; skipped when absent): an
//! extrapolating split is named, a model with a joint table is re-fitted by printed names and
//! groups, and a stale model (two joint zeros off by 0.2°) is repaired from ten poses.

use crate::common::*;
use std::path::{Path, PathBuf};

/// The series' robot file and data.
fn series() -> Option<(PathBuf, PathBuf)> {
    let dir = ur10_dir();
    let data = dir.join("ur10_random_poses.csv");
    Some((dir.join("robot.toml"), data))
}

/// The data file's header and the rows `keep` chooses (0-based row indices), as a new file.
fn rows(dir: &Path, name: &str, data: &Path, keep: impl Fn(usize) -> bool) -> PathBuf {
    let text = std::fs::read_to_string(data).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for (k, l) in lines.enumerate() {
        if keep(k) {
            out.push_str(l);
            out.push('\n');
        }
    }
    write(dir, name, &out)
}

/// Sorted by joint 2 and identified on the 10 % at one end: the held-out poses lie outside the
/// identified joint ranges and the verdict says so (warning or exit 3, never a silent success).
#[test]
fn ur10_an_extrapolating_split_is_named() {
    let Some((robot, data)) = series() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let header = lines.remove(0);
    let q2 = |l: &str| l.split(',').nth(1).unwrap().parse::<f64>().unwrap();
    lines.sort_by(|a, b| q2(a).total_cmp(&q2(b)));
    let sorted = write(
        dir.path(),
        "sorted.csv",
        &format!("{header}\n{}\n", lines.join("\n")),
    );
    let o = run_on("identify", &robot, &sorted, &["--holdout", "0.9", "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (before, after, ident) = (
        j["before"]["validation_rms_mm"].as_f64().unwrap(),
        j["after"]["validation_rms_mm"].as_f64().unwrap(),
        j["after"]["identification_rms_mm"].as_f64().unwrap(),
    );
    eprintln!(
        "UR10 sorted by q2, 10 % identified: held-out {before:.3} -> {after:.3} mm, \
         identification {ident:.3} mm, exit {:?}",
        o.status.code()
    );
    assert_eq!(o.status.code() == Some(3), j["held_out_worse"] == true);
    assert!(after > 2.0 * ident);
    let m = j["acceptance"]["message"].as_str().unwrap();
    assert!(m.contains("joint 2"), "{m}");
    assert!(stderr(&o).contains("joint 2"), "{}", stderr(&o));
}

/// A model with a joint table, re-fitted on the other poses by printed names and groups:
/// `--only base,tool` leaves every knot and row as written; `--fix joint-table2[3]` holds that
/// knot alone.
#[test]
fn ur10_a_model_with_a_table_refitted_by_names_and_groups() {
    let Some((robot, data)) = series() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let first = rows(d, "first.csv", &data, |k| k < 1000);
    let rest = rows(d, "rest.csv", &data, |k| k >= 1000);
    let model = d.join("m.toml");
    json_of(&run_on(
        "identify",
        &robot,
        &first,
        &["--effect", "joint-table:2", "--json", "--out", s(&model)],
    ));
    let j = json_of(&run_on(
        "identify",
        &model,
        &rest,
        &["--only", "base,tool", "--json"],
    ));
    let moved: Vec<&String> = j["changes"].as_object().unwrap().keys().collect();
    assert!(
        moved
            .iter()
            .all(|n| n.starts_with("base.") || n.starts_with("tool.")),
        "{moved:?}"
    );
    let m: kinecal_cli::formats::robot_file::RobotFile =
        kinecal_cli::formats::robot_file::RobotFile::load(&model).unwrap();
    let p = &j["parameters"];
    for (k, e) in m.effects.iter().flat_map(|e| e.values.iter()).enumerate() {
        let v = p[format!("joint-table2[{k}]")].as_f64().unwrap();
        assert!(
            (v - e).abs() <= 1e-12 * e.abs().max(1e-9),
            "knot {k}: {v} vs {e}"
        );
    }
    let j = json_of(&run_on(
        "identify",
        &model,
        &rest,
        &[
            "--free",
            "geometry,joint-table2",
            "--fix",
            "joint-table2[3]",
            "--json",
        ],
    ));
    let c = j["changes"].as_object().unwrap();
    assert!(c.contains_key("joint-table2[2]") && !c.contains_key("joint-table2[3]"));
}

/// A stale model (theta2 and theta3 off by 0.2°, as after a re-mastering) repaired with
/// `--only theta2,theta3` from ten poses of another part of the series: within 1.3× of the
/// model before the change on the other poses.
#[test]
fn ur10_quick_recalibration_from_ten_poses() {
    let Some((robot, data)) = series() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let first = rows(d, "first.csv", &data, |k| k < 1000);
    let ten = rows(d, "ten.csv", &data, |k| k >= 1000 && (k - 1000) % 178 == 0);
    let rest = rows(d, "rest.csv", &data, |k| k >= 1000 && (k - 1000) % 178 != 0);
    let model = d.join("m.toml");
    json_of(&run_on(
        "identify",
        &robot,
        &first,
        &["--json", "--out", s(&model)],
    ));
    let mut stale = kinecal_cli::formats::robot_file::RobotFile::load(&model).unwrap();
    stale.joints[1].theta_deg += 0.2;
    stale.joints[2].theta_deg += 0.2;
    let stale_path = write(d, "stale.toml", &stale.to_toml().unwrap());
    let repaired = d.join("repaired.toml");
    let j = json_of(&run_on(
        "identify",
        &stale_path,
        &ten,
        &["--only", "theta2,theta3", "--json", "--out", s(&repaired)],
    ));
    assert_eq!(j["n_identification"], 10);
    let rms = |m: &Path| {
        json_of(&run_on("check", m, &rest, &["--json"]))["nominal_rms_mm"]
            .as_f64()
            .unwrap()
    };
    let (good, bad, fixed) = (rms(&model), rms(&stale_path), rms(&repaired));
    eprintln!(
        "UR10 other poses: model {good:.4} mm, stale {bad:.4} mm, repaired from 10 {fixed:.4} mm"
    );
    assert!(bad > 2.0 * good);
    assert!(fixed <= 1.3 * good, "{fixed} vs {good}");
}
