//! Measurement CSV files (docs/formats.md) on the desktop: the library's streaming
//! [`kinecal::io::csv::CsvReader`] over a file, errors turned into one line
//! `FILE:LINE:COLUMN: description`, and a writer.

use anyhow::anyhow;
use embedded_io_adapters::std::FromStd;
use kinecal::io::csv::{column_name, CsvError, CsvErrorKind, CsvReader, MAX_ABS_JOINT, MAX_ABS_MM};
use kinecal::{Measurement, Real};
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Read, Seek};
use std::path::Path;

/// Longest line accepted, bytes (the UR10 files use ~110).
pub const LINE_CAPACITY: usize = 4096;
/// Most extra columns carried by name (more are ignored).
pub const MAX_EXTRA: usize = 40;
/// Decimals written for joint readings (degrees); [`quantize_deg`] rounds to them.
pub const Q_DECIMALS: usize = 6;
/// Decimals written for measured points (millimetres).
pub const XYZ_DECIMALS: usize = 8;

/// The extra column carrying the arm's temperature (°C) of each row: what a model's
/// thermal-expansion term is evaluated at.
pub const TEMPERATURE_COLUMN: &str = "temp_c";

/// The extra column carrying the time (s, the session's clock) of each row: what a model's
/// base-drift term is evaluated at.
pub const TIME_COLUMN: &str = "t_s";

/// One measured pose in file units.
#[derive(Clone, Debug, PartialEq)]
pub struct Record<const N: usize> {
    pub q_deg: [f64; N],
    pub xyz_mm: [f64; 3],
    /// Values of the extra columns, in the order of [`Dataset::extra_names`] (NaN = empty cell).
    pub extra: Vec<f64>,
    /// Line of the file (0 for records made in memory).
    pub line: u32,
}

impl<const N: usize> Record<N> {
    /// A record without extra columns.
    pub fn new(q_deg: [f64; N], xyz_mm: [f64; 3]) -> Self {
        Self {
            q_deg,
            xyz_mm,
            extra: Vec::new(),
            line: 0,
        }
    }

    /// In library units (rad, mm).
    pub fn measurement<T: Real>(&self) -> Measurement<T, N> {
        Measurement::from_deg(&self.q_deg, &self.xyz_mm)
    }
}

/// The records of one file.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Dataset<const N: usize> {
    pub records: Vec<Record<N>>,
    pub extra_names: Vec<String>,
}

impl<const N: usize> Dataset<N> {
    pub fn len(&self) -> usize {
        self.records.len()
    }
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// All records in library units (rad, mm), with the [`TEMPERATURE_COLUMN`] and the
    /// [`TIME_COLUMN`] (when the file has them and the cell is not empty) as each
    /// measurement's `temp_c` and `time_s`.
    pub fn measurements<T: Real>(&self) -> Vec<Measurement<T, N>> {
        let temp = self
            .extra_names
            .iter()
            .position(|n| n == TEMPERATURE_COLUMN);
        let time = self.extra_names.iter().position(|n| n == TIME_COLUMN);
        self.records
            .iter()
            .map(|r| {
                let mut m: Measurement<T, N> = r.measurement();
                m.temp_c = temp
                    .and_then(|k| r.extra.get(k).copied())
                    .filter(|t| t.is_finite())
                    .map(T::of);
                m.time_s = time
                    .and_then(|k| r.extra.get(k).copied())
                    .filter(|t| t.is_finite())
                    .map(T::of);
                m
            })
            .collect()
    }

    /// The values of an extra column, if the file has it.
    pub fn extra(&self, name: &str) -> Option<Vec<f64>> {
        let k = self.extra_names.iter().position(|n| n == name)?;
        Some(
            self.records
                .iter()
                .map(|r| r.extra.get(k).copied().unwrap_or(f64::NAN))
                .collect(),
        )
    }

