//! Measurement CSV records (`docs/formats.md#measurement-csv`) from any `embedded_io::Read`: a
//! UART on the controller, a file on the desktop.
//!
//! Fixed line buffer of `L` bytes, header → column map, up to `X` extra columns carried by name,
//! `#` comments and blank lines skipped. Every error carries the 1-based line and column so a
//! technician can find the bad cell.
//!
//! # After an error
//!
//! * **A bad line** (a cell that is not a number, out of range, too many or too few cells, too
//!   long, not UTF-8) is reported once; the reader continues with the next line.
//! * **A read error** ([`CsvErrorKind::Io`]) drops the line being read: it is reported for that
//!   line, the bytes of it already read are thrown away and so is the rest of it (everything up
//!   to the next newline) — a reader may have lost bytes with its error, so what is left of the
//!   line is never parsed as a record. Reading then continues with the next line, whose number
//!   is right when the failing reader lost no newline. The reader does not retry by itself.
//! * **A reader that keeps failing** — a read fails again before any byte arrived since the
//!   previous failure — is given up: that failure is reported once as
//!   [`CsvErrorKind::ReaderFailed`], and from then on [`CsvReader::next_record`] returns `None`,
//!   as it does after the end of the input (the reader is fused).
//!
//! So every record returned is a whole line of the input, parsed, with its right line number
//! (given a reader that loses no newline), and a reader that fails forever ends the stream.
//!
//! # Plausible values
//!
//! Joint readings must satisfy `|q| ≤` [`MAX_ABS_JOINT`] and coordinates `|x|, |y|, |z| ≤`
//! [`MAX_ABS_MM`] (in the units written); NaN and infinities are [`CsvErrorKind::NotFinite`],
//! finite values beyond these bounds [`CsvErrorKind::OutOfRange`]. Extra columns are carried as
//! written.
//!
//! ```
//! use kinecal::io::csv::{CsvErrorKind, CsvReader};
//!
//! let file = b"# tracker export, 2 joints\n\
//!              q1,q2,x,y,z,temp_c\n\
//!              10.0,-20.0,1500.25,-30.5,400.0,21.7\n\
//!              \n\
//!              0,90,812.0,0,1000,\n\
//!              0,abc,812.0,0,1000,21.8\n";
//! // 2 joints, lines up to 128 bytes, up to 4 extra columns; `&[u8]` is an `embedded_io::Read`.
//! let mut csv = CsvReader::<_, 2, 128, 4>::new(&file[..]).unwrap();
//! assert_eq!(csv.extra_names()[0].as_str(), "temp_c");
//!
//! let r = csv.next_record().unwrap().unwrap();
//! assert_eq!((r.line, r.q_deg, r.xyz_mm), (3, [10.0, -20.0], [1500.25, -30.5, 400.0]));
//! assert_eq!(r.extra[0], 21.7);
//! let m = r.measurement::<f32>(); // library units: rad, mm
//! assert_eq!(m.q[1], (-20f64).to_radians() as f32);
//!
//! let r = csv.next_record().unwrap().unwrap(); // the blank line was skipped
//! assert_eq!(r.line, 5);
//! assert!(r.extra[0].is_nan()); // an empty extra cell
//!
//! let e = csv.next_record().unwrap().unwrap_err();
//! assert_eq!((e.kind, e.line, e.column), (CsvErrorKind::NotANumber, 6, 2));
//! assert!(csv.next_record().is_none());
//! ```

pub use super::decimal::parse_decimal;
use crate::Measurement;
use crate::Real;
use embedded_io::Read;
use heapless::{String, Vec};

/// What went wrong in a CSV file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CsvErrorKind {
    /// The underlying reader failed.
    Io,
    /// The file has no header line.
    Empty,
    /// The header lacks a required column (`q1`…`qN`, `x`, `y`, `z`); `column` is 0.
    MissingColumn,
    /// The header names a column twice.
    DuplicateColumn,
    /// The header has a joint column beyond `qN` (the data is for a robot with more joints).
    TooManyJoints,
    /// A line is longer than the reader's buffer.
    LineTooLong,
    /// A line is not valid UTF-8.
    NotText,
    /// A cell that must be a number is not one.
    NotANumber,
    /// A cell is NaN or infinite.
    NotFinite,
    /// A line has fewer cells than a required column needs.
    ShortLine,
    /// More columns than the reader can map.
    TooManyColumns,
    /// A line has more cells than the header has columns; `column` is the first cell beyond
    /// the header. Often a decimal comma (`79,500064`), which shifts every later cell.
    ExtraCell,
    /// A joint reading or coordinate is finite but beyond [`MAX_ABS_JOINT`] or [`MAX_ABS_MM`].
    OutOfRange,
    /// The underlying reader failed again before delivering a byte since its previous failure:
    /// the reader gives up and returns `None` from then on (see the module documentation).
    ReaderFailed,
}

