//! A file in another layout, turned into the text of kinecal's own layout (docs/formats.md,
//! "Measurement CSV") line for line: the columns kinecal reads, under kinecal's names, each
//! number written so that it reads back as the very `f64` it stands for.
//!
//! What the map converts here: the orientation (its unit and the order of its three angles),
//! the per-axis angle σ (combined into one `srot_deg`) and the columns named with their unit
//! (`sx_mm`, `length_mm`, …), a time written as a date (`t_s` in seconds since 1970-01-01
//! 00:00:00 of the file's clock). Joint readings and positions are left as written: the map's
//! `joints` and `length` act as `--angle-unit` and `--length-unit` at the units door.

use super::layout::{cell_text, number, Line};
use super::spec::{ColumnRef, Delimiter, MapFile, TimeFields};
use crate::formats::rotation_order::RotationOrder;
use crate::formats::units::{mm_of_m, AngleUnit, FileKind, LengthUnit};
use std::fmt::Write as _;

/// What kind of value a kinecal column holds, for its conversion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// `q1`…`qN`, `x`, `y`, `z`, `x_NAME`…: as written (converted at the units door).
    Raw,
    /// A length named in millimetres (`sx_mm`, `length_mm`, `sigma_mm`).
    Millimetres,
    /// One angle of a measured orientation (`rx_deg`, `ry_deg`, `rz_deg`): axis 0, 1, 2.
    Orientation(usize),
    /// One angle of a target orientation (`rx`, `ry`, `rz`), written in the joints' unit.
    TargetAngle(usize),
    /// An angular 1-σ (`srot_deg`).
    AngleSigma,
    /// `t_s` written as a date and time (the map's `[units] time` pattern).
    Time,
}

fn kind_of(name: &str) -> Kind {
    match name {
        "rx_deg" => Kind::Orientation(0),
        "ry_deg" => Kind::Orientation(1),
        "rz_deg" => Kind::Orientation(2),
        "rx" => Kind::TargetAngle(0),
        "ry" => Kind::TargetAngle(1),
        "rz" => Kind::TargetAngle(2),
        "srot_deg" => Kind::AngleSigma,
        n if n.ends_with("_mm") => Kind::Millimetres,
        _ => Kind::Raw,
    }
}

/// Where a kinecal column's value comes from.
#[derive(Clone, Debug)]
enum Source {
    /// A cell of the file (0-based column).
    Cell(usize),
    /// The RMS of three angular σ cells (`srx_deg`, `sry_deg`, `srz_deg`).
    SigmaRms([usize; 3]),
}

/// One column of the translated file.
#[derive(Clone, Debug)]
pub struct Column {
    pub name: String,
    source: Source,
    kind: Kind,
    /// Whether every row must give a number (a joint reading or `x`, `y`, `z`).
    required: bool,
    /// The file's name for it, for messages.
    file_name: String,
}

impl Column {
    /// The file's column (1-based) this column reads, for messages.
    pub fn file_column(&self) -> usize {
        match &self.source {
            Source::Cell(k) | Source::SigmaRms([k, _, _]) => k + 1,
        }
    }
}

/// The translated text, and what the checks behind the units door need.
pub struct Translated {
    /// The file in kinecal's layout, with the same line numbers as the file (one more, for
    /// the header line put first, when the file has none).
    pub text: String,
    pub columns: Vec<Column>,
    /// The measured orientation of each row as the file states it (degrees about x, y, z,
    /// before the map's order is applied), when it has one.
    pub raw_angles: Vec<[f64; 3]>,
    /// Line numbers of `text` are the file's plus this (1 without a header line, else 0).
    pub line_shift: u32,
}