    /// `(min, max)` of every joint reading, degrees (`(inf, -inf)` when empty).
    pub fn joint_ranges_deg(&self) -> [(f64, f64); N] {
        let mut r = [(f64::INFINITY, f64::NEG_INFINITY); N];
        for rec in &self.records {
            for (m, q) in r.iter_mut().zip(rec.q_deg) {
                m.0 = m.0.min(q);
                m.1 = m.1.max(q);
            }
        }
        r
    }
}

/// Rounds a joint reading to the decimals the writer keeps, so that a model evaluated at the
/// rounded value matches what a reader of the file will evaluate.
pub fn quantize_deg(q: f64) -> f64 {
    let s = 10f64.powi(Q_DECIMALS as i32);
    (q * s).round() / s
}

/// The name of required column `which` of a `MissingColumn` error (`q1`…`qN`, `x`, `y`, `z`).
pub fn required_column_name(which: usize, n: usize) -> String {
    if which < n {
        format!("q{}", which + 1)
    } else {
        ["x", "y", "z"].get(which - n).unwrap_or(&"?").to_string()
    }
}

/// Reads all records from a byte stream with the library reader.
pub fn read_records<const N: usize, R: Read>(reader: R) -> Result<Dataset<N>, CsvError> {
    let mut csv: CsvReader<FromStd<R>, N, LINE_CAPACITY, MAX_EXTRA> =
        CsvReader::new(FromStd::new(reader))?;
    let extra_names = csv.extra_names().iter().map(|s| s.to_string()).collect();
    let mut records = Vec::new();
    while let Some(r) = csv.next_record() {
        let r = r?;
        records.push(Record {
            q_deg: r.q_deg,
            xyz_mm: r.xyz_mm,
            extra: r.extra.iter().copied().collect(),
            line: r.line,
        });
    }
    Ok(Dataset {
        records,
        extra_names,
    })
}

/// One-line description of a CSV error: `ORIGIN:LINE:COLUMN: what (column NAME: 'cell')`.
/// `text_line` is the offending line's text when available, `header` the header's cells.
pub fn describe_error(
    origin: &str,
    e: &CsvError,
    n: usize,
    header: Option<&[String]>,
    text_line: Option<&str>,
) -> String {
    let line = e.line.max(1);
    let mut col = e.column as usize;
    let mut msg = e.kind.describe().to_string();
    match e.kind {
        CsvErrorKind::DuplicateColumn | CsvErrorKind::MissingColumn
            if header.is_some_and(|h| h.iter().all(|c| c.trim().parse::<f64>().is_ok())) =>
        {
            msg = format!(
                "the first line is numbers, not a header: add the header line (q1..q{n}, x, y, \
                 z, …), or read the file with --map M.toml and header = false"
            );
            col = 1;
        }
        CsvErrorKind::MissingColumn => {
            let name = required_column_name(e.which as usize, n);
            msg = format!(
                "missing required column `{name}` (the header needs q1..q{n}, x, y, z; a file \
                 in another layout: read it with --map M.toml, docs/formats.md \"Files in other \
                 layouts\")"
            );
            col = 1;
        }
        CsvErrorKind::LineTooLong => {
            msg = format!("line longer than {LINE_CAPACITY} bytes");
            col = LINE_CAPACITY + 1;
            // The whole file read as one line: its lines end in a carriage return alone.
            if text_line.is_some_and(|t| t.contains('\r')) {
                msg.push_str(
                    " (the lines end in a carriage return alone, an old Mac format: save the \
                     file with LF or CRLF line ends)",
                );
            }
        }
        CsvErrorKind::NotText => {
            if text_line.is_some_and(|t| t.contains('\0')) {
                msg.push_str(
                    " (the file looks UTF-16, a zero byte beside each character: save it as UTF-8)",
                );
            }
        }
        CsvErrorKind::TooManyJoints => {
            let name = header
                .and_then(|h| h.get(col.wrapping_sub(1)))
                .cloned()
                .unwrap_or_default();
            msg = format!("joint column `{name}` beyond the robot's {n} joints");
        }
        CsvErrorKind::ExtraCell => {
            let columns = header.map_or(col.saturating_sub(1), |h| h.len());
            msg = format!("more cells than the header's {columns} columns");
            if let Some(cell) = text_line.and_then(|t| t.split(',').nth(col.wrapping_sub(1))) {
                let cell = cell.trim();
                if !cell.is_empty() && cell.len() <= 40 {
                    msg.push_str(&format!(": '{cell}'"));
                }
            }
            if text_line.is_some_and(looks_like_decimal_commas) {
                msg.push_str(" (looks like a decimal comma: use '.' as the decimal separator)");
            }
        }
        _ => {
            if col > 0 {
                if let Some(name) = header.and_then(|h| h.get(col - 1)) {
                    msg.push_str(&format!(" in column `{name}`"));
                }
                if let Some(cell) = text_line.and_then(|t| t.split(',').nth(col - 1)) {
                    let cell = cell.trim();
                    if !cell.is_empty() && cell.len() <= 40 {
                        msg.push_str(&format!(": '{cell}'"));
                    }
                    if e.kind == CsvErrorKind::NotANumber
                        && cell.len() >= 2
                        && ['"', '\'']
                            .iter()
                            .any(|q| cell.starts_with(*q) && cell.ends_with(*q))
                    {
                        msg.push_str(" (a quoted number: write the numbers without quotes)");
                    }
                }
                if e.kind == CsvErrorKind::OutOfRange {
                    msg.push_str(&format!(
                        " (joint readings must be within ±{MAX_ABS_JOINT:e}, x, y, z within \
                         ±{MAX_ABS_MM:e} mm)"
                    ));
                }
            }
        }
    }
    format!("{origin}:{line}:{}: {msg}", col.max(1))
}

