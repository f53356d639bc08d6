//! Atomic file output: a reader, a crash or a `kill -9` sees either the previous file or the
//! whole new one, never a half-written file.
//!
//! The bytes go to a temporary file beside the target (same directory, so the same file
//! system), which is flushed to disk and then renamed over the target; finally the directory
//! is synced so that the rename itself survives a power loss. On error the temporary file is
//! removed and the target is untouched.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A temporary name beside `path`: `.NAME.tmp-PID-K` (hidden, unique per process and call).
fn temporary_beside(path: &Path) -> io::Result<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(io::ErrorKind::InvalidInput, "the output path names no file")
    })?;
    let k = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = format!(".{}.tmp-{}-{k}", name.to_string_lossy(), std::process::id());
    Ok(path.with_file_name(tmp))
}

/// What an existing output path is, following links.
enum Existing {
    /// Nothing there yet, or a regular file: written atomically.
    RegularOrNone,
    /// A character device or a FIFO (`/dev/null`, `/dev/stdout` on a pipe): a stream, written
    /// into directly; renaming a file over it would replace the device node itself.
    Stream,
    /// A directory, a block device, a socket: refused.
    Other(&'static str),
}

fn existing(path: &Path) -> Existing {
    let Ok(meta) = fs::metadata(path) else {
        return Existing::RegularOrNone;
    };
    let t = meta.file_type();
    if t.is_file() {
        return Existing::RegularOrNone;
    }
    if t.is_dir() {
        return Existing::Other("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() || t.is_fifo() {
            return Existing::Stream;
        }
        if t.is_block_device() {
            return Existing::Other("a block device");
        }
        if t.is_socket() {
            return Existing::Other("a socket");
        }
    }
    Existing::Other("not a regular file")
}

/// Writes `bytes` to `path` atomically (temporary file beside it, fsync, rename, directory
/// fsync). The file gets the usual permissions of a new file (or keeps the old file's mode when
/// it replaces one).
///
/// An existing character device or FIFO (`/dev/null`, `/dev/stdout`) is written into directly,
/// and its write errors (`/dev/full`: no space left) are returned; a directory, block device or
/// socket is an error. A symbolic link to a regular file is followed: the file it points to is
/// replaced and the link kept (`/dev/stdout` redirected to a file, a link into another
/// directory).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    match existing(path) {
        Existing::RegularOrNone => {}
        Existing::Stream => {
            let mut f = OpenOptions::new().write(true).open(path)?;
            f.write_all(bytes)?;
            return f.flush();
        }
        Existing::Other(what) => {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("{} is {what}: give the path of a file", path.display()),
            ))
        }
    }
    let resolved;
    let path = match fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            resolved = fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
            resolved.as_path()
        }
        _ => path,
    };
    let tmp = temporary_beside(path)?;
    let result = (|| {
        let mut f = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        if let Ok(old) = fs::metadata(path) {
            // Keep the mode of the file being replaced (best effort).
            let _ = f.set_permissions(old.permissions());
        }
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
        return result;
    }
    // Make the rename durable; not every platform or file system lets a directory be opened.
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// True when `a` and `b` name the same file (the same path, or the same file through links or
/// relative paths once both exist).
pub fn same_file(a: &Path, b: &Path) -> bool {
    a == b || (a.canonicalize().ok().is_some() && a.canonicalize().ok() == b.canonicalize().ok())
}

/// Refuses (exit 2) an output path that names one of the command's inputs: `identify --data D
/// --out D` must not destroy the measurements it just read.
pub fn refuse_overwriting_inputs(
    flag: &str,
    out: &Path,
    inputs: &[(&str, &Path)],
) -> anyhow::Result<()> {
    for (name, input) in inputs {
        if same_file(out, input) {
            crate::refuse!(
                "{flag} {} is the {name} file: choose another output path (kinecal never writes over its inputs)",
                out.display()
            );
        }
    }
    Ok(())
}

/// [`refuse_overwriting_inputs`] for a command that writes a model (`--out`) from a robot file,
/// a data file and an optional validation file (`identify`, `diagnose`).
pub fn refuse_model_over_inputs(
    out: Option<&Path>,
    robot: &Path,
    data: &Path,
    validate: Option<&Path>,
) -> anyhow::Result<()> {
    let Some(out) = out else { return Ok(()) };
    let mut inputs = vec![("robot", robot), ("data", data)];
    if let Some(v) = validate {
        inputs.push(("validation", v));
    }
    refuse_overwriting_inputs("--out", out, &inputs)
}
