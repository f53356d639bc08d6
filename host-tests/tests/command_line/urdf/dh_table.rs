//! The parameter table (`export --format dh-table`) in CSV and JSON against the files.

use super::*;

fn csv_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn dh_table_csv_and_json_agree_with_the_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = urdf_path("kuka_kr16_2", "kr16_2.urdf");
    let (robot_path, nominal) = import(d, &path, &[]);
    let mut model = nominal.clone();
    model.joints[1].a_mm += 0.25;
    model.joints[2].theta_deg -= 0.01;
    model.tool.xyz_mm[0] += 1.5;
    model.base.as_mut().unwrap().xyz_mm[1] = 2000.0;
    let model_path = d.join("model.toml");
    model.save(&model_path).unwrap();
    let csv = d.join("t.csv");
    kinecal_ok(&[
        "export",
        "--model",
        s(&model_path),
        "--format",
        "dh-table",
        "--robot",
        s(&robot_path),
        "--out",
        s(&csv),
    ]);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("parameter,unit,nominal,calibrated,delta\n"));
    let rows = csv_rows(&text);
    assert_eq!(rows.len(), 6 + 5 * 6 + 3);
    let num = |r: &Vec<String>, k: usize| r[k].parse::<f64>().unwrap();
    let find = |name: &str| rows.iter().find(|r| r[0] == name).unwrap().clone();
    let r = find("joint2_a_mm");
    assert_eq!(
        (num(&r, 2), num(&r, 3)),
        (nominal.joints[1].a_mm, model.joints[1].a_mm)
    );
    assert!((num(&r, 4) - 0.25).abs() < 1e-12);
    let r = find("joint3_theta_deg");
    assert!((num(&r, 4) + 0.01).abs() < 1e-12);
    let r = find("tool_x_mm");
    assert!((num(&r, 4) - 1.5).abs() < 1e-12);
    let r = find("base_y_mm");
    assert_eq!(num(&r, 3), 2000.0);
    for r in &rows {
        assert!((num(r, 3) - num(r, 2) - num(r, 4)).abs() < 1e-9, "{r:?}");
    }
    // JSON, nominal from the URDF itself: the same numbers.
    let json = d.join("t.json");
    kinecal_ok(&[
        "export",
        "--model",
        s(&model_path),
        "--format",
        "dh-table",
        "--urdf",
        s(&path),
        "--out",
        s(&json),
    ]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let arr = v.as_array().unwrap();
    assert_eq!(arr.len(), rows.len());
    for (o, r) in arr.iter().zip(&rows) {
        assert_eq!(o["parameter"].as_str().unwrap(), r[0]);
        assert_eq!(o["unit"].as_str().unwrap(), r[1]);
        for (k, key) in [(2, "nominal"), (3, "calibrated"), (4, "delta")] {
            assert!(
                (o[key].as_f64().unwrap() - num(r, k)).abs() < 1e-9,
                "{key} {r:?}"
            );
        }
    }
    // No nominal: empty columns and one warning, exit 0.
    let bare = d.join("bare.csv");
    let o = kinecal_ok(&[
        "export",
        "--model",
        s(&model_path),
        "--format",
        "dh-table",
        "--out",
        s(&bare),
    ]);
    assert!(stderr(&o).contains("no nominal given: pass --robot R.toml"));
    let rows = csv_rows(&std::fs::read_to_string(&bare).unwrap());
    assert!(rows
        .iter()
        .all(|r| r[2].is_empty() && r[4].is_empty() && !r[3].is_empty()));
}

/// What the table cannot hold is warned about and listed in JSON `dropped`, as the URDF export
/// lists it (it said `"dropped": []` for a model with five joint tables); a tilt fitted as an
/// `axis-tilt` effect (radians) is the table's `beta_deg` (it read 0).
#[test]
fn dh_table_names_what_it_drops_and_keeps_a_fitted_tilt() {
    use kinecal_cli::formats::robot_file::EffectSpec;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = urdf_path("kuka_kr16_2", "kr16_2.urdf");
    let (robot_path, nominal) = import(d, &path, &[]);
    let mut model = nominal.clone();
    let effect = |kind: &str, joint: usize, values: Vec<f64>| EffectSpec {
        kind: kind.into(),
        joint,
        values,
        order: None,
        step_deg: None,
        start_deg: None,
        reference_c: None,
    };
    model.effects = vec![
        effect("axis-tilt", 3, vec![0.0005]),
        effect("joint-scale", 2, vec![0.0003]),
        effect("thermal-expansion", 0, vec![1.2e-5]),
    ];
    model.effects[2].reference_c = Some(22.0);
    let model_path = d.join("model.toml");
    model.save(&model_path).unwrap();
    let out = d.join("t.csv");
    let args = ["export", "--model", s(&model_path), "--format", "dh-table"];
    let o = kinecal_ok(
        &[
            &args[..],
            &["--robot", s(&robot_path), "--out", s(&out), "--json"],
        ]
        .concat(),
    );
    let j = crate::common::json_of(&o);
    let dropped: Vec<&str> = j["dropped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(dropped.len(), 2, "{j}");
    assert!(
        dropped[0].starts_with("effect joint-scale on joint 2 (non-geometric: a DH table"),
        "{dropped:?}"
    );
    assert!(
        dropped[1].starts_with("effect thermal-expansion (non-geometric"),
        "{dropped:?}"
    );
    let err = stderr(&o);
    assert_eq!(
        err.matches("warning: not exported: effect").count(),
        2,
        "{err}"
    );
    // With --json the table is JSON too.
    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let beta = table
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["parameter"] == "joint3_beta_deg")
        .unwrap();
    let b = beta["calibrated"].as_f64().unwrap();
    assert!((b - 0.0005f64.to_degrees()).abs() < 1e-9, "{beta}");
}