/// The column index a reference names, refused (exit 2) when the file has no such column.
fn resolve(
    r: &ColumnRef,
    header: Option<&[String]>,
    width: usize,
    key: &str,
    origins: (&str, &str),
) -> anyhow::Result<usize> {
    let (data, map) = origins;
    match r {
        ColumnRef::Number(k) => {
            let k = *k as usize;
            if k > width {
                crate::refuse!(
                    "{map}: [columns] {key} = {k}: {data} has {width} columns: give a column number from 1 to {width}"
                );
            }
            Ok(k - 1)
        }
        ColumnRef::Name(n) => {
            let h = header.unwrap_or(&[]);
            let at: Vec<usize> = (0..h.len()).filter(|&k| h[k] == *n).collect();
            if let [first, second, ..] = at[..] {
                crate::refuse!(
                    "{map}: [columns] {key} = {n:?}: {data}'s header names {} columns {n:?} \
                     (columns {} and {}): give the one meant by its number ({key} = {} or {})",
                    at.len(),
                    first + 1,
                    second + 1,
                    first + 1,
                    second + 1
                );
            }
            h.iter().position(|c| c == n).ok_or_else(|| {
                let mut list: Vec<&str> = h.iter().take(12).map(String::as_str).collect();
                if h.len() > 12 {
                    list.push("…");
                }
                crate::refused(format!(
                    "{map}: [columns] {key} = {n:?}: {data} has no such column (its header: {}): give the name as the header writes it",
                    list.join(", ")
                ))
            })
        }
    }
}

/// kinecal's column names besides `qK` and `x_NAME` (docs/formats.md, "Measurement CSV",
/// "Sweep files", "Target and command files").
const KNOWN_NAMES: [&str; 17] = [
    "x", "y", "z", "rx_deg", "ry_deg", "rz_deg", "sx_mm", "sy_mm", "sz_mm", "srot_deg", "temp_c",
    "t_s", "sweep", "rx", "ry", "rz", "tool",
];

/// Whether a header cell is already one of kinecal's column names ([`KNOWN_NAMES`], `qK`,
/// `x_NAME`), read as it is.
fn kinecal_name(name: &str) -> bool {
    let joint = name
        .strip_prefix('q')
        .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()));
    let point = ["x_", "y_", "z_"].iter().any(|p| {
        name.strip_prefix(p).is_some_and(|r| {
            !r.is_empty() && r.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
        })
    });
    (joint || point || KNOWN_NAMES.contains(&name)) && name.len() <= kinecal::io::csv::NAME_LEN
}

