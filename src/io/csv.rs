//! Measurement CSV records (`docs/formats.md#measurement-csv`) from any `embedded_io::Read`: a
//! UART on the controller, a file on the desktop.
//!
//! Fixed line buffer of `L` bytes, header → column map, up to `X` extra columns carried by name,
//! `#` comments and blank lines skipped. Every error carries the 1-based line and column so a
//! technician can find the bad cell; after an error the reader continues with the next line.
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
            let name = cell.trim().trim_matches('"');
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
        let missing = seen_q
            .iter()
            .position(|s| !s)
            .or_else(|| seen_xyz.iter().position(|s| !s).map(|k| N + k));
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
                self.chunk_len = n;
                self.chunk_pos = 0;
                Ok(true)
            }
            Err(_) => Err(CsvError {
                kind: CsvErrorKind::Io,
                line: self.line_no + 1,
                column: 0,
                which: 0,
            }),
        }
    }

    /// Reads one line (without the terminator) into the buffer.
    fn read_line(&mut self) -> Result<LineRead, CsvError> {
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
            let b = self.chunk[self.chunk_pos];
            self.chunk_pos += 1;
            any = true;
            if b == b'\n' {
                break;
            }
            if n < L {
                self.line[n] = b;
                n += 1;
            } else {
                too_long = true;
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

    /// The next record, `None` at the end of the file.
    pub fn next_record(&mut self) -> Option<Result<Record<N, X>, CsvError>> {
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
            xyz_mm: [0.0; 3],
            extra: Vec::new(),
            line,
        };
        let mut extra = [f64::NAN; X];
        let mut cells = 0usize;
        for (c, cell) in text.split(',').enumerate() {
            cells = c + 1;
            let slot = match self.slots.get(c) {
                Some(s) => *s,
                None => break,
            };
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
            match slot {
                Slot::Joint(j) | Slot::Xyz(j) if !v.is_finite() => {
                    let _ = j;
                    return Err(e(CsvErrorKind::NotFinite, c + 1));
                }
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

/// Exact powers of ten representable in `f64` (Clinger's fast path).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Parses a decimal number (`-12.5`, `3e-4`, `nan`, `inf`) without core's float parser, which
/// costs ~16 KB of flash and ~11k instructions per cell on a Cortex-M4F.
///
/// Correctly rounded (identical to `str::parse::<f64>`) whenever the digits fit in 2^53 and the
/// decimal exponent in ±22, which covers every measurement file written with up to 15
/// significant digits; otherwise within a few ulp. `nan`/`inf` parse, so the caller can name
/// them as non-finite instead of "not a number".
pub fn parse_decimal(s: &str) -> Option<f64> {
    let b = s.as_bytes();
    let (neg, mut i) = match b.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    // Bytes, not `&s[i..]`: no char-boundary check, whose panic path costs ~1.7 KB of flash.
    let rest = b.get(i..).unwrap_or(&[]);
    let special = if rest.eq_ignore_ascii_case(b"nan") {
        Some(f64::NAN)
    } else if rest.eq_ignore_ascii_case(b"inf") || rest.eq_ignore_ascii_case(b"infinity") {
        Some(f64::INFINITY)
    } else {
        None
    };
    if let Some(v) = special {
        return Some(if neg { -v } else { v });
    }
    let mut mantissa: u64 = 0;
    let mut digits = 0u32;
    let mut exp10: i64 = 0;
    let mut truncated = false;
    let mut seen_digit = false;
    let mut seen_point = false;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_digit() {
            seen_digit = true;
            if mantissa == 0 && c == b'0' {
                // Leading zeros carry no significance.
                if seen_point {
                    exp10 -= 1;
                }
            } else if digits < 19 {
                mantissa = mantissa * 10 + (c - b'0') as u64;
                digits += 1;
                if seen_point {
                    exp10 -= 1;
                }
            } else {
                truncated |= c != b'0';
                if !seen_point {
                    exp10 += 1;
                }
            }
        } else if c == b'.' && !seen_point {
            seen_point = true;
        } else {
            break;
        }
        i += 1;
    }
    if !seen_digit {
        return None;
    }
    if i < b.len() {
        if b[i] != b'e' && b[i] != b'E' {
            return None;
        }
        i += 1;
        let (eneg, start) = match b.get(i) {
            Some(b'-') => (true, i + 1),
            Some(b'+') => (false, i + 1),
            _ => (false, i),
        };
        if start >= b.len() {
            return None;
        }
        let mut e: i64 = 0;
        for &c in &b[start..] {
            if !c.is_ascii_digit() {
                return None;
            }
            e = (e * 10 + (c - b'0') as i64).min(100_000);
        }
        exp10 += if eneg { -e } else { e };
    }
    let v = if mantissa == 0 {
        0.0
    } else if !truncated && mantissa <= (1u64 << 53) && (-22..=22).contains(&exp10) {
        let m = mantissa as f64;
        if exp10 >= 0 {
            m * POW10[exp10 as usize]
        } else {
            m / POW10[(-exp10) as usize]
        }
    } else if exp10 > 330 {
        f64::INFINITY
    } else if exp10 < -360 {
        0.0
    } else {
        let mut v = mantissa as f64;
        let mut e = exp10;
        while e > 22 {
            v *= 1e22;
            e -= 22;
        }
        while e < -22 {
            v /= 1e22;
            e += 22;
        }
        if e >= 0 {
            v * POW10[e as usize]
        } else {
            v / POW10[(-e) as usize]
        }
    };
    Some(if neg { -v } else { v })
}