/// Whether a line with more cells than its header looks written with decimal commas: no cell
/// with a decimal point, and two adjacent cells that are an integer and a digits-only fragment
/// (`79,500064`, `-0,5`).
fn looks_like_decimal_commas(line: &str) -> bool {
    if line.contains('.') {
        return false;
    }
    let integer = |c: &str| {
        let c = c.trim();
        let d = c.strip_prefix(['-', '+']).unwrap_or(c);
        !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit())
    };
    let cells: Vec<&str> = line.split(',').collect();
    cells.windows(2).any(|w| {
        let frac = w[1].trim();
        integer(w[0]) && !frac.is_empty() && frac.bytes().all(|b| b.is_ascii_digit())
    })
}

/// Opens a file positioned after a UTF-8 byte-order mark, if it has one (spreadsheets write it).
fn open_skipping_bom(path: &Path) -> std::io::Result<std::fs::File> {
    let mut f = std::fs::File::open(path)?;
    let mut bom = [0u8; 3];
    let n = f.read(&mut bom)?;
    if !(n == 3 && bom == [0xEF, 0xBB, 0xBF]) {
        f.rewind()?;
    }
    Ok(f)
}

/// The header cells (first line that is neither blank nor a comment) and the text of line
/// `want` (1-based), read with std for error messages.
fn context_lines(path: &Path, want: u32) -> (Option<Vec<String>>, Option<String>) {
    let Ok(f) = open_skipping_bom(path) else {
        return (None, None);
    };
    let mut header = None;
    let mut wanted = None;
    for (i, l) in BufReader::new(f).split(b'\n').enumerate() {
        let Ok(l) = l else { break };
        let text = String::from_utf8_lossy(&l)
            .trim_end_matches('\r')
            .to_string();
        let t = text.trim();
        if header.is_none() && !t.is_empty() && !t.starts_with('#') {
            header = Some(
                text.split(',')
                    .map(|c| column_name(c).to_string())
                    .collect(),
            );
        }
        if i + 1 == want as usize {
            wanted = Some(text);
        }
        if header.is_some() && (i + 1) as u32 >= want {
            break;
        }
    }
    (header, wanted)
}