/// Refuses (exit 2) a `[columns]` key that is none of the column names kinecal reads in a
/// file of `kind`: a slip (`temp` for `temp_c`, `X` for `x`, a target's `rx` for a measured
/// `rx_deg`) would otherwise be carried along unread and its column's values silently left
/// out of the fit. Names the closest of kinecal's names when one is near (a name cut short
/// first: `temp` is `temp_c`).
fn unknown_name(key: &str, (n, kind): (usize, FileKind), map_origin: &str) -> anyhow::Result<()> {
    const PER_AXIS: [&str; 3] = ["srx_deg", "sry_deg", "srz_deg"];
    // A target's orientation, read by compensate only; `tool` is a constraint file's column,
    // and constraint files are not read through a map.
    let target = ["rx", "ry", "rz"];
    let read_here = |m: &str| m != "tool" && (kind == FileKind::Targets || !target.contains(&m));
    if (kinecal_name(key) || PER_AXIS.contains(&key)) && read_here(key) {
        return Ok(());
    }
    if target.contains(&key) {
        crate::refuse!(
            "{map_origin}: [columns] {key}: a target file's orientation (compensate); a measured \
             orientation is {key}_deg: use {key}_deg as the key"
        );
    }
    if key.len() > kinecal::io::csv::NAME_LEN {
        crate::refuse!(
            "{map_origin}: [columns] {key}: longer than kinecal's {} bytes for a column name \
             (a reflector's x_NAME included): shorten the reflector's name here and in the \
             robot file's [[tools]]",
            kinecal::io::csv::NAME_LEN
        );
    }
    // A quaternion component (`qw` would be taken for a typo of `q1`): kinecal reads angles.
    let bare = key.to_ascii_lowercase().replace(['_', '-', '.'], "");
    let quaternion = ["qw", "qx", "qy", "qz", "quatw", "quatx", "quaty", "quatz"];
    if quaternion.contains(&bare.as_str()) {
        crate::refuse!(
            "{map_origin}: [columns] {key}: a quaternion component; kinecal reads orientations \
             as fixed-axis angles rx_deg, ry_deg, rz_deg (docs/formats.md, \"Observations\"): \
             convert the quaternion to them (mind its order, w first or last), or leave the \
             orientation out for a positions calibration"
        );
    }
    let names: Vec<String> = (1..=n)
        .map(|j| format!("q{j}"))
        .chain(
            KNOWN_NAMES
                .iter()
                .chain(PER_AXIS.iter())
                .filter(|m| read_here(m))
                .map(|s| s.to_string()),
        )
        .collect();
    let lower = key.to_ascii_lowercase();
    let near = names
        .iter()
        .map(|m| {
            let d = strsim::damerau_levenshtein(&lower, m);
            // `temp` for `temp_c`, `sx_m` for `sx_mm`: a name cut short is as near as a typo,
            // and nearer than another name as many edits away.
            let cut = m.starts_with(&lower) && lower.len() >= 2;
            ((if cut { d.min(1) } else { d }, !cut), m)
        })
        // Two edits make a short name into most others (`foo`, `tool`): one for short names.
        .filter(|((d, _), m)| *d <= if lower.len() >= 5 { 2 } else { 1 } && *d < m.len())
        .min_by_key(|(rank, _)| *rank)
        .map(|(_, m)| m);
    match near {
        Some(m) => crate::refuse!(
            "{map_origin}: [columns] {key}: kinecal reads no column of that name (did you mean \
             {m}?): use kinecal's name as the key, {m} = \"the file's column name\" \
             (docs/formats.md, \"Measurement CSV\"), or leave it out"
        ),
        None => crate::refuse!(
            "{map_origin}: [columns] {key}: kinecal reads no column of that name: its names are \
             q1 … q{n}, x, y, z, x_NAME … for further reflectors, rx_deg, ry_deg, rz_deg, sx_mm, \
             sy_mm, sz_mm, srot_deg (or srx_deg, sry_deg, srz_deg), temp_c, t_s, sweep, and \
             rx, ry, rz of targets (docs/formats.md, \"Measurement CSV\"); use one as the key, \
             or leave out the columns kinecal does not read"
        ),
    }
}

/// Whether kinecal's column `name` is a joint reading or a coordinate (of a point or an
/// orientation): no two of them come from one column of a file.
fn one_of_a_kind(name: &str) -> bool {
    let joint = name
        .strip_prefix('q')
        .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()));
    joint
        || [
            "x", "y", "z", "rx_deg", "ry_deg", "rz_deg", "rx", "ry", "rz",
        ]
        .contains(&name)
        || ["x_", "y_", "z_"].iter().any(|p| name.starts_with(p))
}

