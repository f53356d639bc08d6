//! The files users bring and get, each with its schema and unit checks: the robot description
//! (TOML), measurements (CSV), the measurement cell of `plan` (TOML) and the units at the door.

pub mod cell_file;
pub mod computed_points;
pub mod convention;
pub mod dh_table;
pub mod firmware_model;
pub mod loading;
pub mod map;
pub mod measurements;
pub mod observations;
pub mod origin;
pub mod pace;
pub mod placement;
pub mod prior;
pub mod robot_file;
pub mod rotation_order;
pub mod stale;
pub mod stated_units;
pub mod table_reach;
pub mod text_cells;
pub mod tiny_sigma;
pub mod units;
pub mod urdf;

use std::path::Path;

/// The one-line reason a file `origin` could not be read, with what to do about it.
pub fn cannot_read(origin: &str, e: &std::io::Error) -> String {
    use std::io::ErrorKind;
    let todo = match e.kind() {
        ErrorKind::IsADirectory => "a folder: give the file in it",
        ErrorKind::NotFound => "no such file: check the path",
        ErrorKind::PermissionDenied => "not readable by this user: check its permissions",
        _ => "give a readable file",
    };
    format!("{origin}: cannot read ({e}): {todo}")
}

/// Reads at most `max` bytes of the file at `path`: refused (exit status 2) when it cannot be
/// read or is larger, naming `what` it should be. The file is never read whole before its
/// size is known to be within `max` (an endless `/dev/stdin` or a multi-gigabyte file stops at
/// `max + 1` bytes).
pub fn read_limited(path: &Path, max: u64, what: &str) -> anyhow::Result<Vec<u8>> {
    use std::io::Read as _;
    let cannot = |e: std::io::Error| crate::refused(cannot_read(&path.display().to_string(), &e));
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .map_err(cannot)?
        .take(max + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > max {
        crate::refuse!(
            "{}: larger than {} MiB: not {what}; give the right file",
            path.display(),
            max >> 20
        );
    }
    Ok(bytes)
}

/// [`read_limited`] as UTF-8 text (refused, exit status 2, when it is not).
pub fn read_text_limited(path: &Path, max: u64, what: &str) -> anyhow::Result<String> {
    String::from_utf8(read_limited(path, max, what)?)
        .map_err(|_| crate::refused(format!("{}: not UTF-8 text: not {what}", path.display())))
}

/// Largest robot file, diagnose or validate JSON read (each is kilobytes).
pub const MAX_SMALL_FILE: u64 = 16 << 20;
