//! Streaming CSV measurements (`kc_csv`: the library's `io::csv::CsvReader` over a C read
//! callback): header line, `q1`..`q6` (degrees), `x`, `y`, `z` (mm), extra columns.

use crate::handle::{self, handle};
use crate::lm::kc_measurement;
use crate::{array_ref, obj_mut, slice_mut, status, Kc, KC_JOINTS};
use crate::{kc_status, KC_CSV_ERROR, KC_END, KC_INVALID_ARGUMENT, KC_NOT_FOUND, KC_NULL_POINTER};
use core::ffi::{c_char, c_void, CStr};
use kinecal::io::csv::{CsvError, CsvErrorKind, CsvReader, Record};
use kinecal::Measurement;

/// The read callback: copies up to `len` bytes of the input into `buf` and returns how many
/// (`0` = end of the input). A value above `len` (e.g. `(size_t)-1`) reports a read error
/// (`KC_CSV_ERROR`, kind `KC_CSV_IO`; a second failure in a row stops the reader).
pub type kc_read_fn =
    Option<unsafe extern "C" fn(ctx: *mut c_void, buf: *mut u8, len: usize) -> usize>;

/// Longest line (bytes) a `kc_csv` reads.
pub const KC_CSV_LINE: usize = 256;
/// Most extra columns a `kc_csv` carries (more are ignored).
pub const KC_CSV_MAX_EXTRAS: usize = 8;

/// A failed read of the callback.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ReadFailed;

impl core::fmt::Display for ReadFailed {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the read callback failed")
    }
}

impl core::error::Error for ReadFailed {}