/// The columns of the translated file: `q1`…`qN`, `x`, `y`, `z` first, then the others in the
/// file's order; the file's columns the map does not name are read too when they carry one
/// of kinecal's names (`q3`, `temp_c`, …); any other column is left out.
fn plan(
    map: &MapFile,
    (n, kind): (usize, FileKind),
    header: Option<&[String]>,
    width: usize,
    origins: (&str, &str),
) -> anyhow::Result<Vec<Column>> {
    let (data, map_origin) = origins;
    let mut named: Vec<(String, usize)> = Vec::new();
    let mut per_axis = [None; 3];
    for (key, r) in &map.columns {
        unknown_name(key, (n, kind), map_origin)?;
        if let Some(j) = key.strip_prefix('q').and_then(|k| k.parse::<usize>().ok()) {
            if j == 0 || j > n {
                crate::refuse!(
                    "{map_origin}: [columns] {key}: the robot has {n} joints (q1 to q{n})"
                );
            }
        }
        let k = resolve(r, header, width, key, origins)?;
        // A joint reading or a coordinate read twice from one column is a slip of the map
        // (σ columns may share one: a tracker that states one uncertainty).
        if one_of_a_kind(key) {
            if let Some((other, _)) = named.iter().find(|(o, c)| *c == k && one_of_a_kind(o)) {
                crate::refuse!(
                    "{map_origin}: [columns] {other} and {key} name the same column of {data}: \
                     each joint reading and coordinate has a column of its own; correct the map"
                );
            }
        }
        match key.as_str() {
            "srx_deg" => per_axis[0] = Some(k),
            "sry_deg" => per_axis[1] = Some(k),
            "srz_deg" => per_axis[2] = Some(k),
            _ => named.push((key.clone(), k)),
        }
    }
    let used: Vec<usize> = named
        .iter()
        .map(|(_, k)| *k)
        .chain(per_axis.iter().flatten().copied())
        .collect();
    if let Some(h) = header {
        for (k, c) in h.iter().enumerate() {
            if !used.contains(&k) && kinecal_name(c) && !named.iter().any(|(m, _)| m == c) {
                named.push((c.clone(), k));
            }
        }
    }
    let file_name = |k: usize| {
        header
            .and_then(|h| h.get(k))
            .map_or(format!("column {}", k + 1), |c| format!("`{c}`"))
    };
    let mut required: Vec<String> = (1..=n).map(|j| format!("q{j}")).collect();
    let several = named.iter().any(|(c, _)| c.starts_with("x_"));
    let has_xyz = named
        .iter()
        .any(|(c, _)| ["x", "y", "z"].contains(&c.as_str()));
    if !several || has_xyz {
        required.extend(["x", "y", "z"].map(String::from));
    }
    let mut columns = Vec::new();
    for want in &required {
        let Some((_, k)) = named.iter().find(|(c, _)| c == want) else {
            crate::refuse!(
                "{data}: no column for {want} (read with --map {map_origin}): name it in the map's [columns], {want} = \"the file's column name\" (or its number)"
            );
        };
        columns.push(Column {
            name: want.clone(),
            source: Source::Cell(*k),
            kind: Kind::Raw,
            required: true,
            file_name: file_name(*k),
        });
    }
    let mut rest: Vec<(String, Source)> = named
        .into_iter()
        .filter(|(c, _)| !required.contains(c))
        .map(|(c, k)| (c, Source::Cell(k)))
        .collect();
    if let [Some(a), Some(b), Some(c)] = per_axis {
        rest.push(("srot_deg".into(), Source::SigmaRms([a, b, c])));
    }
    rest.sort_by_key(|(_, s)| match s {
        Source::Cell(k) | Source::SigmaRms([k, _, _]) => *k,
    });
    for (name, source) in rest {
        let first = match &source {
            Source::Cell(k) | Source::SigmaRms([k, _, _]) => *k,
        };
        columns.push(Column {
            kind: kind_of(&name),
            file_name: file_name(first),
            name,
            source,
            required: false,
        });
    }
    if let Some(pattern) = &map.units.time {
        match columns.iter_mut().find(|c| c.name == "t_s") {
            Some(c) => c.kind = Kind::Time,
            None => crate::refuse!(
                "{map_origin}: [units] time = {pattern:?} but no t_s column: name the file's time column in [columns], t_s = \"its name\" (or its 1-based number)"
            ),
        }
    }
    for group in [
        [
            Kind::Orientation(0),
            Kind::Orientation(1),
            Kind::Orientation(2),
        ],
        [
            Kind::TargetAngle(0),
            Kind::TargetAngle(1),
            Kind::TargetAngle(2),
        ],
    ] {
        let found = group
            .iter()
            .filter(|g| columns.iter().any(|c| c.kind == **g))
            .count();
        if found > 0 && found < 3 && map.rotation != RotationOrder::KINECAL {
            crate::refuse!(
                "{map_origin}: [units] rotation = \"{}\" needs all three angles (rx_deg, ry_deg, rz_deg, or rx, ry, rz for targets) in [columns]",
                map.rotation.text()
            );
        }
    }
    Ok(columns)
}

