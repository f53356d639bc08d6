//! Words in a number column. The reader takes a cell of a carried column (`t_s`, `temp_c`,
//! `sx_mm`, …) that is no number for an empty one, so that a placeholder (`-`, `n/a`) leaves a
//! row without that value. A column that is mostly words is no such placeholder: a time written
//! as a date (`2026-11-02 10:00:00`) or a temperature with its unit (`21.5 °C`) would be left
//! out of every row in silence (a `base-drift` or `thermal-expansion` fitted to nothing, the
//! drift check blind). Refused (exit 2), naming the first such cell and what to do.

/// Share of a column's non-empty cells that may be words before the column is refused.
pub const MOST_WORDS: f64 = 0.5;

/// Counts of one column's cells: the first word (line, text), how many words, how many
/// non-empty cells.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Words {
    pub first: Option<(u32, String)>,
    pub words: usize,
    pub filled: usize,
}

impl Words {
    /// Counts one cell (its text trimmed) of line `line`; `number`: whether it reads as one.
    pub fn count(&mut self, line: u32, text: &str, number: bool) {
        if text.is_empty() {
            return;
        }
        self.filled += 1;
        if !number {
            self.words += 1;
            if self.first.is_none() {
                self.first = Some((line, text.chars().take(40).collect()));
            }
        }
    }

    /// The refusal for column `name` of `origin` when its cells are mostly words.
    pub fn refusal(&self, origin: &str, name: &str, how: &str) -> Option<String> {
        let (line, text) = self.first.as_ref()?;
        if (self.words as f64) <= MOST_WORDS * self.filled as f64 {
            return None;
        }
        let hint = match name {
            "t_s" => {
                " (a date and time? read the file with --map M.toml whose [units] time gives \
                 its pattern, such as \"%Y-%m-%d %H:%M:%S\"; docs/formats.md, \"Files in other \
                 layouts\")"
            }
            _ => " (a unit written in the cells? write the numbers alone)",
        };
        Some(format!(
            "{origin}:{line}: '{text}' in column {name}{how} is not a number, nor are {} of its \
             {} cells: kinecal reads {name} as numbers{hint}",
            self.words - 1,
            self.filled - 1
        ))
    }
}

/// kinecal's number columns besides the joints and the point (docs/formats.md, "Measurement
/// CSV", "Observations"); the `x_NAME`… of named reflectors too. Other columns (a pose's name,
/// a comment) are the user's and may hold anything.
pub fn read_as_numbers(name: &str) -> bool {
    const NAMES: [&str; 15] = [
        "t_s", "temp_c", "sx_mm", "sy_mm", "sz_mm", "srot_deg", "srx_deg", "sry_deg", "srz_deg",
        "rx_deg", "ry_deg", "rz_deg", "rx", "ry", "rz",
    ];
    NAMES.contains(&name)
        || ["x_", "y_", "z_"]
            .iter()
            .any(|p| name.strip_prefix(p).is_some_and(|r| !r.is_empty()))
}

/// The refusal for the first of kinecal's number columns ([`read_as_numbers`]) of the CSV text
/// `bytes` (kinecal's layout, comma-separated; `extra_names` as the reader carried them) whose
/// cells are mostly words.
pub fn refusal(bytes: &[u8], extra_names: &[String], origin: &str) -> Option<String> {
    let text = String::from_utf8_lossy(bytes);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines.next()?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let at: Vec<(usize, &String)> = extra_names
        .iter()
        .filter(|n| read_as_numbers(n))
        .filter_map(|n| Some((names.iter().position(|c| c == n)?, n)))
        .collect();
    let mut words: Vec<Words> = vec![Words::default(); at.len()];
    for (i, l) in lines {
        let cells: Vec<&str> = l.split(',').collect();
        for ((k, _), w) in at.iter().zip(&mut words) {
            let t = cells.get(*k).map_or("", |c| c.trim());
            w.count(i as u32 + 1, t, t.parse::<f64>().is_ok());
        }
    }
    at.iter()
        .zip(&words)
        .find_map(|((_, n), w)| w.refusal(origin, n, ""))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_of_dates_is_refused_and_a_few_placeholders_are_not() {
        let names = vec!["t_s".to_string(), "temp_c".to_string()];
        let dated =
            "q1,x,y,z,t_s,temp_c\n1,2,3,4,2026-11-02 10:00:00,21\n1,2,3,4,2026-11-02 10:01:00,-\n";
        let e = refusal(dated.as_bytes(), &names, "d.csv").unwrap();
        assert!(
            e.starts_with("d.csv:2: '2026-11-02 10:00:00' in column t_s"),
            "{e}"
        );
        assert!(e.contains("[units] time"), "{e}");
        let placeholders = "q1,x,y,z,t_s,temp_c\n1,2,3,4,0,21\n1,2,3,4,1,-\n1,2,3,4,2,22\n";
        assert_eq!(refusal(placeholders.as_bytes(), &names, "d.csv"), None);
        // A column of the user's own may hold words.
        let named = "q1,x,y,z,pose\n1,2,3,4,home\n1,2,3,4,left\n";
        assert_eq!(
            refusal(named.as_bytes(), &["pose".to_string()], "d.csv"),
            None
        );
    }
}