impl CsvErrorKind {
    /// A short English description, for error messages.
    pub fn describe(self) -> &'static str {
        match self {
            CsvErrorKind::Io => "read error",
            CsvErrorKind::Empty => "empty file: no header line",
            CsvErrorKind::MissingColumn => "missing required column",
            CsvErrorKind::DuplicateColumn => "duplicate column",
            CsvErrorKind::TooManyJoints => "joint column beyond the robot's joints",
            CsvErrorKind::LineTooLong => "line too long",
            CsvErrorKind::NotText => "line is not UTF-8 text",
            CsvErrorKind::NotANumber => "not a number",
            CsvErrorKind::NotFinite => "NaN or infinite value",
            CsvErrorKind::ShortLine => "line has too few columns",
            CsvErrorKind::TooManyColumns => "too many columns",
            CsvErrorKind::ExtraCell => "more cells than the header has columns",
            CsvErrorKind::OutOfRange => "implausible magnitude",
            CsvErrorKind::ReaderFailed => "read error again: reading stopped",
        }
    }
}

/// A CSV error at a place in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CsvError {
    /// What went wrong.
    pub kind: CsvErrorKind,
    /// 1-based line number (0 when the file has none).
    pub line: u32,
    /// 1-based column number (0 when the error concerns the whole line or header).
    pub column: u16,
    /// For `MissingColumn`: which required column (0..N = q1.., N = x, N+1 = y, N+2 = z).
    pub which: u16,
}

/// Longest extra-column name carried.
pub const NAME_LEN: usize = 24;
/// Most columns a header may have.
pub const MAX_COLUMNS: usize = 64;
/// Largest plausible |x|, |y|, |z| of a measured point, in the units written (1 km in mm): a
/// larger value is [`CsvErrorKind::OutOfRange`].
pub const MAX_ABS_MM: f64 = 1.0e6;
/// Largest plausible |joint reading|, in the units written (~278 turns in degrees, 100 m for a
/// prismatic joint in mm): a larger value is [`CsvErrorKind::OutOfRange`].
pub const MAX_ABS_JOINT: f64 = 1.0e5;

/// The column a header cell names: quotes and blanks stripped from both ends, in any mix,
/// until neither is left, so `"t "`, `t"" ` and `t` name the same column and a name written
/// back reads back the same (fuzz measurement_file/write-read-round-trip-1 and -2). Every
/// reader of a header uses this.
pub fn column_name(cell: &str) -> &str {
    cell.trim_matches(|c: char| c == '"' || c.is_whitespace())
}

/// One record, in file units (degrees, millimetres), with the extra columns' values.
#[derive(Clone, Debug, PartialEq)]
pub struct Record<const N: usize, const X: usize> {
    /// Joint readings `q1`…`qN` as written (degrees by the file convention).
    pub q_deg: [f64; N],
    /// Measured point `x`, `y`, `z` as written (millimetres by the file convention).
    pub xyz_mm: [f64; 3],
    /// Values of the extra columns, in the order of [`CsvReader::extra_names`];
    /// NaN for an empty or non-numeric cell.
    pub extra: Vec<f64, X>,
    /// Line of the file this record came from.
    pub line: u32,
}

