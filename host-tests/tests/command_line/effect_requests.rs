//! `identify --effect`: every requested effect is estimated once and reported as such.

use crate::common::*;

/// Every `--effect` joins the fitted parameters once: listed twice, a parameter was held as
/// "confounded with" itself and reported as unidentifiable although it was estimated.
#[test]
fn requested_effects_are_estimated_not_reported_unidentifiable() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = dir.path().join("cyclic.csv");
    kinecal_ok(&[
        "simulate",
        "--robot",
        s(&robot),
        "--poses",
        "300",
        "--noise-mm",
        "0.01",
        "--seed",
        "4",
        "--geom-errors",
        "--effect",
        "joint-cyclic:2:0.0004,-0.0002",
        "--out",
        s(&data),
    ]);
    let v = json_of(&run_on(
        "identify",
        &robot,
        &data,
        &["--json", "--effect", "joint-cyclic:2"],
    ));
    let names: Vec<&str> = v["unidentifiable"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect();
    assert!(
        !names.iter().any(|n| n.starts_with("joint-cyclic")),
        "{names:?}"
    );
    let a = v["parameters"]["joint-cyclic2.n1.a"].as_f64().unwrap();
    let b = v["parameters"]["joint-cyclic2.n1.b"].as_f64().unwrap();
    assert!(
        (a - 0.0004).abs() < 2e-5 && (b + 0.0002).abs() < 2e-5,
        "{a} {b}"
    );
}

/// A joint table fitted to readings many turns from zero (a multi-turn joint; the data
/// file's readings may reach ±1e5°) is written with its `start_deg` there, and the model reads
/// back: tables used to be refused beyond ±3600° although `identify` wrote them.
#[test]
fn a_table_fitted_many_turns_out_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    let data = ur10_rows(dir.path(), "turns.csv", 400, |_, cells| {
        cells[0] = format!("{:?}", cells[0].parse::<f64>().unwrap() + 36000.0);
    });
    let model = dir.path().join("m.toml");
    let out = run_on(
        "identify",
        &robot,
        &data,
        &["--effect", "joint-table:1:10", "--out", s(&model)],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = std::fs::read_to_string(&model).unwrap();
    let start: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("start_deg = "))
        .unwrap()
        .parse()
        .unwrap();
    assert!(start > 35000.0, "{start}");
    let out = run_on("check", &model, &data, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}
