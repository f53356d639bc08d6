//! The map file (`--map M.toml`, docs/formats.md "Files in other layouts"): how to read a
//! measurement, sweep or target file written in another layout — its delimiter, decimal
//! separator, header, column names and units — checked as it is read.

use crate::formats::rotation_order::RotationOrder;
use crate::formats::units::{AngleUnit, LengthUnit};
use serde::Deserialize;
use std::path::Path;

/// A column of the file: its header name or its 1-based number.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum ColumnRef {
    Name(String),
    Number(i64),
}

impl ColumnRef {
    /// `measurement_x` or `column 3`, for messages.
    pub fn describe(&self) -> String {
        match self {
            ColumnRef::Name(n) => format!("`{n}`"),
            ColumnRef::Number(k) => format!("column {k}"),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawUnits {
    joints: Option<String>,
    length: Option<String>,
    orientation: Option<String>,
    rotation: Option<String>,
    time: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMap {
    delimiter: Option<String>,
    decimal: Option<String>,
    header: Option<bool>,
    #[serde(default)]
    columns: toml::Table,
    units: Option<RawUnits>,
}

/// The cell separator of a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delimiter {
    Comma,
    Semicolon,
    Tab,
    /// One or more spaces (or tabs) between cells.
    Space,
}

impl Delimiter {
    /// The candidates of detection, most specific first.
    pub const ALL: [Delimiter; 4] = [
        Delimiter::Tab,
        Delimiter::Semicolon,
        Delimiter::Comma,
        Delimiter::Space,
    ];

    /// The cells of a line.
    pub fn split(self, line: &str) -> Vec<&str> {
        match self {
            Delimiter::Comma => line.split(',').collect(),
            Delimiter::Semicolon => line.split(';').collect(),
            Delimiter::Tab => line.split('\t').collect(),
            Delimiter::Space => line.split_whitespace().collect(),
        }
    }

    /// How the map file writes it.
    pub fn text(self) -> &'static str {
        match self {
            Delimiter::Comma => "\",\"",
            Delimiter::Semicolon => "\";\"",
            Delimiter::Tab => "tab",
            Delimiter::Space => "\" \"",
        }
    }
}

/// Units of the file's kinds of values; `None` = not stated (the defaults, mm and degrees,
/// then questioned by the plausibility check as without a map).
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct MapUnits {
    pub joints: Option<AngleUnit>,
    pub length: Option<LengthUnit>,
    pub orientation: Option<AngleUnit>,
    /// How `t_s` is written: `None` in seconds (numbers), or a date and time pattern
    /// (`%Y%m%d%H%M%S`, chrono's `strftime` specifiers) read as seconds since 1970-01-01
    /// 00:00:00 of the same clock.
    pub time: Option<String>,
}

/// What a time pattern (`[units] time`, chrono's strftime specifiers) states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeFields {
    /// A date alone: its midnight.
    Date,
    /// A date and a time of day, with no zone (read as they are).
    DateTime,
    /// An instant: a zone offset (`%z`, RFC 3339 or 2822) or seconds since 1970 (`%s`).
    Instant,
}

impl TimeFields {
    /// Classifies `pattern`, or says why it cannot be one: no specifier, one chrono does not
    /// know, a time of day without a date, a 12-hour clock without AM/PM.
    pub fn of(pattern: &str) -> Result<TimeFields, &'static str> {
        use chrono::format::{Fixed, Item, Numeric, StrftimeItems};
        let (mut date, mut time, mut instant, mut hour12, mut am_pm, mut any) =
            (false, false, false, false, false, false);
        let mut after_separator = false;
        for item in StrftimeItems::new(pattern) {
            if matches!(item, Item::Numeric(Numeric::Nanosecond, _)) && after_separator {
                return Err("%f after a point or comma counts nanoseconds, not a fraction: write %.f for a point, %3f, %6f or %9f for that many digits after a comma");
            }
            after_separator = matches!(&item, Item::Literal(l) if l.ends_with(['.', ',']))
                || matches!(&item, Item::OwnedLiteral(l) if l.ends_with(['.', ',']));
            match item {
                Item::Error => return Err("not a pattern chrono can read"),
                Item::Literal(_) | Item::OwnedLiteral(_) | Item::Space(_) | Item::OwnedSpace(_) => {
                }
                Item::Numeric(n, _) => {
                    any = true;
                    match n {
                        Numeric::Hour | Numeric::Minute | Numeric::Second | Numeric::Nanosecond => {
                            time = true
                        }
                        Numeric::Hour12 => (time, hour12) = (true, true),
                        Numeric::Timestamp => instant = true,
                        _ => date = true,
                    }
                }
                Item::Fixed(f) => {
                    any = true;
                    match f {
                        Fixed::LowerAmPm | Fixed::UpperAmPm => am_pm = true,
                        // `Internal`: chrono's %3f, %6f, %9f (digits without a point).
                        Fixed::Nanosecond
                        | Fixed::Nanosecond3
                        | Fixed::Nanosecond6
                        | Fixed::Nanosecond9
                        | Fixed::Internal(_) => time = true,
                        Fixed::TimezoneName => {
                            return Err(
                                "%Z, a zone's name, cannot be read: write %z for its offset",
                            )
                        }
                        Fixed::TimezoneOffset
                        | Fixed::TimezoneOffsetColon
                        | Fixed::TimezoneOffsetDoubleColon
                        | Fixed::TimezoneOffsetTripleColon
                        | Fixed::TimezoneOffsetColonZ
                        | Fixed::TimezoneOffsetZ
                        | Fixed::RFC2822
                        | Fixed::RFC3339 => instant = true,
                        _ => date = true,
                    }
                }
            }
        }
        if !any {
            return Err("no date or time specifier (%Y, %m, %d, %H, …)");
        }
        if hour12 && !am_pm {
            return Err("a 12-hour clock (%I) without AM/PM (%p)");
        }
        if !date && !instant {
            return Err("a time of day without the date: the rows' times must be comparable");
        }
        Ok(if instant {
            TimeFields::Instant
        } else if time {
            TimeFields::DateTime
        } else {
            TimeFields::Date
        })
    }
}