/// One row's value of each column: `Ok(None)` for an empty cell (or a column the line is too
/// short for); `Err(column)` when a required cell is missing or not a number.
fn values(
    columns: &[Column],
    cells: &[&str],
    decimal_comma: bool,
    time: Option<(&str, TimeFields)>,
) -> Result<Vec<Option<f64>>, usize> {
    let cell = |k: usize, required: bool, c: usize| -> Result<Option<f64>, usize> {
        match cells.get(k) {
            None if required => Err(c),
            None => Ok(None),
            Some(t) => match number(t, decimal_comma) {
                Ok(v) => Ok(v),
                Err(_) if required => Err(c),
                Err(_) => Ok(None),
            },
        }
    };
    columns
        .iter()
        .enumerate()
        .map(|(c, col)| match col.source {
            Source::Cell(k) if col.kind == Kind::Time => {
                match (cells.get(k).map(|t| cell_text(t)), time) {
                    (None | Some(""), _) => Ok(None),
                    (Some(t), Some((pattern, fields))) => {
                        seconds_of(t, pattern, fields).map(Some).ok_or(c)
                    }
                    (Some(_), None) => Err(c),
                }
            }
            Source::Cell(k) => match cell(k, col.required, c)? {
                None if col.required => Err(c),
                v => Ok(v),
            },
            Source::SigmaRms(ks) => {
                let mut ss = 0.0;
                for k in ks {
                    match cell(k, false, c)? {
                        Some(v) => ss += v * v,
                        None => return Ok(None),
                    }
                }
                Ok(Some((ss / 3.0).sqrt()))
            }
        })
        .collect()
}

/// Seconds since 1970-01-01 00:00:00 of the time `text` states, read with the strftime
/// `pattern`, which states `fields` (a date alone is its midnight; with a zone offset, UTC);
/// `None` when the text does not match it.
fn seconds_of(text: &str, pattern: &str, fields: TimeFields) -> Option<f64> {
    use chrono::{DateTime, NaiveDate, NaiveDateTime};
    let t = match fields {
        TimeFields::Instant => DateTime::parse_from_str(text, pattern)
            .ok()
            .map(|t| t.to_utc())
            .or_else(|| Some(NaiveDateTime::parse_from_str(text, pattern).ok()?.and_utc()))?,
        TimeFields::DateTime => NaiveDateTime::parse_from_str(text, pattern).ok()?.and_utc(),
        TimeFields::Date => NaiveDate::parse_from_str(text, pattern)
            .ok()?
            .and_hms_opt(0, 0, 0)?
            .and_utc(),
    };
    Some(t.timestamp() as f64 + f64::from(t.timestamp_subsec_nanos()) * 1e-9)
}

/// Converts one row's values in place (see the module documentation); returns the measured
/// orientation as the file states it (degrees), when the row has one.
fn convert(map: &MapFile, columns: &[Column], v: &mut [Option<f64>]) -> Option<[f64; 3]> {
    let orient = map.units.orientation.unwrap_or(AngleUnit::Deg);
    let joints = map.units.joints.unwrap_or(AngleUnit::Deg);
    let mut raw = None;
    for (group, target) in [
        (Kind::Orientation as fn(usize) -> Kind, false),
        (Kind::TargetAngle, true),
    ] {
        let at: Vec<usize> = (0..3)
            .filter_map(|a| columns.iter().position(|c| c.kind == group(a)))
            .collect();
        if at.len() != 3 {
            // An incomplete orientation is kinecal's own (the map refuses another order then):
            // only the unit changes.
            for k in at {
                v[k] = v[k].map(|x| orient.to_deg(x));
                if target {
                    v[k] = v[k].map(|d| joints.from_deg(d));
                }
            }
            continue;
        }
        let (Some(a), Some(b), Some(c)) = (v[at[0]], v[at[1]], v[at[2]]) else {
            continue;
        };
        let deg = [a, b, c].map(|x| orient.to_deg(x));
        if !target {
            raw = Some(deg);
        }
        let k = map.rotation.to_kinecal_deg(deg);
        for (i, &col) in at.iter().enumerate() {
            v[col] = Some(if target { joints.from_deg(k[i]) } else { k[i] });
        }
    }
    let length = map.units.length.unwrap_or(LengthUnit::Mm);
    for (col, x) in columns.iter().zip(v.iter_mut()) {
        match col.kind {
            Kind::AngleSigma => *x = x.map(|s| orient.to_deg(s)),
            Kind::Millimetres if length == LengthUnit::M => *x = x.map(mm_of_m),
            _ => {}
        }
    }
    raw
}

