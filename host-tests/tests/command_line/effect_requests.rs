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