/// Loads a measurement file for an `N`-joint robot, values as written (no unit conversion:
/// the commands load through [`crate::formats::units`]). Errors are one line naming the file, line and
/// column; malformed content is [`crate::Refused`] (exit status 2), an unreadable file is not.
pub fn load<const N: usize>(path: &Path) -> anyhow::Result<Dataset<N>> {
    let origin = path.display().to_string();
    // An input that cannot be read is refused like a malformed one (exit status 2): the user
    // must fix the path or the file.
    let file =
        FileBytes::open(path).map_err(|e| crate::refused(super::cannot_read(&origin, &e)))?;
    let bytes = file.bytes();
    let bytes = bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(bytes);
    // Malformed content is refused input (exit status 2, docs/formats.md "Command line: exit status and JSON").
    let ds = read_bytes::<N>(bytes).map_err(|e| {
        let (header, text) = context_lines(path, e.line);
        crate::refused(describe_error(
            &origin,
            &e,
            N,
            header.as_deref(),
            text.as_deref(),
        ))
    })?;
    // Cells the reader took for empty: words in a number column (only read again when any).
    let empty = |k: usize| {
        ds.records
            .iter()
            .any(|r| r.extra.get(k).is_some_and(|v| v.is_nan()))
    };
    if (0..ds.extra_names.len()).any(empty) {
        if let Some(why) = super::text_cells::refusal(bytes, &ds.extra_names, &origin) {
            crate::refuse!("{why}");
        }
    }
    Ok(ds)
}

/// A file's bytes: a large regular file mapped (the parsing threads read it in place, nothing
/// is copied and the pages are the system's file cache), anything else read into memory.
enum FileBytes {
    Mapped(memmap2::Mmap),
    Read(Vec<u8>),
}

impl FileBytes {
    fn open(path: &Path) -> std::io::Result<Self> {
        let file = std::fs::File::open(path)?;
        let meta = file.metadata()?;
        if meta.is_file() && meta.len() >= PARALLEL_MIN_BYTES as u64 {
            // SAFETY: the map is only read, while this command runs; a file truncated by
            // another program meanwhile is the one hazard (as for every program that maps its
            // input), and a measurement file is not written while it is being calibrated from.
            if let Ok(map) = unsafe { memmap2::Mmap::map(&file) } {
                return Ok(Self::Mapped(map));
            }
        }
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut &file, &mut bytes)?;
        Ok(Self::Read(bytes))
    }

    fn bytes(&self) -> &[u8] {
        match self {
            Self::Mapped(m) => m,
            Self::Read(v) => v,
        }
    }
}

/// Files larger than this are parsed in parts on several threads.
pub const PARALLEL_MIN_BYTES: usize = 1 << 20;