/// Translates the content `lines` of the file (`origins`: the data file and the map file, for
/// messages) for an `n`-joint robot. Refused (exit 2): a column the map names that the file
/// lacks, a missing required column, a required cell that is not a number.
pub fn translate(
    map: &MapFile,
    lines: &[Line<'_>],
    (n, kind): (usize, FileKind),
    origins: (&str, &str),
) -> anyhow::Result<Translated> {
    let (data, map_origin) = origins;
    let Some(first) = lines.first() else {
        crate::refuse!("{data}:1:1: empty file: no header line");
    };
    let delimiter = match map.delimiter {
        Some(d) => d,
        None => super::layout::detect(lines, map.decimal_comma).ok_or_else(|| {
            crate::refused(format!(
                "{data}: cannot tell its delimiter (the first lines split into different numbers of cells by \",\", \";\", tab and spaces): state it in {map_origin}, delimiter = \";\""
            ))
        })?,
    };
    let header: Option<Vec<String>> = map.header.then(|| {
        delimiter
            .split(first.text)
            .iter()
            .map(|c| cell_text(c).to_string())
            .collect()
    });
    if let Some(h) = &header {
        let numeric = |c: &String| number(c, map.decimal_comma).is_ok_and(|v| v.is_some());
        if h.len() >= 2 && h.iter().all(numeric) {
            crate::refuse!(
                "{data}:{}: the first line is numbers, not a header ({}): a header = true map \
                 would read that row as the names and lose it; say header = false in \
                 {map_origin} and name the columns by number",
                first.number,
                h.iter().take(4).cloned().collect::<Vec<_>>().join(", ")
            );
        }
    }
    let width = header
        .as_ref()
        .map_or_else(|| delimiter.split(first.text).len(), Vec::len);
    if let (Delimiter::Space, Some(pattern)) = (delimiter, &map.units.time) {
        if pattern.contains(char::is_whitespace) {
            crate::refuse!(
                "{map_origin}: [units] time = {pattern:?} has spaces, but {data}'s cells are separated by spaces: a time would be split; give the file's other delimiter, or a pattern without spaces"
            );
        }
    }
    let columns = plan(map, (n, kind), header.as_deref(), width, origins)?;
    // The pattern classified once (the map was checked when read: `of` accepts it).
    let time = map
        .units
        .time
        .as_deref()
        .and_then(|p| Some((p, TimeFields::of(p).ok()?)));
    let body = if map.header { &lines[1..] } else { lines };
    let line_shift = u32::from(!map.header);
    let mut text = String::new();
    let mut at_line = 1u32;
    let mut newline_to = |text: &mut String, line: u32| {
        while at_line < line + line_shift {
            text.push('\n');
            at_line += 1;
        }
    };
    let head: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
    if map.header {
        newline_to(&mut text, first.number);
    }
    text.push_str(&head.join(","));
    let mut raw_angles = Vec::with_capacity(body.len());
    // Words in the columns read as empty when no number (a placeholder); mostly words: refused.
    let mut words = vec![crate::formats::text_cells::Words::default(); columns.len()];
    for line in body {
        newline_to(&mut text, line.number);
        let cells = delimiter.split(line.text);
        for (col, w) in columns.iter().zip(&mut words) {
            if let (Source::Cell(k), false) = (&col.source, col.kind == Kind::Time) {
                let t = cells.get(*k).map_or("", |c| cell_text(c));
                let is_number = number(t, map.decimal_comma).is_ok_and(|v| v.is_some());
                w.count(line.number, t, is_number);
            }
        }
        let mut v = values(
            &columns,
            &cells,
            map.decimal_comma,
            time,
        )
        .map_err(|c| {
            let col = &columns[c];
            let k = col.file_column();
            if let (Some(t), Kind::Time) = (cells.get(k - 1), col.kind) {
                return crate::refused(format!(
                    "{data}:{}:{k}: '{}' in column {} (kinecal's t_s) does not match [units] time = {:?} of {map_origin}: correct the cell, or give the pattern the file writes its times in",
                    line.number,
                    cell_text(t).chars().take(40).collect::<String>(),
                    col.file_name,
                    map.units.time.as_deref().unwrap_or("")
                ));
            }
            let what = match cells.get(k - 1) {
                None => "no cell".to_string(),
                Some(t) => {
                    let t = cell_text(t);
                    let mut s =
                        format!("not a number: '{}'", t.chars().take(40).collect::<String>());
                    let unit_word = ["rad", "deg", "°", "mm", "m", "s", "degc", "°c", "in"]
                        .contains(&t.trim().trim_matches(['[', ']', '(', ')']).to_lowercase().as_str());
                    if unit_word {
                        s.push_str(
                            " (a row of units under the header? put # at the start of that line \
                             and state the units in the map's [units])",
                        );
                    } else if t.contains(',') && t.contains('.') {
                        // "1.144,21" or "1,144.21": one of them groups thousands.
                        s.push_str(
                            " (a thousands separator: the cell holds both '.' and ','; write \
                             the numbers without grouping)",
                        );
                    } else if !map.decimal_comma && t.contains(',') {
                        // "-3,241": three digits after each comma can be either.
                        let grouped = t.split(',').skip(1).all(|g| {
                            g.len() == 3 && g.bytes().all(|b| b.is_ascii_digit())
                        });
                        s.push_str(&if grouped {
                            format!(
                                " (a decimal comma, or a comma grouping thousands? for a decimal \
                                 comma say decimal = \",\" in {map_origin}; for thousands write \
                                 the numbers without grouping)"
                            )
                        } else {
                            format!(" (a decimal comma? say decimal = \",\" in {map_origin})")
                        });
                    } else if map.decimal_comma && t.contains('.') {
                        s.push_str(&format!(
                            " (a decimal point: {map_origin} says decimal = \",\")"
                        ));
                    }
                    s
                }
            };
            crate::refused(format!(
                "{data}:{}:{k}: {what} in column {} (kinecal's {}); delimiter {}",
                line.number,
                col.file_name,
                col.name,
                delimiter.text()
            ))
        })?;
        if let Some(r) = convert(map, &columns, &mut v) {
            raw_angles.push(r);
        } else if columns.iter().any(|c| c.kind == Kind::Orientation(0)) {
            raw_angles.push([f64::NAN; 3]);
        }
        for (k, x) in v.iter().enumerate() {
            if k > 0 {
                text.push(',');
            }
            if let Some(x) = x {
                // `{:?}` is the shortest text that reads back as the same f64.
                let _ = write!(text, "{x:?}");
            }
        }
    }
    text.push('\n');
    for (col, w) in columns.iter().zip(&words) {
        let how = format!(" (the file's {})", col.file_name);
        if let Some(why) = w.refusal(data, &col.name, &how) {
            crate::refuse!("{why}");
        }
    }
    Ok(Translated {
        text,
        columns,
        raw_angles,
        line_shift,
    })
}
