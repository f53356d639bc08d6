//! Measurement CSV parsing: every malformed-input class gives the right error kind, line and
//! column; the accepted variations (comments, blank lines, CRLF, extra columns, any order) work.

use kinecal::io::csv::{CsvError, CsvErrorKind};
use kinecal_cli::formats::measurements::{self, Dataset, Record, LINE_CAPACITY};
use proptest::prelude::*;

const HEAD6: &str = "q1,q2,q3,q4,q5,q6,x,y,z";

fn read6(text: &str) -> Result<Dataset<6>, CsvError> {
    measurements::read_records::<6, _>(text.as_bytes())
}

/// Kind, line and column of the error `text` must give.
fn err6(text: &str) -> (CsvErrorKind, u32, u16) {
    let e = read6(text).expect_err("must be refused");
    (e.kind, e.line, e.column)
}

/// Writes `text` to a file and loads it; returns the one-line message (asserting the
/// `FILE:LINE:COLUMN: ` prefix) split into line, column and description.
fn load_message(text: &[u8]) -> (u32, u32, String) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.csv");
    std::fs::write(&p, text).unwrap();
    let msg = format!(
        "{:#}",
        measurements::load::<6>(&p).expect_err("must be refused")
    );
    assert!(!msg.contains('\n'), "one line: {msg}");
    let rest = msg
        .strip_prefix(&format!("{}:", p.display()))
        .unwrap_or_else(|| panic!("names the file: {msg}"));
    let mut it = rest.splitn(3, ':');
    let line = it
        .next()
        .unwrap()
        .parse()
        .unwrap_or_else(|_| panic!("line: {msg}"));
    let col = it
        .next()
        .unwrap()
        .parse()
        .unwrap_or_else(|_| panic!("column: {msg}"));
    (line, col, it.next().unwrap().trim().to_string())
}

