//! `kinecal_cli::formats::map::translate` (cli/src/formats/map/translate.rs) on its own.

use kinecal_cli::formats::map::layout::content_lines;
use kinecal_cli::formats::map::spec::MapFile;
use kinecal_cli::formats::map::translate::*;
use kinecal_cli::formats::units::FileKind;

fn map(text: &str) -> MapFile {
    MapFile::parse(text, "M.toml").unwrap()
}

/// The refusal of translating measurement `lines` ("D.csv") with map `m` ("M.toml").
fn error_of(m: &MapFile, lines: &str) -> String {
    translate(
        m,
        &content_lines(lines),
        (1, FileKind::Measurements),
        ("D.csv", "M.toml"),
    )
    .err()
    .unwrap()
    .to_string()
}

#[test]
fn a_vendor_layout_becomes_kinecal_s() {
    let m = map(
        "decimal = \",\"\n[columns]\nq1 = \"j1\"\nq2 = \"j2\"\nx = \"mx\"\ny = \"my\"\nz = \"mz\"\nsx_mm = \"sdx\"\nsrx_deg = \"a\"\nsry_deg = \"b\"\nsrz_deg = \"c\"\n[units]\nlength = \"m\"\n",
    );
    let file =
        "time;j1;j2;mx;my;mz;sdx;a;b;c;temp_c\n\n1;0,5;-1,25;1,5;0,25;-0,75;0,00002;3;0;4;21,5\n";
    let t = translate(
        &m,
        &content_lines(file),
        (2, FileKind::Measurements),
        ("D.csv", "M.toml"),
    )
    .unwrap();
    let names: Vec<&str> = t.columns.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        ["q1", "q2", "x", "y", "z", "sx_mm", "srot_deg", "temp_c"]
    );
    let s = (25.0f64 / 3.0).sqrt();
    assert_eq!(
        t.text,
        format!("q1,q2,x,y,z,sx_mm,srot_deg,temp_c\n\n0.5,-1.25,1.5,0.25,-0.75,0.02,{s:?},21.5\n")
    );
}

#[test]
fn without_a_header_columns_are_numbers_and_lines_shift_by_one() {
    let m = map("header = false\n[columns]\nq1 = 2\nx = 3\ny = 4\nz = 5\n");
    let t = translate(
        &m,
        &content_lines("# c\n9 10 11 12 13\n"),
        (1, FileKind::Measurements),
        ("D", "M"),
    )
    .unwrap();
    assert_eq!(t.text, "q1,x,y,z\n\n10.0,11.0,12.0,13.0\n");
    assert_eq!(t.line_shift, 1);
}

#[test]
fn mistakes_name_the_file_line_and_column() {
    let m = map("[columns]\nq1 = \"j\"\nx = \"a\"\ny = \"b\"\nz = \"c\"\n");
    let lines = "j;a;b;c\n1;2;3;4\n1;2,5;3;4\n";
    let e = error_of(&m, lines);
    assert_eq!(
        e,
        "D.csv:3:2: not a number: '2,5' (a decimal comma? say decimal = \",\" in M.toml) in column `a` (kinecal's x); delimiter \";\""
    );
    // Both separators in one cell: a thousands separator, whichever the decimal one is.
    for decimal in ["", "decimal = \",\"\n"] {
        let m = map(&format!(
            "{decimal}[columns]\nq1 = \"j\"\nx = \"a\"\ny = \"b\"\nz = \"c\"\n"
        ));
        let e = error_of(&m, "j;a;b;c\n1;1.144,25;3;4\n");
        assert!(e.contains("'1.144,25' (a thousands separator"), "{e}");
    }
    // A row of units under the header.
    let m = map("[columns]\nq1 = \"j\"\nx = \"a\"\ny = \"b\"\nz = \"c\"\n");
    let e = error_of(&m, "j;a;b;c\n[deg];mm;mm;mm\n1;2;3;4\n");
    assert!(
        e.contains("D.csv:2:1: not a number: '[deg]' (a row of units under the header?"),
        "{e}"
    );
    let m = map("[columns]\nq1 = \"joint\"\n");
    let e = error_of(&m, lines);
    assert!(
        e.starts_with(
            "M.toml: [columns] q1 = \"joint\": D.csv has no such column (its header: j, a, b, c)"
        ),
        "{e}"
    );
    let m = map("[columns]\nq1 = \"j\"\n");
    let e = error_of(&m, lines);
    assert!(e.starts_with("D.csv: no column for x"), "{e}");
}