impl<const N: usize, const X: usize> Record<N, X> {
    /// The measurement in library units (rad, mm).
    pub fn measurement<T: Real>(&self) -> Measurement<T, N> {
        Measurement::from_deg(&self.q_deg, &self.xyz_mm)
    }
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Slot {
    Ignored,
    Joint(u8),
    Xyz(u8),
    Extra(u8),
}

/// Streaming reader of measurement records for an `N`-joint robot.
#[derive(Debug)]
pub struct CsvReader<R: Read, const N: usize, const L: usize = 512, const X: usize = 8> {
    reader: R,
    chunk: [u8; 64],
    chunk_len: usize,
    chunk_pos: usize,
    line: [u8; L],
    line_no: u32,
    slots: Vec<Slot, MAX_COLUMNS>,
    extra_names: Vec<String<NAME_LEN>, X>,
    eof: bool,
    /// The rest of line `line_no` is being thrown away after a read error.
    dropping: bool,
    /// The last read failed (no byte arrived since).
    failed: bool,
    /// Given up after [`CsvErrorKind::ReaderFailed`]: `next_record` returns `None`.
    stopped: bool,
    /// The header names points `x_NAME`… (several reflectors) instead of `x`, `y`, `z`.
    named_points: bool,
}

enum LineRead {
    Line(usize),
    TooLong,
    Eof,
}

impl<R: Read, const N: usize, const L: usize, const X: usize> CsvReader<R, N, L, X> {
    /// Reads the header and builds the column map.
    pub fn new(reader: R) -> Result<Self, CsvError> {
        let mut s = Self {
            reader,
            chunk: [0; 64],
            chunk_len: 0,
            chunk_pos: 0,
            line: [0; L],
            line_no: 0,
            slots: Vec::new(),
            extra_names: Vec::new(),
            eof: false,
            dropping: false,
            failed: false,
            stopped: false,
            named_points: false,
        };
        let err = |kind, line, column| CsvError {
            kind,
            line,
            column,
            which: 0,
        };
        loop {
            match s.read_line()? {
                LineRead::Eof => return Err(err(CsvErrorKind::Empty, s.line_no, 0)),
                LineRead::TooLong => return Err(err(CsvErrorKind::LineTooLong, s.line_no, 0)),
                LineRead::Line(n) => {
                    if Self::skip(&s.line[..n]) {
                        continue;
                    }
                    s.header(n)?;
                    return Ok(s);
                }
            }
        }
    }

    /// Names of the extra columns carried, in the order of [`Record::extra`].
    pub fn extra_names(&self) -> &[String<NAME_LEN>] {
        &self.extra_names
    }

    /// True when the file names its points `x_NAME`, `y_NAME`, `z_NAME` (several reflectors)
    /// instead of `x`, `y`, `z`: records then carry NaN as [`Record::xyz_mm`] and the points
    /// among their extra columns.
    pub fn named_points(&self) -> bool {
        self.named_points
    }

    /// Index in [`Record::extra`] of the named extra column.
    pub fn extra_index(&self, name: &str) -> Option<usize> {
        self.extra_names.iter().position(|n| n.as_str() == name)
    }

    fn skip(line: &[u8]) -> bool {
        let t = line.trim_ascii();
        t.is_empty() || t[0] == b'#'
    }

    fn header(&mut self, n: usize) -> Result<(), CsvError> {
        let line_no = self.line_no;
        let text = core::str::from_utf8(&self.line[..n]).map_err(|_| CsvError {
            kind: CsvErrorKind::NotText,
            line: line_no,
            column: 0,
            which: 0,
        })?;
        let mut seen_q = [false; N];
        let mut seen_xyz = [false; 3];
        for (c, cell) in text.split(',').enumerate() {
            let col = (c + 1) as u16;
            let e = |kind| CsvError {
                kind,
                line: line_no,
                column: col,
                which: 0,
            };
            let name = column_name(cell);
            let slot = if let Some(rest) = name
                .strip_prefix('q')
                .filter(|r| !r.is_empty() && r.bytes().all(|b| b.is_ascii_digit()))
            {
                match rest.parse::<usize>() {
                    Ok(j) if j >= 1 && j <= N => {
                        if seen_q[j - 1] {
                            return Err(e(CsvErrorKind::DuplicateColumn));
                        }
                        seen_q[j - 1] = true;
                        Slot::Joint((j - 1) as u8)
                    }
                    _ => return Err(e(CsvErrorKind::TooManyJoints)),
                }
            } else if let Some(k) = ["x", "y", "z"].iter().position(|x| *x == name) {
                if seen_xyz[k] {
                    return Err(e(CsvErrorKind::DuplicateColumn));
                }
                seen_xyz[k] = true;
                Slot::Xyz(k as u8)
            } else if !name.is_empty() && name.len() <= NAME_LEN && !self.extra_names.is_full() {
                if self.extra_names.iter().any(|n| n.as_str() == name) {
                    return Err(e(CsvErrorKind::DuplicateColumn));
                }
                let mut s = String::new();
                let _ = s.push_str(name);
                let _ = self.extra_names.push(s);
                Slot::Extra((self.extra_names.len() - 1) as u8)
            } else {
                Slot::Ignored
            };
            self.slots
                .push(slot)
                .map_err(|_| e(CsvErrorKind::TooManyColumns))?;
        }
        // Several reflectors (docs/formats.md): `x_NAME`, `y_NAME`, `z_NAME` instead of
        // `x`, `y`, `z`, carried as extra columns; the record's point is then NaN.
        let named_points =
            seen_xyz == [false; 3] && self.extra_names.iter().any(|n| n.starts_with("x_"));
        self.named_points = named_points;
        let missing = seen_q.iter().position(|s| !s).or_else(|| {
            if named_points {
                None
            } else {
                seen_xyz.iter().position(|s| !s).map(|k| N + k)
            }
        });
        if let Some(w) = missing {
            return Err(CsvError {
                kind: CsvErrorKind::MissingColumn,
                line: line_no,
                column: 0,
                which: w as u16,
            });
        }
        Ok(())
    }

