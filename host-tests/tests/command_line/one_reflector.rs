//! One `[[tools]]` entry names its reflector: the file's `x_NAME`, `y_NAME`, `z_NAME` are read
//! (not refused as if there were no names), and `check` lists as carried-along columns only
//! those without a fixed meaning (not the reflector's point, not the stated σ).

use crate::common::{json_of, kinecal_ok, s, simulate, write, ER20_PLACED};

#[test]
fn a_single_named_reflector_is_read_and_its_columns_are_not_extra() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = write(d, "er20.toml", ER20_PLACED);
    let data = d.join("data.csv");
    simulate(
        &robot,
        Some(30),
        Some(0.01),
        Some(2),
        &["--geom-errors"],
        &data,
    );
    // The same rows with the point as reflector `smr`, stated σ and a temperature.
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines
        .next()
        .unwrap()
        .replace(",x,y,z", ",x_smr,y_smr,z_smr");
    assert!(header.contains("x_smr"), "{header}");
    let mut named = format!("{header},sx_mm,sy_mm,sz_mm,temp_c\n");
    for l in lines {
        named.push_str(&format!("{l},0.01,0.01,0.02,21.5\n"));
    }
    let named = write(d, "named.csv", &named);
    let old = "[tool]\nxyz_mm = [12.0, -7.0, 100.0]\n";
    assert!(ER20_PLACED.contains(old));
    let one = write(
        d,
        "one.toml",
        &ER20_PLACED.replace(
            old,
            "[[tools]]\nname = \"smr\"\nxyz_mm = [12.0, -7.0, 100.0]\n",
        ),
    );
    let named_check = json_of(&kinecal_ok(&[
        "check",
        "--robot",
        s(&one),
        "--data",
        s(&named),
        "--json",
    ]));
    let plain_check = json_of(&kinecal_ok(&[
        "check",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--json",
    ]));
    assert_eq!(named_check["extra_columns"], serde_json::json!(["temp_c"]));
    // Every row kept: the named reflector's points are not taken for repeated readings.
    assert_eq!(named_check["poses"], 30, "{named_check}");
    // The same points: the same nominal error.
    let (a, b) = (
        named_check["nominal_rms_mm"].as_f64().unwrap(),
        plain_check["nominal_rms_mm"].as_f64().unwrap(),
    );
    assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    kinecal_ok(&["identify", "--robot", s(&one), "--data", s(&named)]);
}
