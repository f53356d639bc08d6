//! The text layout of a file read through a map: its content lines, the delimiter (given or
//! detected) and numbers with a decimal point or a decimal comma.

use super::spec::Delimiter;

/// A line that holds content (neither blank nor a `#` comment), with its 1-based number.
pub struct Line<'a> {
    pub number: u32,
    pub text: &'a str,
}

/// The content lines of a text (a `\r` before each newline dropped).
pub fn content_lines(text: &str) -> Vec<Line<'_>> {
    text.split('\n')
        .enumerate()
        .map(|(i, l)| Line {
            number: (i + 1) as u32,
            text: l.strip_suffix('\r').unwrap_or(l),
        })
        .filter(|l| {
            let t = l.text.trim();
            !(t.is_empty() || t.starts_with('#'))
        })
        .collect()
}

/// Lines looked at to detect the delimiter.
const DETECT_LINES: usize = 8;

/// The delimiter that splits the first lines into the same number (at least two) of cells,
/// the most cells winning, tab, `;`, `,`, spaces in this order among equals; `,` is no
/// candidate with decimal commas. `None` when no candidate splits them consistently.
pub fn detect(lines: &[Line<'_>], decimal_comma: bool) -> Option<Delimiter> {
    let first: Vec<&str> = lines.iter().take(DETECT_LINES).map(|l| l.text).collect();
    let mut best: Option<(Delimiter, usize)> = None;
    for d in Delimiter::ALL {
        if decimal_comma && d == Delimiter::Comma {
            continue;
        }
        let counts: Vec<usize> = first.iter().map(|l| d.split(l.trim()).len()).collect();
        let Some(&n) = counts.first() else { continue };
        if n < 2 || counts.iter().any(|c| *c != n) {
            continue;
        }
        // A file written with `;` or tabs keeps them even when its numbers hold commas.
        if matches!(best, Some((Delimiter::Tab | Delimiter::Semicolon, _))) {
            continue;
        }
        if best.is_none_or(|(_, m)| n > m) {
            best = Some((d, n));
        }
    }
    best.map(|(d, _)| d)
}

/// A cell as text: surrounding spaces and double quotes removed.
pub fn cell_text(cell: &str) -> &str {
    kinecal::io::csv::column_name(cell)
}

/// A cell that is not a number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NotANumber;

/// The number in a cell: `Ok(None)` for an empty cell, `Err(NotANumber)` when it is not one.
/// With `decimal_comma`, `3,14` is 3.14 (and a cell with a `.` is not a number: thousands
/// separators are not read).
pub fn number(cell: &str, decimal_comma: bool) -> Result<Option<f64>, NotANumber> {
    let t = cell_text(cell);
    if t.is_empty() {
        return Ok(None);
    }
    let parsed = if decimal_comma {
        if t.contains('.') {
            return Err(NotANumber);
        }
        t.replacen(',', ".", 1).parse::<f64>()
    } else {
        t.parse::<f64>()
    };
    parsed.map(Some).map_err(|_| NotANumber)
}