    /// Refills the chunk: `Ok(false)` at the end of the input. A failed read reports
    /// [`CsvErrorKind::Io`] for the line being read, or, when the previous read failed too,
    /// [`CsvErrorKind::ReaderFailed`] and stops the reader.
    fn fill(&mut self) -> Result<bool, CsvError> {
        if self.eof {
            return Ok(false);
        }
        match self.reader.read(&mut self.chunk) {
            Ok(0) => {
                self.eof = true;
                Ok(false)
            }
            Ok(n) => {
                self.chunk_len = n.min(self.chunk.len());
                self.chunk_pos = 0;
                self.failed = false;
                Ok(true)
            }
            Err(_) => {
                let kind = if self.failed {
                    self.stopped = true;
                    CsvErrorKind::ReaderFailed
                } else {
                    self.failed = true;
                    CsvErrorKind::Io
                };
                // The line being read is dropped (counted now, its rest thrown away later).
                if !self.dropping {
                    self.line_no = self.line_no.saturating_add(1);
                    self.dropping = true;
                }
                Err(CsvError {
                    kind,
                    line: self.line_no,
                    column: 0,
                    which: 0,
                })
            }
        }
    }

    /// Throws away the rest of a line dropped after a read error, through its newline. A
    /// further failure in it is not reported again unless it is [`CsvErrorKind::ReaderFailed`].
    fn drop_rest(&mut self) -> Result<(), CsvError> {
        while self.dropping {
            if self.chunk_pos >= self.chunk_len {
                match self.fill() {
                    Ok(true) => {}
                    Ok(false) => self.dropping = false,
                    Err(e) if e.kind == CsvErrorKind::ReaderFailed => return Err(e),
                    Err(_) => {}
                }
                continue;
            }
            let b = self.chunk[self.chunk_pos];
            self.chunk_pos += 1;
            if b == b'\n' {
                self.dropping = false;
            }
        }
        Ok(())
    }

    /// Reads one line (without the terminator) into the buffer.
    fn read_line(&mut self) -> Result<LineRead, CsvError> {
        self.drop_rest()?;
        let mut n = 0usize;
        let mut too_long = false;
        let mut any = false;
        loop {
            if self.chunk_pos >= self.chunk_len && !self.fill()? {
                if !any {
                    return Ok(LineRead::Eof);
                }
                break;
            }
            // The rest of the chunk up to the line end (or all of it), copied at once.
            let avail = &self.chunk[self.chunk_pos..self.chunk_len];
            any = true;
            let end = avail.iter().position(|b| *b == b'\n');
            let take = end.unwrap_or(avail.len());
            let copy = take.min(L - n);
            self.line[n..n + copy].copy_from_slice(&avail[..copy]);
            n += copy;
            too_long |= take > copy;
            self.chunk_pos += take + usize::from(end.is_some());
            if end.is_some() {
                break;
            }
        }
        self.line_no = self.line_no.saturating_add(1);
        if n > 0 && self.line[n - 1] == b'\r' {
            n -= 1;
        }
        Ok(if too_long {
            LineRead::TooLong
        } else {
            LineRead::Line(n)
        })
    }