impl embedded_io::Error for ReadFailed {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

/// The C callback as an `embedded_io` reader.
pub(crate) struct Callback {
    read: unsafe extern "C" fn(*mut c_void, *mut u8, usize) -> usize,
    ctx: *mut c_void,
}

impl embedded_io::ErrorType for Callback {
    type Error = ReadFailed;
}

impl embedded_io::Read for Callback {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ReadFailed> {
        if buf.is_empty() {
            return Ok(0);
        }
        // SAFETY: the callback's contract (kc_csv_init): it writes at most `len` bytes into
        // `buf`, which is valid for `buf.len()` bytes; `ctx` is the caller's own pointer.
        let n = unsafe { (self.read)(self.ctx, buf.as_mut_ptr(), buf.len()) };
        if n > buf.len() {
            Err(ReadFailed)
        } else {
            Ok(n)
        }
    }
}

type Reader = CsvReader<Callback, KC_JOINTS, KC_CSV_LINE, KC_CSV_MAX_EXTRAS>;

/// What a `kc_csv` holds: the reader (or the header's error) and the last error.
pub(crate) struct Csv {
    reader: Result<Reader, CsvError>,
    last: Option<CsvError>,
}

/// Bytes of a [`kc_csv`] (see `KC_ROBOT_SIZE`).
pub const KC_CSV_SIZE: usize = 792;

/// A streaming CSV reader (`CsvReader<_, 6, KC_CSV_LINE, KC_CSV_MAX_EXTRAS>`). Opaque,
/// caller-owned; [`kc_csv_init`].
#[repr(C, align(8))]
pub struct kc_csv {
    _opaque: [u8; KC_CSV_SIZE],
}

handle!(kc_csv, KC_CSV_SIZE, Csv, 0x4343_4343);

/// The codes of `kc_csv_error.kind` (the library's `CsvErrorKind`).
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum kc_csv_error_kind {
    /// No error.
    KC_CSV_NONE = 0,
    /// The read callback failed.
    KC_CSV_IO = 1,
    /// The input has no header line.
    KC_CSV_EMPTY = 2,
    /// The header lacks a required column (`q1`..`q6`, `x`, `y`, `z`).
    KC_CSV_MISSING_COLUMN = 3,
    /// The header names a column twice.
    KC_CSV_DUPLICATE_COLUMN = 4,
    /// The header has a joint column beyond `q6`.
    KC_CSV_TOO_MANY_JOINTS = 5,
    /// A line is longer than `KC_CSV_LINE`.
    KC_CSV_LINE_TOO_LONG = 6,
    /// A line is not UTF-8 text.
    KC_CSV_NOT_TEXT = 7,
    /// A cell that must be a number is not one.
    KC_CSV_NOT_A_NUMBER = 8,
    /// A cell is NaN or infinite.
    KC_CSV_NOT_FINITE = 9,
    /// A line has fewer cells than a required column needs.
    KC_CSV_SHORT_LINE = 10,
    /// More columns than the reader can map (64).
    KC_CSV_TOO_MANY_COLUMNS = 11,
    /// A line has more cells than the header (often a decimal comma).
    KC_CSV_EXTRA_CELL = 12,
    /// A joint reading or coordinate of implausible magnitude.
    KC_CSV_OUT_OF_RANGE = 13,
    /// The callback failed twice in a row: reading stopped.
    KC_CSV_READER_FAILED = 14,
}

fn kind_code(k: CsvErrorKind) -> kc_csv_error_kind {
    use kc_csv_error_kind::*;
    match k {
        CsvErrorKind::Io => KC_CSV_IO,
        CsvErrorKind::Empty => KC_CSV_EMPTY,
        CsvErrorKind::MissingColumn => KC_CSV_MISSING_COLUMN,
        CsvErrorKind::DuplicateColumn => KC_CSV_DUPLICATE_COLUMN,
        CsvErrorKind::TooManyJoints => KC_CSV_TOO_MANY_JOINTS,
        CsvErrorKind::LineTooLong => KC_CSV_LINE_TOO_LONG,
        CsvErrorKind::NotText => KC_CSV_NOT_TEXT,
        CsvErrorKind::NotANumber => KC_CSV_NOT_A_NUMBER,
        CsvErrorKind::NotFinite => KC_CSV_NOT_FINITE,
        CsvErrorKind::ShortLine => KC_CSV_SHORT_LINE,
        CsvErrorKind::TooManyColumns => KC_CSV_TOO_MANY_COLUMNS,
        CsvErrorKind::ExtraCell => KC_CSV_EXTRA_CELL,
        CsvErrorKind::OutOfRange => KC_CSV_OUT_OF_RANGE,
        CsvErrorKind::ReaderFailed => KC_CSV_READER_FAILED,
    }
}

/// Where and why the CSV input was refused.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct kc_csv_error {
    /// 1-based line (0 when the input has none).
    pub line: u32,
    /// 1-based column (0 when the error concerns the whole line or header).
    pub column: u16,
    /// A `kc_csv_error_kind` (`KC_CSV_NONE`: no error so far).
    pub kind: u8,
}

/// One record in file units (f64, as written).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_csv_record {
    /// Joint readings `q1`..`q6` as written (degrees).
    pub q_deg: [f64; KC_JOINTS],
    /// The point `x`, `y`, `z` as written (mm).
    pub xyz_mm: [f64; 3],
    /// Line of the input the record came from.
    pub line: u32,
}

/// Starts reading: reads the header line through `read(ctx, …)`. Errors: `KC_NULL_POINTER`
/// (`c`, `read`), `KC_CSV_ERROR` (a malformed header: the handle is then initialised but every
/// [`kc_csv_next`] returns `KC_CSV_ERROR`; [`kc_csv_last_error`] says why).
///
/// # Safety
/// `c` NULL or a writable `kc_csv` not otherwise in use; `read` NULL or a function that honours
/// `kc_read_fn`'s contract with `ctx` for as long as the handle is used.
#[no_mangle]
pub unsafe extern "C" fn kc_csv_init(
    c: *mut kc_csv,
    read: kc_read_fn,
    ctx: *mut c_void,
) -> kc_status {
    status((|| {
        let read = read.ok_or(KC_NULL_POINTER)?;
        // SAFETY: the header contract.
        let slot = unsafe { handle::uninit::<kc_csv>(c) }?;
        let csv = handle::init::<kc_csv>(
            slot,
            Csv {
                reader: CsvReader::new(Callback { read, ctx }),
                last: None,
            },
        );
        if let Err(e) = &csv.reader {
            csv.last = Some(*e);
            return Err(KC_CSV_ERROR);
        }
        Ok(())
    })())
}