/// Reads all records of a whole file in memory: large files in [`crate::compute::parallel::PARTS`]
/// parts cut at line ends, each read by the library reader after the file's header lines, on
/// several threads. Records, line numbers and the first error are those of one reader over the
/// whole file.
pub fn read_bytes<const N: usize>(bytes: &[u8]) -> Result<Dataset<N>, CsvError> {
    let Some(body_start) = header_end(bytes).filter(|_| bytes.len() >= PARALLEL_MIN_BYTES) else {
        return read_records::<N, _>(bytes);
    };
    let (prefix, body) = bytes.split_at(body_start);
    let parts = split_at_lines(body, crate::compute::parallel::PARTS);
    let read = crate::compute::parallel::map_each(&parts, |part| {
        let lines = memchr::memchr_iter(b'\n', part).count() as u32;
        (read_records::<N, _>(prefix.chain(*part)), lines)
    });
    // The parts in order: the first error (its line counted from the file's start) is the
    // whole file's first.
    let mut parts = Vec::with_capacity(read.len());
    let mut before = 0u32;
    for (ds, lines) in read {
        let ds = ds.map_err(|e| CsvError {
            line: e.line.saturating_add(before),
            ..e
        })?;
        parts.push((ds, before));
        before = before.saturating_add(lines);
    }
    let total: usize = parts.iter().map(|(ds, _)| ds.len()).sum();
    let mut out = Dataset {
        extra_names: parts
            .last()
            .map(|(ds, _)| ds.extra_names.clone())
            .unwrap_or_default(),
        // One allocation of the final size: growing it part by part would hold the old and
        // the new list at once (and up to twice the records).
        records: crate::compute::huge_pages::with_capacity(total),
    };
    // Each part's records moved to their place on several threads (a part's reader numbers
    // the prefix's lines too, as the whole file's reader does: its lines are shifted by the
    // lines of the parts before it).
    let mut slots = &mut out.records.spare_capacity_mut()[..total];
    let mut jobs = Vec::with_capacity(parts.len());
    for (ds, before) in parts {
        let (here, rest) = slots.split_at_mut(ds.len());
        slots = rest;
        jobs.push((ds.records, here, before));
    }
    crate::compute::parallel::map_each_mut(&mut jobs, |(records, slots, before)| {
        for (r, slot) in std::mem::take(records).into_iter().zip(slots.iter_mut()) {
            slot.write(Record {
                line: r.line.saturating_add(*before),
                ..r
            });
        }
    });
    // SAFETY: the jobs' slots cover the first `total` slots exactly once, and every job wrote
    // each of its slots (its records are exactly as many as its slots, and it cannot fail).
    unsafe { out.records.set_len(total) };
    Ok(out)
}

/// The index just after the header line (the first line neither blank nor a comment, as the
/// library reader decides), `None` when there is no complete one.
fn header_end(bytes: &[u8]) -> Option<usize> {
    let mut start = 0;
    while let Some(len) = bytes[start..].iter().position(|b| *b == b'\n') {
        let t = bytes[start..start + len].trim_ascii();
        start += len + 1;
        if !(t.is_empty() || t[0] == b'#') {
            return Some(start);
        }
    }
    None
}

/// `bytes` cut into at most `parts` pieces of similar size, each ending at a line end (the
/// last at the end of `bytes`).
fn split_at_lines(bytes: &[u8], parts: usize) -> Vec<&[u8]> {
    let target = bytes.len().div_ceil(parts.max(1)).max(1);
    let mut out = Vec::with_capacity(parts);
    let mut rest = bytes;
    while !rest.is_empty() {
        let cut = if rest.len() <= target {
            rest.len()
        } else {
            rest[target..]
                .iter()
                .position(|b| *b == b'\n')
                .map_or(rest.len(), |k| target + k + 1)
        };
        let (head, tail) = rest.split_at(cut);
        out.push(head);
        rest = tail;
    }
    out
}

/// The joint count a measurement file is for: the largest `K` of its `qK` columns.
pub fn joint_count(path: &Path) -> anyhow::Result<usize> {
    let origin = path.display().to_string();
    let f = open_skipping_bom(path).map_err(|e| crate::refused(super::cannot_read(&origin, &e)))?;
    for (i, l) in BufReader::new(f).split(b'\n').enumerate() {
        let l = l.map_err(|e| anyhow!("{origin}:{}:1: cannot read: {e}", i + 1))?;
        let text = String::from_utf8_lossy(&l);
        let t = text.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let n = t
            .split(',')
            .filter_map(|c| {
                column_name(c)
                    .strip_prefix('q')
                    .and_then(|k| k.parse::<usize>().ok())
            })
            .max()
            .unwrap_or(0);
        if n == 0 {
            return Err(crate::refused(format!(
                "{origin}:{}:1: the header has no joint columns q1, q2, …",
                i + 1
            )));
        }
        return Ok(n);
    }
    Err(crate::refused(format!(
        "{origin}:1:1: {}",
        CsvErrorKind::Empty.describe()
    )))
}