    /// The next record or error, `None` at the end of the input and after
    /// [`CsvErrorKind::ReaderFailed`] (see the module documentation for what follows an error).
    pub fn next_record(&mut self) -> Option<Result<Record<N, X>, CsvError>> {
        if self.stopped {
            return None;
        }
        loop {
            let n = match self.read_line() {
                Err(e) => return Some(Err(e)),
                Ok(LineRead::Eof) => return None,
                Ok(LineRead::TooLong) => {
                    return Some(Err(CsvError {
                        kind: CsvErrorKind::LineTooLong,
                        line: self.line_no,
                        column: 0,
                        which: 0,
                    }))
                }
                Ok(LineRead::Line(n)) => n,
            };
            if Self::skip(&self.line[..n]) {
                continue;
            }
            return Some(self.parse(n));
        }
    }

    fn parse(&self, n: usize) -> Result<Record<N, X>, CsvError> {
        let line = self.line_no;
        let e = |kind, column: usize| CsvError {
            kind,
            line,
            column: column as u16,
            which: 0,
        };
        let text =
            core::str::from_utf8(&self.line[..n]).map_err(|_| e(CsvErrorKind::NotText, 0))?;
        let mut rec = Record {
            q_deg: [0.0; N],
            xyz_mm: if self.named_points {
                [f64::NAN; 3]
            } else {
                [0.0; 3]
            },
            extra: Vec::new(),
            line,
        };
        // A cell beyond the header first: it shifted the cells (a decimal comma, `79,500064`),
        // so their values would be reported against the wrong columns.
        let cells = text.bytes().filter(|b| *b == b',').count() + 1;
        if cells > self.slots.len() {
            return Err(e(CsvErrorKind::ExtraCell, self.slots.len() + 1));
        }
        let mut extra = [f64::NAN; X];
        for (c, cell) in Cells(Some(text)).enumerate() {
            let slot = self.slots.get(c).copied().unwrap_or(Slot::Ignored);
            if slot == Slot::Ignored {
                continue;
            }
            let t = cell.trim();
            let v: f64 = match parse_cell(t) {
                Some(v) => v,
                None => {
                    // An empty or non-numeric extra cell is carried as NaN; required cells must be numbers.
                    if let Slot::Extra(_) = slot {
                        continue;
                    }
                    return Err(e(CsvErrorKind::NotANumber, c + 1));
                }
            };
            let bound = match slot {
                Slot::Joint(_) => MAX_ABS_JOINT,
                Slot::Xyz(_) => MAX_ABS_MM,
                _ => f64::INFINITY,
            };
            if bound < f64::INFINITY && !v.is_finite() {
                return Err(e(CsvErrorKind::NotFinite, c + 1));
            }
            if v.abs() > bound {
                return Err(e(CsvErrorKind::OutOfRange, c + 1));
            }
            match slot {
                Slot::Joint(j) => rec.q_deg[j as usize] = v,
                Slot::Xyz(k) => rec.xyz_mm[k as usize] = v,
                Slot::Extra(k) => extra[k as usize] = v,
                Slot::Ignored => {}
            }
        }
        // Any required column at or beyond the number of cells present is missing.
        if let Some(c) = self
            .slots
            .iter()
            .enumerate()
            .skip(cells)
            .find(|(_, s)| matches!(s, Slot::Joint(_) | Slot::Xyz(_)))
        {
            return Err(e(CsvErrorKind::ShortLine, c.0 + 1));
        }
        for v in extra.iter().take(self.extra_names.len()) {
            let _ = rec.extra.push(*v);
        }
        Ok(rec)
    }
}

/// The cells of a line, as `text.split(',')` yields them: a byte search (cells are short: a
/// general substring searcher costs more than the scan). `None`: the last cell was yielded.
struct Cells<'a>(Option<&'a str>);

impl<'a> Iterator for Cells<'a> {
    type Item = &'a str;
    #[inline]
    fn next(&mut self) -> Option<&'a str> {
        let t = self.0?;
        match t.bytes().position(|b| b == b',') {
            Some(k) => {
                // `,` is one byte: both sides are on character boundaries.
                self.0 = t.get(k + 1..);
                Some(t.get(..k).unwrap_or(""))
            }
            None => {
                self.0 = None;
                Some(t)
            }
        }
    }
}

/// A numeric cell: core's correctly rounded parser, or [`parse_decimal`] with the `lean-parse`
/// feature (firmware: 16 KB less flash, ~10× fewer instructions per cell).
#[inline]
fn parse_cell(t: &str) -> Option<f64> {
    #[cfg(feature = "lean-parse")]
    {
        parse_decimal(t)
    }
    #[cfg(not(feature = "lean-parse"))]
    {
        t.parse().ok()
    }
}