/// The next record, or `KC_END`, or `KC_CSV_ERROR` (the record is skipped; the next call
/// reads on).
fn next(csv: &mut Csv) -> Kc<Record<KC_JOINTS, KC_CSV_MAX_EXTRAS>> {
    let reader = match &mut csv.reader {
        Ok(r) => r,
        Err(_) => return Err(KC_CSV_ERROR),
    };
    match reader.next_record() {
        None => Err(KC_END),
        Some(Ok(r)) => Ok(r),
        Some(Err(e)) => {
            csv.last = Some(e);
            Err(KC_CSV_ERROR)
        }
    }
}

fn copy_extras(rec: &Record<KC_JOINTS, KC_CSV_MAX_EXTRAS>, out: &mut [f64]) {
    for (o, v) in out.iter_mut().zip(rec.extra.iter()) {
        *o = *v;
    }
}

#[inline(always)]
fn measurement_of(m: &Measurement<f32, KC_JOINTS>) -> kc_measurement {
    let [a, b, c, d, e, f] = m.q;
    kc_measurement {
        q: [a, b, c, d, e, f, 0.0],
        xyz_mm: [m.point.x, m.point.y, m.point.z],
    }
}

/// The next record in library units (rad, mm) into `*out`, the first `n_extras` extra
/// columns' values into `extras` (NaN for an empty or non-numeric cell; `extras` may be NULL
/// when `n_extras` is 0) and its line into `*line` (may be NULL). `KC_END` at the end of the
/// input; `KC_CSV_ERROR` for a malformed record (skipped: call again for the next one; `*line`
/// is the error's line, [`kc_csv_last_error`] says why).
///
/// # Safety
/// `c` NULL or valid and not otherwise in use; `out` NULL or writable; `extras` NULL or
/// `n_extras` writable doubles; `line` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_csv_next(
    c: *mut kc_csv,
    out: *mut kc_measurement,
    extras: *mut f64,
    n_extras: usize,
    line: *mut u32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let csv = unsafe { handle::get_mut(c) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        // SAFETY: the header contract (`n_extras` doubles).
        let extras = unsafe { slice_mut(extras, n_extras) }?;
        // SAFETY: NULL is allowed; otherwise the header contract.
        let line = unsafe { line.as_mut() };
        match next(csv) {
            Ok(rec) => {
                *out = measurement_of(&rec.measurement());
                copy_extras(&rec, extras);
                if let Some(l) = line {
                    *l = rec.line;
                }
                Ok(())
            }
            Err(s) => {
                if let (Some(l), Some(e)) = (line, csv.last.filter(|_| s == KC_CSV_ERROR)) {
                    *l = e.line;
                }
                Err(s)
            }
        }
    })())
}

/// As [`kc_csv_next`], the record in file units (f64 degrees and millimetres, as written) into
/// `*out` (its `line` included); [`kc_measurement_from_deg`] converts it.
///
/// # Safety
/// As [`kc_csv_next`].
#[no_mangle]
pub unsafe extern "C" fn kc_csv_next_raw(
    c: *mut kc_csv,
    out: *mut kc_csv_record,
    extras: *mut f64,
    n_extras: usize,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let csv = unsafe { handle::get_mut(c) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        // SAFETY: the header contract (`n_extras` doubles).
        let extras = unsafe { slice_mut(extras, n_extras) }?;
        let rec = next(csv)?;
        *out = kc_csv_record {
            q_deg: rec.q_deg,
            xyz_mm: rec.xyz_mm,
            line: rec.line,
        };
        copy_extras(&rec, extras);
        Ok(())
    })())
}