#[test]
fn a_good_file() {
    let d = read6(&format!(
        "{HEAD6}\n1,2,3,4,5,6,100.5,-200.25,300\n-1.5,0,0,0,0,1e1,1,2,3\n"
    ))
    .unwrap();
    assert_eq!(d.len(), 2);
    assert_eq!(d.records[0].q_deg, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert_eq!(d.records[0].xyz_mm, [100.5, -200.25, 300.0]);
    assert_eq!(d.records[1].q_deg[5], 10.0);
    assert_eq!(d.records[1].line, 3);
    let m = d.records[0].measurement::<f64>();
    assert_eq!(m.q[0], 1f64.to_radians());
}

#[test]
fn missing_column() {
    let e = read6("q1,q2,q3,q4,q5,x,y,z\n1,2,3,4,5,6,7,8\n").unwrap_err();
    assert_eq!(
        (e.kind, e.line, e.which),
        (CsvErrorKind::MissingColumn, 1, 5)
    );
    assert_eq!(
        measurements::required_column_name(e.which as usize, 6),
        "q6"
    );
    let e = read6("# comment\n\nq1,q2,q3,q4,q5,q6,x,y\n").unwrap_err();
    assert_eq!(
        (e.kind, e.line, e.which),
        (CsvErrorKind::MissingColumn, 3, 8)
    );
    let (line, col, msg) = load_message(b"q1,q2,q3,q4,q5,q6,x,z\n1,2,3,4,5,6,7,8\n");
    assert_eq!((line, col), (1, 1));
    assert!(msg.contains("`y`"), "{msg}");
}

#[test]
fn text_in_a_numeric_cell() {
    assert_eq!(
        err6(&format!(
            "{HEAD6}\n1,2,3,4,5,6,7,8,9\n1,2,abc,4,5,6,7,8,9\n"
        )),
        (CsvErrorKind::NotANumber, 3, 3)
    );
    assert_eq!(
        err6(&format!("{HEAD6}\n1,2,3,4,5,6,7,8,\n")),
        (CsvErrorKind::NotANumber, 2, 9),
        "empty cell"
    );
    assert_eq!(
        err6(&format!("{HEAD6}\n1,2,3,4,5,6,7,8.0.1,9\n")),
        (CsvErrorKind::NotANumber, 2, 8)
    );
    let (line, col, msg) =
        load_message(format!("{HEAD6}\n1,2,3,4,5,6,7,8,9\n1,2,3,4,5,6,7,1.2.3,9\n").as_bytes());
    assert_eq!((line, col), (3, 8));
    assert!(
        msg.contains("not a number") && msg.contains("`y`") && msg.contains("1.2.3"),
        "{msg}"
    );
}

#[test]
fn nan_and_infinity() {
    for bad in ["nan", "NaN", "inf", "-inf", "infinity", "+Infinity"] {
        assert_eq!(
            err6(&format!("{HEAD6}\n1,2,3,4,{bad},6,7,8,9\n")),
            (CsvErrorKind::NotFinite, 2, 5),
            "{bad}"
        );
        assert_eq!(
            err6(&format!("{HEAD6}\n1,2,3,4,5,6,7,8,{bad}\n")),
            (CsvErrorKind::NotFinite, 2, 9),
            "{bad}"
        );
    }
    let (line, col, msg) = load_message(format!("{HEAD6}\n1,2,3,4,5,6,NaN,8,9\n").as_bytes());
    assert_eq!((line, col), (2, 7));
    assert!(
        msg.contains("NaN or infinite") && msg.contains("`x`"),
        "{msg}"
    );
}

#[test]
fn short_line() {
    assert_eq!(
        err6(&format!("{HEAD6}\n1,2,3,4,5,6,7,8,9\n1,2,3\n")),
        (CsvErrorKind::ShortLine, 3, 4)
    );
    // Required columns after an extra one: the first missing required one is named.
    let e = measurements::read_records::<2, _>("q1,temp,q2,x,y,z\n1,20\n".as_bytes()).unwrap_err();
    assert_eq!((e.kind, e.line, e.column), (CsvErrorKind::ShortLine, 2, 3));
    let (line, col, msg) = load_message(format!("{HEAD6}\n1,2,3,4,5,6,7,8\n").as_bytes());
    assert_eq!((line, col), (2, 9));
    assert!(msg.contains("too few") && msg.contains("`z`"), "{msg}");
}

#[test]
fn too_many_joints() {
    assert_eq!(
        err6("q1,q2,q3,q4,q5,q6,q7,x,y,z\n"),
        (CsvErrorKind::TooManyJoints, 1, 7)
    );
    assert_eq!(
        err6("x,y,z,q1,q2,q3,q4,q5,q6,q7\n"),
        (CsvErrorKind::TooManyJoints, 1, 10)
    );
    let (line, col, msg) = load_message(b"q1,q2,q3,q4,q5,q6,q7,x,y,z\n");
    assert_eq!((line, col), (1, 7));
    assert!(msg.contains("q7"), "{msg}");
    // And the joint count of such a file is detected from its header.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.csv");
    std::fs::write(&p, "# seven joints\n\nz,q7,x,q1,q2,q3,q4,q5,q6,y\n").unwrap();
    assert_eq!(measurements::joint_count(&p).unwrap(), 7);
    std::fs::write(&p, "x,y,z\n").unwrap();
    assert!(measurements::joint_count(&p).is_err());
}

#[test]
fn over_long_line() {
    let long = format!(
        "{HEAD6}\n1,2,3,4,5,6,7,8,9\n1,2,3,4,5,6,7,8,9{}\n1,2,3,4,5,6,7,8,9\n",
        " ".repeat(LINE_CAPACITY)
    );
    assert_eq!(err6(&long), (CsvErrorKind::LineTooLong, 3, 0));
    let (line, col, msg) = load_message(long.as_bytes());
    assert_eq!((line, col), (3, LINE_CAPACITY as u32 + 1));
    assert!(msg.contains("longer than"), "{msg}");
    // A line of exactly the capacity is fine.
    let fits = format!(
        "{HEAD6}\n1,2,3,4,5,6,7,8,9{}\n",
        " ".repeat(LINE_CAPACITY - 17)
    );
    assert_eq!(read6(&fits).unwrap().len(), 1);
    // An over-long header too.
    assert_eq!(
        err6(&format!("{HEAD6}{}\n", ",".repeat(LINE_CAPACITY))).0,
        CsvErrorKind::LineTooLong
    );
}

#[test]
fn empty_file() {
    assert_eq!(err6("").0, CsvErrorKind::Empty);
    assert_eq!(err6("\n\n# only comments\n   \n").0, CsvErrorKind::Empty);
    let (line, col, msg) = load_message(b"");
    assert_eq!((line, col), (1, 1));
    assert!(msg.contains("empty"), "{msg}");
}

#[test]
fn duplicate_column() {
    assert_eq!(
        err6("q1,q2,q3,q4,q5,q6,x,y,z,q2\n"),
        (CsvErrorKind::DuplicateColumn, 1, 10)
    );
}

#[test]
fn not_utf8() {
    let e =
        measurements::read_records::<6, _>(&b"q1,q2,q3,q4,q5,q6,x,y,z\n1,2,3,4,5,\xff,7,8,9\n"[..])
            .unwrap_err();
    assert_eq!((e.kind, e.line), (CsvErrorKind::NotText, 2));
}

#[test]
fn comments_and_blank_lines_are_skipped_and_counted() {
    let d = read6(&format!(
        "# made by hand\n\n{HEAD6}\n# pose 1\n1,2,3,4,5,6,7,8,9\n\n   \n2,2,3,4,5,6,7,8,9\n"
    ))
    .unwrap();
    assert_eq!(d.len(), 2);
    assert_eq!((d.records[0].line, d.records[1].line), (5, 8));
    assert_eq!(
        err6(&format!("#\n{HEAD6}\n\n#\n1,x,3,4,5,6,7,8,9\n")),
        (CsvErrorKind::NotANumber, 5, 2)
    );
}

#[test]
fn crlf_line_ends() {
    let d = read6(&format!(
        "{HEAD6}\r\n1,2,3,4,5,6,7,8,9\r\n\r\n2,2,3,4,5,6,7,8,9.5\r\n"
    ))
    .unwrap();
    assert_eq!(d.len(), 2);
    assert_eq!(d.records[1].xyz_mm[2], 9.5);
    assert_eq!(d.records[1].line, 4);
}

#[test]
fn extra_columns_are_carried_by_name() {
    let d = read6(
        "t_s,q1,q2,q3,q4,q5,q6,x,y,z,temp_c\n0.5,1,2,3,4,5,6,7,8,9,21.5\n1.5,1,2,3,4,5,6,7,8,9,\n",
    )
    .unwrap();
    assert_eq!(d.extra_names, vec!["t_s", "temp_c"]);
    assert_eq!(d.records[0].extra, vec![0.5, 21.5]);
    assert!(d.records[1].extra[1].is_nan(), "an empty extra cell is NaN");
    assert_eq!(d.extra("temp_c").unwrap()[0], 21.5);
    assert_eq!(d.extra("t_s").unwrap(), vec![0.5, 1.5]);
    assert!(d.extra("pressure").is_none());
}

#[test]
fn columns_in_any_order() {
    let d = read6("z,q6,\"x\",q5,q4,q3,y,q2,q1\n9,6,7,5,4,3,8,2,1\n").unwrap();
    assert_eq!(d.records[0].q_deg, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert_eq!(d.records[0].xyz_mm, [7.0, 8.0, 9.0]);
}

#[test]
fn byte_order_mark_is_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.csv");
    std::fs::write(&p, format!("\u{feff}{HEAD6}\n1,2,3,4,5,6,7,8,9\n")).unwrap();
    assert_eq!(measurements::load::<6>(&p).unwrap().len(), 1);
}

#[test]
fn the_ur10_file_loads() {
    let p =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/ur10/ur10_random_poses.csv");
    assert_eq!(measurements::joint_count(&p).unwrap(), 6);
    let d = measurements::load::<6>(&p).unwrap();
    assert_eq!(d.len(), 2773);
    assert_eq!(d.extra_names, vec!["temp_c"]);
    assert_eq!(d.records[0].xyz_mm, [383.97123, -3240.75620, 201.72621]);
}

fn arb_records() -> impl Strategy<Value = Vec<([f64; 6], [f64; 3], f64)>> {
    prop::collection::vec(
        (
            prop::array::uniform6(-400.0f64..400.0),
            prop::array::uniform3(-5000.0f64..5000.0),
            -40.0f64..80.0,
        ),
        0..20,
    )
}

proptest! {
    /// The writer's output reads back: readings to 1e-6°, points to 1e-8 mm, extras exactly.
    #[test]
    fn write_then_read(recs in arb_records()) {
        let ds = Dataset::<6> {
            records: recs.iter().map(|(q, p, t)| Record { q_deg: *q, xyz_mm: *p, extra: vec![*t], line: 0 }).collect(),
            extra_names: vec!["temp_c".into()],
        };
        let back = read6(&measurements::to_csv_string(&ds)).unwrap();
        prop_assert_eq!(back.len(), ds.len());
        prop_assert_eq!(&back.extra_names, &ds.extra_names);
        for (a, b) in ds.records.iter().zip(&back.records) {
            for (x, y) in a.q_deg.iter().zip(b.q_deg) {
                prop_assert!((x - y).abs() <= 5.1e-7);
                prop_assert_eq!(measurements::quantize_deg(*x), y);
            }
            for (x, y) in a.xyz_mm.iter().zip(b.xyz_mm) {
                prop_assert!((x - y).abs() <= 5.1e-9 + 1e-15 * x.abs());
            }
            prop_assert_eq!(&a.extra, &b.extra);
        }
    }

    /// Arbitrary bytes never panic the reader: a record or a located error.
    #[test]
    fn arbitrary_input_never_panics(body in prop::collection::vec(prop_oneof![
        Just(b','), Just(b'\n'), Just(b'\r'), Just(b'#'), Just(b'.'), Just(b'-'), Just(b'e'), Just(b' '),
        b'0'..=b'9', any::<u8>()
    ], 0..600), header in prop::sample::select(vec![HEAD6, "x,y,z,q1,q2,q3,q4,q5,q6,t", "q1,q2"])) {
        let mut text = format!("{header}\n").into_bytes();
        text.extend(body);
        match measurements::read_records::<6, _>(&text[..]) {
            Ok(d) => for r in d.records { prop_assert!(r.q_deg.iter().chain(&r.xyz_mm).all(|v| v.is_finite())) },
            Err(e) => prop_assert!(e.line >= 1),
        }
    }
}

/// A row of `cells` (each `(padding, number or empty)`) joined with commas.
fn row_text(cells: &[(usize, Option<f64>)]) -> String {
    let cell = |(pad, v): &(usize, Option<f64>)| {
        let pad = " ".repeat(*pad);
        v.map_or(pad.clone(), |v| format!("{pad}{v}{pad}"))
    };
    cells.iter().map(cell).collect::<Vec<_>>().join(",")
}

proptest! {
    /// The reader cuts a line into the cells `str::split(',')` gives: padded numbers, empty
    /// extra cells (NaN), missing extras (NaN), a cell beyond the header (refused, column 12).
    #[test]
    fn cells_are_the_comma_separated_fields(
        required in prop::collection::vec((0usize..3, -1e4f64..1e4), 9),
        extras in prop::collection::vec((0usize..3, prop::option::of(-1e4f64..1e4)), 0..=3),
    ) {
        let mut cells: Vec<(usize, Option<f64>)> = required.iter().map(|(p, v)| (*p, Some(*v))).collect();
        cells.extend(extras.iter().copied());
        let line = row_text(&cells);
        let text = format!("q1,q2,q3,q4,q5,q6,x,y,z,t_s,temp_c\n{line}\n");
        let fields: Vec<&str> = line.split(',').collect();
        match read6(&text) {
            Ok(d) => {
                prop_assert!(fields.len() <= 11);
                let r = &d.records[0];
                let want = |k: usize| fields.get(k).and_then(|c| c.trim().parse::<f64>().ok());
                for k in 0..6 {
                    prop_assert_eq!(Some(r.q_deg[k]), want(k));
                }
                for k in 0..3 {
                    prop_assert_eq!(Some(r.xyz_mm[k]), want(6 + k));
                }
                for k in 0..2 {
                    match want(9 + k) {
                        Some(v) => prop_assert_eq!(r.extra[k], v),
                        None => prop_assert!(r.extra[k].is_nan()),
                    }
                }
            }
            Err(e) => {
                prop_assert_eq!(fields.len(), 12);
                prop_assert_eq!((e.kind, e.line, e.column), (CsvErrorKind::ExtraCell, 2, 12));
            }
        }
    }
}

mod decimal {
    use kinecal::io::csv::parse_decimal;
    use proptest::prelude::*;

    #[test]
    fn agrees_with_core_on_typical_and_edge_cells() {
        for s in [
            "0",
            "-0",
            "1",
            "-179.999848",
            "3240.75620",
            "1e-3",
            "2.5E+2",
            ".5",
            "5.",
            "+7",
            "0.000001",
            "123456789012345",
            "1e22",
            "1e-22",
            "00012.50",
        ] {
            assert_eq!(
                parse_decimal(s).map(f64::to_bits),
                s.parse::<f64>().ok().map(f64::to_bits),
                "{s}"
            );
        }
        for s in [
            "", "-", ".", "e5", "1e", "1e+", "1.2.3", "12a", "--1", "0x10",
        ] {
            assert_eq!(parse_decimal(s), None, "{s:?}");
        }
        assert!(parse_decimal("NaN").unwrap().is_nan());
        assert_eq!(parse_decimal("-inf"), Some(f64::NEG_INFINITY));
    }

    proptest! {
        #[test]
        fn exact_for_file_precision(v in -1e7f64..1e7, decimals in 0usize..9) {
            let s = format!("{v:.decimals$}");
            prop_assert_eq!(parse_decimal(&s).map(f64::to_bits), s.parse::<f64>().ok().map(f64::to_bits), "{}", s);
        }

        #[test]
        fn close_for_any_float(v in proptest::num::f64::NORMAL) {
            let s = format!("{v:e}");
            let p = parse_decimal(&s).unwrap();
            prop_assert!(((p - v) / v).abs() < 1e-14, "{} -> {}", s, p);
        }
    }
}

/// A file above `PARALLEL_MIN_BYTES`: comment lines before the header, CRLF endings, blank
/// and comment lines scattered through the body, an extra column.
fn big_file(rows: usize) -> String {
    let mut t = String::from("# exported by a tracker\r\n\r\nq1,q2,q3,q4,q5,q6,x,y,z,temp\r\n");
    for i in 0..rows {
        if i % 997 == 0 {
            t.push_str("# a comment in the body\r\n\r\n");
        }
        let v = i as f64 * 0.001;
        t.push_str(&format!(
            "{v:.6},{:.6},{:.6},1.5,-2.5,3.5,{:.8},{:.8},{:.8},{}\r\n",
            -v,
            2.0 * v,
            100.0 + v,
            -200.0 - v,
            300.0,
            20 + i % 5
        ));
    }
    t
}

#[test]
fn a_large_file_read_in_parts_equals_one_reader() {
    let text = big_file(30_000);
    assert!(text.len() > measurements::PARALLEL_MIN_BYTES);
    let parts = measurements::read_bytes::<6>(text.as_bytes()).unwrap();
    let whole = read6(&text).unwrap();
    assert_eq!(parts.records.len(), 30_000);
    assert_eq!(parts, whole, "records, extra columns and line numbers");
}

#[test]
fn an_error_deep_in_a_large_file_names_its_line() {
    let text = big_file(30_000);
    // Damage a row in the last part and one in the middle: the first one is reported.
    for frac in [0.97, 0.5] {
        let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
        let k = (lines.len() as f64 * frac) as usize;
        let bad = lines[k].replacen(',', ",x", 1);
        lines[k] = &bad;
        let damaged: String = lines.concat();
        let e = measurements::read_bytes::<6>(damaged.as_bytes()).expect_err("refused");
        let one = read6(&damaged).expect_err("refused");
        assert_eq!(e, one);
        assert_eq!(e.line as usize, k + 1, "1-based line of the damaged row");
    }
}
