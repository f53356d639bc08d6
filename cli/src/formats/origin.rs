//! A measurement set's name in messages and where its header is: a file's own header line, or
//! the columns of kinecal's layout (`q1…qN, x, y, z` and the extra columns, header on line 1)
//! for a set handed over in memory (the Python package's arrays), the file
//! [`crate::formats::measurements::to_exact_csv_string`] would write for it.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where a measurement set came from, for messages that name its file, line and column.
#[derive(Clone, Debug, PartialEq)]
pub struct Origin {
    name: String,
    header: Header,
}

#[derive(Clone, Debug, PartialEq)]
enum Header {
    /// Read from the file when a message needs it.
    File(PathBuf),
    /// Line 1 with these columns.
    Columns(Vec<String>),
}

impl Origin {
    /// The file at `path`, named by its path.
    pub fn file(path: &Path) -> Self {
        Self {
            name: path.display().to_string(),
            header: Header::File(path.to_path_buf()),
        }
    }

    /// A set in kinecal's layout for an `n`-joint robot with the extra columns `extra`, named
    /// `name`.
    pub fn layout(name: &str, n: usize, extra: &[String]) -> Self {
        let mut columns: Vec<String> = (1..=n).map(|i| format!("q{i}")).collect();
        columns.extend(["x", "y", "z"].map(String::from));
        columns.extend(extra.iter().cloned());
        Self {
            name: name.to_string(),
            header: Header::Columns(columns),
        }
    }

    /// The name messages give it (a path, or what the caller calls the set).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The header's line (1-based) and its column names: of a file, its first line that is
    /// neither blank nor a comment (line 1 and no columns when there is none, or the file
    /// cannot be read).
    pub fn header(&self) -> (usize, Vec<String>) {
        match &self.header {
            Header::Columns(c) => (1, c.clone()),
            Header::File(path) => {
                let text = std::fs::read_to_string(path).unwrap_or_default();
                for (i, l) in text.lines().enumerate() {
                    let t = l.trim().trim_start_matches('\u{feff}');
                    if !t.is_empty() && !t.starts_with('#') {
                        return (
                            i + 1,
                            t.split(',')
                                .map(|c| kinecal::io::csv::column_name(c).to_string())
                                .collect(),
                        );
                    }
                }
                (1, Vec::new())
            }
        }
    }

    /// The header's line (1-based).
    pub fn header_line(&self) -> usize {
        self.header().0
    }

    /// The 1-based column of `name` in the header, if it has one.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.header()
            .1
            .iter()
            .position(|c| c == name)
            .map(|i| i + 1)
    }
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name)
    }
}
