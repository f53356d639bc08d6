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
    assert_eq!(dropped.len(), 3, "{j}");
    assert!(
        dropped[0].starts_with("effect joint-scale on joint 2 (non-geometric: a DH table"),
        "{dropped:?}"
    );
    assert!(
        dropped[1].starts_with("effect thermal-expansion (non-geometric"),
        "{dropped:?}"
    );
    // Each with what leaving it out costs, and the two together.
    assert!(
        dropped[1].contains("at 32 °C (10 K above the model's reference temperature)"),
        "{dropped:?}"
    );
    assert!(
        dropped[2].starts_with("all of the above together (without them the tool point moves"),
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

/// What leaving an effect out costs, against known truth: a 2R arm whose last joint reads
/// 1e-3 of its angle short (`joint-scale`) with the tool point 300 mm from that joint's axis.
/// Without the effect the point moves `2 · 300 · sin(|1e-3 · q2| / 2)` ≈ 0.3 mm per rad of
/// `q2`: with `q2` uniform over ±90°, up to 0.471 mm and 0.272 mm RMS (`0.3 · (π/2) / √3`).
#[test]
fn what_leaving_an_effect_out_costs_is_said_and_right() {
    let dir = tempfile::tempdir().unwrap();
    let model = crate::common::write(
        dir.path(),
        "m.toml",
        "name = \"2R\"\n\
         [[joints]]\nalpha_deg = 0.0\na_mm = 0.0\ntheta_deg = 0.0\nd_mm = 0.0\nlimits_deg = [-90.0, 90.0]\n\
         [[joints]]\nalpha_deg = 0.0\na_mm = 500.0\ntheta_deg = 0.0\nd_mm = 0.0\nlimits_deg = [-90.0, 90.0]\n\
         [tool]\nxyz_mm = [300.0, 0.0, 0.0]\n\
         [base]\nxyz_mm = [0.0, 0.0, 0.0]\n\
         [[effects]]\nkind = \"joint-scale\"\njoint = 2\nvalues = [0.001]\n",
    );
    let out = dir.path().join("t.csv");
    let o = kinecal_ok(&[
        "export",
        "--model",
        s(&model),
        "--format",
        "dh-table",
        "--out",
        s(&out),
        "--json",
    ]);
    let j = crate::common::json_of(&o);
    let dropped = j["dropped"].as_array().unwrap();
    assert_eq!(dropped.len(), 1, "{j}");
    let text = dropped[0].as_str().unwrap();
    let number = |after: &str| -> f64 {
        let rest = &text[text.find(after).unwrap_or_else(|| panic!("{text}")) + after.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    let (rms, max) = (number("moves "), number("up to "));
    let truth_max = 600.0 * (1e-3 * std::f64::consts::FRAC_PI_2 / 2.0).sin();
    let truth_rms = 0.3 * std::f64::consts::FRAC_PI_2 / 3f64.sqrt();
    assert!(max <= truth_max + 1e-3 && max > 0.99 * truth_max, "{text}");
    assert!((rms / truth_rms - 1.0).abs() < 0.05, "{text}");
    assert!(stderr(&o).contains("warning: not exported: effect joint-scale on joint 2"));
}
