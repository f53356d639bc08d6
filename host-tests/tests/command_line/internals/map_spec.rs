//! `kinecal_cli::formats::map::spec` (cli/src/formats/map/spec.rs) on its own.

use kinecal_cli::formats::map::spec::*;
use kinecal_cli::formats::units::AngleUnit;

#[test]
fn the_documented_map_reads() {
    let m = MapFile::parse(
        "delimiter = \";\"\ndecimal = \",\"\nheader = true\n[columns]\nq1 = \"shoulder_pan_joint\"\nx = \"measurement_x\"\nrx_deg = 5\n[units]\njoints = \"rad\"\nlength = \"mm\"\norientation = \"deg\"\nrotation = \"Rx*Ry*Rz\"\n",
        "M.toml",
    )
    .unwrap();
    assert_eq!(m.delimiter, Some(Delimiter::Semicolon));
    assert!(m.decimal_comma && m.header);
    assert_eq!(m.columns.len(), 3);
    assert!(m.columns.contains(&("rx_deg".into(), ColumnRef::Number(5))));
    assert_eq!(m.units.joints, Some(AngleUnit::Rad));
    assert_eq!(m.rotation.text(), "Rx*Ry*Rz");
}

#[test]
fn mistakes_are_refused_with_the_entry_named() {
    for (text, says) in [
        ("delimiter = \"|\"", "delimiter = \"|\""),
        (
            "decimal = \",\"\ndelimiter = \",\"",
            "decimal = \",\" with delimiter",
        ),
        (
            "header = false\n[columns]\nq1 = \"a\"",
            "q1 = \"a\" with header = false",
        ),
        ("[columns]\nq1 = 0", "column numbers start at 1"),
        ("[units]\njoints = \"grad\"", "joints = \"grad\""),
        (
            "[units]\nrotation = \"Rx*Rx*Rz\"",
            "rotation = \"Rx*Rx*Rz\"",
        ),
        ("[columns]\nsrx_deg = \"a\"", "needs all of srx_deg"),
        ("colums = 1", "not a map file"),
    ] {
        let e = MapFile::parse(text, "M.toml").unwrap_err().to_string();
        assert!(e.starts_with("M.toml: ") && e.contains(says), "{text}: {e}");
    }
}