/// A measurement in library units (rad, mm) from file units (`q_deg[KC_JOINTS]` degrees,
/// `xyz_mm[3]`), rounded to float as the CSV reader does.
///
/// # Safety
/// Arrays NULL or of their sizes; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_measurement_from_deg(
    q_deg: *const f64,
    xyz_mm: *const f64,
    out: *mut kc_measurement,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract (KC_JOINTS doubles).
        let q = unsafe { array_ref::<f64, KC_JOINTS>(q_deg) }?;
        // SAFETY: the header contract (3 doubles).
        let p = unsafe { array_ref::<f64, 3>(xyz_mm) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        *out = measurement_of(&Measurement::from_deg(q, p));
        Ok(())
    })())
}

/// The number of extra columns carried (at most `KC_CSV_MAX_EXTRAS`) into `*count`.
///
/// # Safety
/// `c` NULL or valid; `count` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_csv_extra_count(c: *const kc_csv, count: *mut usize) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let csv = unsafe { handle::get(c) }?;
        // SAFETY: the header contract.
        let count = unsafe { obj_mut(count) }?;
        let reader = csv.reader.as_ref().map_err(|_| KC_CSV_ERROR)?;
        *count = reader.extra_names().len();
        Ok(())
    })())
}

/// The index (in the `extras` of [`kc_csv_next`]) of the extra column `name` (a NUL-terminated
/// string) into `*index`. `KC_NOT_FOUND` when there is none.
///
/// # Safety
/// `c` NULL or valid; `name` NULL or a NUL-terminated string; `index` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_csv_extra_index(
    c: *const kc_csv,
    name: *const c_char,
    index: *mut usize,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let csv = unsafe { handle::get(c) }?;
        // SAFETY: the header contract.
        let index = unsafe { obj_mut(index) }?;
        if name.is_null() {
            return Err(KC_NULL_POINTER);
        }
        // SAFETY: non-NULL and NUL-terminated per the header contract.
        let name = unsafe { CStr::from_ptr(name) }
            .to_str()
            .map_err(|_| KC_INVALID_ARGUMENT)?;
        let reader = csv.reader.as_ref().map_err(|_| KC_CSV_ERROR)?;
        *index = reader.extra_index(name).ok_or(KC_NOT_FOUND)?;
        Ok(())
    })())
}

/// The last error of the reader (its header's, or the last malformed record's) into `*out`;
/// `kind` is `KC_CSV_NONE` when there was none.
///
/// # Safety
/// `c` NULL or valid; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_csv_last_error(c: *const kc_csv, out: *mut kc_csv_error) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let csv = unsafe { handle::get(c) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        *out = match csv.last {
            None => kc_csv_error::default(),
            Some(e) => kc_csv_error {
                line: e.line,
                column: e.column,
                kind: kind_code(e.kind) as u8,
            },
        };
        Ok(())
    })())
}

/// A static English description of a `kc_csv_error_kind` (unknown codes: "unknown CSV error").
/// Never NULL.
#[no_mangle]
pub extern "C" fn kc_csv_error_message(kind: u32) -> *const c_char {
    let s: &'static CStr = match kind {
        0 => c"no error",
        1 => c"read error",
        2 => c"empty file: no header line",
        3 => c"missing required column",
        4 => c"duplicate column",
        5 => c"joint column beyond the robot's joints",
        6 => c"line too long",
        7 => c"line is not UTF-8 text",
        8 => c"not a number",
        9 => c"NaN or infinite value",
        10 => c"line has too few columns",
        11 => c"too many columns",
        12 => c"more cells than the header has columns",
        13 => c"implausible magnitude",
        14 => c"read error again: reading stopped",
        _ => c"unknown CSV error",
    };
    s.as_ptr()
}