/// A map file, read and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFile {
    /// `None`: detected from the file.
    pub delimiter: Option<Delimiter>,
    pub decimal_comma: bool,
    pub header: bool,
    /// kinecal's column name → the file's column, in the map file's order.
    pub columns: Vec<(String, ColumnRef)>,
    pub units: MapUnits,
    /// The order in which the file's three angles compose the rotation.
    pub rotation: RotationOrder,
}

/// Whether `name` can be a kinecal column name (letters, digits, `_`).
fn is_name(name: &str) -> bool {
    !name.is_empty() && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
}

impl MapFile {
    /// Reads and checks a map file; every mistake is refused (exit 2) naming the file and
    /// the entry.
    pub fn load(path: &Path) -> anyhow::Result<MapFile> {
        let text =
            crate::formats::read_text_limited(path, crate::formats::MAX_SMALL_FILE, "a map file")?;
        Self::parse(&text, &path.display().to_string())
    }

    /// [`MapFile::load`] of a text (`origin` names it in messages).
    pub fn parse(text: &str, origin: &str) -> anyhow::Result<MapFile> {
        let raw: RawMap = toml::from_str(text).map_err(|e| {
            let first = e.message().lines().next().unwrap_or("").trim().to_string();
            crate::refused(format!(
                "{origin}: not a map file ({first}): see docs/formats.md, \"Files in other layouts\""
            ))
        })?;
        let delimiter = match raw.delimiter.as_deref() {
            None => None,
            Some(",") => Some(Delimiter::Comma),
            Some(";") => Some(Delimiter::Semicolon),
            Some("\t") | Some("tab") => Some(Delimiter::Tab),
            Some(" ") | Some("space") => Some(Delimiter::Space),
            Some(d) => crate::refuse!(
                "{origin}: delimiter = {d:?}: give \",\", \";\", \"\\t\" (tab) or \" \" (spaces), or leave it out to have it detected"
            ),
        };
        let decimal_comma = match raw.decimal.as_deref() {
            None | Some(".") => false,
            Some(",") => true,
            Some(d) => crate::refuse!("{origin}: decimal = {d:?}: give \".\" or \",\""),
        };
        if decimal_comma && delimiter == Some(Delimiter::Comma) {
            crate::refuse!(
                "{origin}: decimal = \",\" with delimiter = \",\": a file with decimal commas separates its cells otherwise; give its delimiter"
            );
        }
        let header = raw.header.unwrap_or(true);
        let mut columns = Vec::new();
        for (name, v) in raw.columns {
            if !is_name(&name) {
                crate::refuse!(
                    "{origin}: [columns] {name:?}: kinecal's column names are letters, digits and _ (q1, x, rx_deg, …)"
                );
            }
            let r: ColumnRef = v.clone().try_into().map_err(|_| {
                crate::refused(format!(
                    "{origin}: [columns] {name} = {v}: give the file's column name (a string) or its 1-based number"
                ))
            })?;
            match &r {
                ColumnRef::Number(k) if *k < 1 => crate::refuse!(
                    "{origin}: [columns] {name} = {k}: column numbers start at 1"
                ),
                ColumnRef::Name(n) if !header => crate::refuse!(
                    "{origin}: [columns] {name} = {n:?} with header = false: a file without a header has no column names; give the column's 1-based number"
                ),
                _ => {}
            }
            columns.push((name, r));
        }
        let has = |n: &str| columns.iter().any(|(k, _)| k == n);
        let per_axis = ["srx_deg", "sry_deg", "srz_deg"];
        let given = per_axis.iter().filter(|n| has(n)).count();
        if given > 0 && given < 3 {
            crate::refuse!(
                "{origin}: [columns] per-axis angle σ needs all of srx_deg, sry_deg, srz_deg (or one srot_deg)"
            );
        }
        if given == 3 && has("srot_deg") {
            crate::refuse!(
                "{origin}: [columns] srot_deg and srx_deg, sry_deg, srz_deg: give one of the two"
            );
        }
        let u = raw.units.unwrap_or(RawUnits {
            joints: None,
            length: None,
            orientation: None,
            rotation: None,
            time: None,
        });
        let angle = |what: &str, v: Option<String>| -> anyhow::Result<Option<AngleUnit>> {
            match v.as_deref() {
                None => Ok(None),
                Some("deg") => Ok(Some(AngleUnit::Deg)),
                Some("rad") => Ok(Some(AngleUnit::Rad)),
                Some(o) => Err(crate::refused(format!(
                    "{origin}: [units] {what} = {o:?}: give \"deg\" or \"rad\""
                ))),
            }
        };
        let time = match u.time {
            None => None,
            Some(t) if t == "s" => None,
            Some(t) => match TimeFields::of(&t) {
                Ok(_) => Some(t),
                Err(why) => crate::refuse!(
                    "{origin}: [units] time = {t:?}: {why}; give \"s\" (seconds) or the pattern the file writes its times in, such as \"%Y-%m-%d %H:%M:%S\" or \"%Y%m%d%H%M%S\" (docs/formats.md, \"Files in other layouts\")"
                ),
            },
        };
        let units = MapUnits {
            joints: angle("joints", u.joints)?,
            orientation: angle("orientation", u.orientation)?,
            length: match u.length.as_deref() {
                None => None,
                Some("mm") => Some(LengthUnit::Mm),
                Some("m") => Some(LengthUnit::M),
                Some(o) => {
                    let convert = match o.to_ascii_lowercase().as_str() {
                        "in" | "inch" | "inches" | "\"" => {
                            " (inches: multiply x, y, z by 25.4 and give \"mm\")"
                        }
                        "cm" => " (centimetres: multiply x, y, z by 10 and give \"mm\")",
                        "ft" | "feet" => " (feet: multiply x, y, z by 304.8 and give \"mm\")",
                        _ => "",
                    };
                    crate::refuse!(
                        "{origin}: [units] length = {o:?}: give \"mm\" or \"m\", the units kinecal reads{convert}"
                    )
                }
            },
            time,
        };
        let rotation = match u.rotation.as_deref() {
            None => RotationOrder::KINECAL,
            Some(r) => RotationOrder::parse(r).ok_or_else(|| {
                crate::refused(format!(
                    "{origin}: [units] rotation = {r:?}: give the order of the three factors, one of \"Rz*Ry*Rx\" (kinecal's own), \"Rx*Ry*Rz\", \"Rx*Rz*Ry\", \"Ry*Rx*Rz\", \"Ry*Rz*Rx\", \"Rz*Rx*Ry\""
                ))
            })?,
        };
        Ok(MapFile {
            delimiter,
            decimal_comma,
            header,
            columns,
            units,
            rotation,
        })
    }
}