/// The CSV text of a dataset: header `q1..qN,x,y,z[,extra…]`, joint readings with
/// [`Q_DECIMALS`] and points with [`XYZ_DECIMALS`] decimals, extra values exactly.
pub fn to_csv_string<const N: usize>(data: &Dataset<N>) -> String {
    csv_text(
        data,
        |s, q| write!(s, "{q:.Q_DECIMALS$}"),
        |s, v| write!(s, "{v:.XYZ_DECIMALS$}"),
    )
}

/// The CSV text of a dataset with every number exactly as it is (the shortest decimal that
/// reads back to the same `f64`): a file that gives the very numbers of data made in memory.
pub fn to_exact_csv_string<const N: usize>(data: &Dataset<N>) -> String {
    csv_text(data, |s, q| write!(s, "{q}"), |s, v| write!(s, "{v}"))
}

type Put = fn(&mut String, f64) -> std::fmt::Result;

fn csv_text<const N: usize>(data: &Dataset<N>, q_text: Put, xyz_text: Put) -> String {
    let mut s = String::new();
    let mut head: Vec<String> = (1..=N).map(|i| format!("q{i}")).collect();
    // Rows of named reflectors only (every x, y, z empty): written without those columns; a
    // set without rows keeps them (a header of kinecal's layout).
    let xyz = data.records.is_empty()
        || !data
            .records
            .iter()
            .all(|r| r.xyz_mm.iter().all(|v| v.is_nan()));
    if xyz {
        head.extend(["x", "y", "z"].map(String::from));
    }
    head.extend(data.extra_names.iter().cloned());
    s.push_str(&head.join(","));
    s.push('\n');
    for r in &data.records {
        for (k, q) in r.q_deg.iter().enumerate() {
            if k > 0 {
                s.push(',');
            }
            let _ = q_text(&mut s, *q);
        }
        for v in r.xyz_mm.iter().filter(|_| xyz) {
            s.push(',');
            let _ = xyz_text(&mut s, *v);
        }
        for k in 0..data.extra_names.len() {
            let v = r.extra.get(k).copied().unwrap_or(f64::NAN);
            if v.is_finite() {
                let _ = write!(s, ",{v}");
            } else {
                s.push(',');
            }
        }
        s.push('\n');
    }
    s
}

/// The dataset a file that [`write()`] writes for `data` reads back to: its numbers as the file
/// keeps them ([`to_csv_string`]), in memory.
pub fn as_written<const N: usize>(data: &Dataset<N>) -> anyhow::Result<Dataset<N>> {
    read_bytes::<N>(to_csv_string(data).as_bytes())
        .map_err(|e| anyhow!("the measurements do not read back: {}", e.kind.describe()))
}

/// Writes a measurement file (see [`to_csv_string`]).
pub fn write<const N: usize>(path: &Path, data: &Dataset<N>) -> anyhow::Result<()> {
    crate::output::atomic::write_atomic(path, to_csv_string(data).as_bytes())
        .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))
}

/// Whether the file at `path` is a constraint file: its header line has a `kind` column.
/// Reads up to the header line only (within its first MiB): a measurement file of a million
/// rows is not read twice.
pub fn is_constraint_file(path: &Path) -> bool {
    use std::io::{BufRead, Read};
    let Ok(f) = std::fs::File::open(path) else {
        return false;
    };
    let mut lines = std::io::BufReader::new(f.take(1 << 20))
        .split(b'\n')
        .map_while(Result::ok);
    let header = lines.find_map(|l| {
        let l = String::from_utf8_lossy(&l).into_owned();
        let t = l.trim().trim_start_matches('\u{feff}').trim().to_string();
        (!t.is_empty() && !t.starts_with('#')).then_some(t)
    });
    // Split on any delimiter: a constraint file written with `;` or tabs is still one, and is
    // refused as such by its reader (with what to convert) rather than as tracker points.
    header.is_some_and(|h| h.split([',', ';', '\t']).any(|c| c.trim() == "kind"))
}
