//! Reading a constraint measurement file (docs/formats.md, "Constraint measurements"): a
//! `kind` column (`socket`, `plane`, `distance`, `point`), `group`, `q1`…`qN`, optional
//! `length_mm`, `sigma_mm`, `tool`, and `x`, `y`, `z` for `point` rows. Every rule the spec
//! states is checked here and a violation refused (exit 2) with what to do.

use crate::formats::units::{LengthUnit, UnitArgs};
use core::f64::consts::PI;
use std::collections::BTreeMap;
use std::path::Path;

/// σ of a row without `sigma_mm` (mm): a contact or a length good to ten micrometres.
pub const DEFAULT_SIGMA_MM: f64 = 0.01;

/// What the rows of a group say.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// The tool point is at one fixed, unknown location.
    Socket,
    /// The tool point lies on one unknown plane.
    Plane,
    /// Two rows whose tool points are `length_mm` apart.
    Distance,
    /// A tracker point `x`, `y`, `z`.
    Point,
}

impl Kind {
    pub fn id(self) -> &'static str {
        match self {
            Kind::Socket => "socket",
            Kind::Plane => "plane",
            Kind::Distance => "distance",
            Kind::Point => "point",
        }
    }

    fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "socket" => Kind::Socket,
            "plane" => Kind::Plane,
            "distance" => Kind::Distance,
            "point" => Kind::Point,
            _ => return None,
        })
    }
}

/// One row: joint readings in radians, lengths in millimetres.
#[derive(Clone, Debug, PartialEq)]
pub struct Row<const N: usize> {
    pub q: [f64; N],
    /// Tool point index (0: `[tool]` or the first of `[[tools]]`).
    pub tool: usize,
    pub sigma_mm: f64,
    /// The measured point of a `point` row.
    pub xyz: Option<[f64; 3]>,
    /// The arm's temperature (°C) when the row was taken (`temp_c`; `None`: not given, the
    /// model's reference temperature).
    pub temp_c: Option<f64>,
    /// Line of the file.
    pub line: usize,
}

/// The kinds present in `groups`, in the order socket, plane, distance, point, each with the
/// indices of its groups (what the reports tabulate per kind).
pub fn by_kind<const N: usize>(groups: &[Group<N>]) -> Vec<(Kind, Vec<usize>)> {
    [Kind::Socket, Kind::Plane, Kind::Distance, Kind::Point]
        .into_iter()
        .map(|kind| {
            let of = (0..groups.len())
                .filter(|&k| groups[k].kind == kind)
                .collect::<Vec<_>>();
            (kind, of)
        })
        .filter(|(_, of)| !of.is_empty())
        .collect()
}

/// A group of rows tied together by its `group` name.
#[derive(Clone, Debug, PartialEq)]
pub struct Group<const N: usize> {
    pub kind: Kind,
    pub name: String,
    pub rows: Vec<Row<N>>,
    /// The length of a `distance` group (mm).
    pub length_mm: Option<f64>,
}

/// The groups of a constraint file, in the order they first appear.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Session<const N: usize> {
    pub groups: Vec<Group<N>>,
    /// Some row of the file gives `sigma_mm` (else every row has [`DEFAULT_SIGMA_MM`]).
    pub sigma_stated: bool,
}

impl<const N: usize> Session<N> {
    /// Whether any group carries tracker points (then the base is seen).
    pub fn has_points(&self) -> bool {
        self.groups.iter().any(|g| g.kind == Kind::Point)
    }

    /// Rows of all groups.
    pub fn rows(&self) -> usize {
        self.groups.iter().map(|g| g.rows.len()).sum()
    }

    /// Each row's line and joint readings (degrees), for the joint-limit check.
    pub fn joint_rows(&self) -> impl Iterator<Item = (u32, [f64; N])> + Clone + '_ {
        self.groups.iter().flat_map(|g| {
            g.rows
                .iter()
                .map(|r| (r.line as u32, r.q.map(f64::to_degrees)))
        })
    }
}

pub use crate::formats::measurements::is_constraint_file;

/// Loads a constraint file for an `N`-joint robot whose tool points are named `tools` (empty
/// for one `[tool]`), in `units` (joint readings, `length_mm`/`sigma_mm`/`x,y,z` in the length
/// unit). Refuses (exit 2) anything the spec rules out.
pub fn load<const N: usize>(
    path: &Path,
    units: &UnitArgs,
    tools: &[String],
) -> anyhow::Result<Session<N>> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| crate::refused(crate::formats::cannot_read(&origin, &e)))?;
    parse(&text, &origin, units, tools)
}

/// [`load`] on the text of a file named `origin`.
pub fn parse<const N: usize>(
    text: &str,
    origin: &str,
    units: &UnitArgs,
    tools: &[String],
) -> anyhow::Result<Session<N>> {
    let mm = units.length().mm_per_unit();
    let angle = units.angle();
    let mut lines = text
        .trim_start_matches('\u{feff}')
        .lines()
        .enumerate()
        .map(|(k, l)| (k + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((_, header)) = lines.next() else {
        crate::refuse!("{origin}: empty file: a header line with kind, group, q1…q{N} is needed");
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    if names.len() == 1 && header.contains([';', '\t']) {
        crate::refuse!(
            "{origin}: a constraint file separated by `;` or tabs: constraint files are \
             comma-separated with `.` decimals (--map does not read them); convert it"
        );
    }
    // A name given twice would be read at its first column, the other ignored in silence.
    for (k, n) in names.iter().enumerate() {
        if let Some(first) = names[..k]
            .iter()
            .position(|m| m == n)
            .filter(|_| !n.is_empty())
        {
            crate::refuse!(
                "{origin}: the header names column `{n}` twice (columns {} and {}): keep one",
                first + 1,
                k + 1
            );
        }
    }
    let col = |name: &str| names.iter().position(|n| *n == name);
    let required = |name: &str| {
        col(name).ok_or_else(|| {
            crate::refused(format!(
                "{origin}: no `{name}` column: a constraint file has kind, group, q1…q{N}"
            ))
        })
    };
    let (kind_col, group_col) = (required("kind")?, required("group")?);
    let q_cols = (1..=N)
        .map(|j| required(&format!("q{j}")))
        .collect::<anyhow::Result<Vec<usize>>>()?;
    // A length column without its unit in the name would be ignored as an extra column.
    for (written, meant) in [("sigma", "sigma_mm"), ("length", "length_mm")] {
        if col(written).is_some() && col(meant).is_none() {
            crate::refuse!(
                "{origin}: column `{written}`: constraint files name it `{meant}` (millimetres); \
                 rename it, or it is not read"
            );
        }
    }
    let (length_col, sigma_col, tool_col) = (col("length_mm"), col("sigma_mm"), col("tool"));
    // Stated when some row gives a σ (a column of empty cells states none).
    let mut sigma_stated = false;
    let xyz_cols = [col("x"), col("y"), col("z")];
    let temp_col = col("temp_c");
    let mut groups: Vec<Group<N>> = Vec::new();
    let mut index: BTreeMap<String, usize> = BTreeMap::new();
    let mut lengths: Vec<Vec<Option<f64>>> = Vec::new();
    // A row that repeats an earlier one cell for cell is a copy (pasted twice): it adds no
    // information, only weight, and is left out with a warning, as in tracker files.
    let mut seen: BTreeMap<Vec<&str>, usize> = BTreeMap::new();
    let mut copies: Vec<(usize, usize)> = Vec::new();
    for (line, text) in lines {
        let cells: Vec<&str> = text.split(',').map(str::trim).collect();
        if let Some(&first) = seen.get(&cells) {
            copies.push((line, first));
            continue;
        }
        seen.insert(cells.clone(), line);
        let at = |c: usize| cells.get(c).copied().unwrap_or("");
        let number = |c: usize, name: &str| -> anyhow::Result<Option<f64>> {
            let s = at(c);
            if s.is_empty() {
                return Ok(None);
            }
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => Err(crate::refused(format!(
                    "{origin}:{line}: column {name}: `{s}` is not a finite number"
                ))),
            }
        };
        let kind_text = at(kind_col);
        let Some(kind) = Kind::parse(kind_text) else {
            crate::refuse!(
                "{origin}:{line}: kind `{kind_text}` is unknown: use socket, plane, distance or point"
            );
        };
        let name = at(group_col);
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            crate::refuse!(
                "{origin}:{line}: group `{name}`: name groups with letters, digits, `_` and `-`"
            );
        }
        let mut q = [0.0; N];
        for (j, &c) in q_cols.iter().enumerate() {
            let Some(v) = number(c, &format!("q{}", j + 1))? else {
                crate::refuse!(
                    "{origin}:{line}: q{} is empty: every row needs its joint readings",
                    j + 1
                );
            };
            // Degrees read as radians reach tens of turns: refused below.
            if angle == crate::formats::units::AngleUnit::Rad && v.abs() > 4.0 * PI {
                crate::refuse!(
                    "{origin}:{line}: q{} = {v} rad is over two turns: the readings look like \
                     degrees; leave --angle-unit rad out",
                    j + 1
                );
            }
            q[j] = angle.to_deg(v).to_radians();
        }
        let sigma_mm = match sigma_col
            .map(|c| number(c, "sigma_mm"))
            .transpose()?
            .flatten()
        {
            Some(s) if s > 0.0 => {
                sigma_stated = true;
                s * mm
            }
            Some(s) => crate::refuse!("{origin}:{line}: sigma_mm {s} must be > 0"),
            None => DEFAULT_SIGMA_MM,
        };
        let tool = match tool_col.map(at).filter(|t| !t.is_empty()) {
            None => 0,
            Some(t) => tools.iter().position(|n| n == t).ok_or_else(|| {
                crate::refused(format!(
                    "{origin}:{line}: tool `{t}` is not among the robot file's [[tools]] ({})",
                    if tools.is_empty() {
                        "it has one [tool]: leave the column empty".to_string()
                    } else {
                        tools.join(", ")
                    }
                ))
            })?,
        };
        let xyz = if kind == Kind::Point {
            let mut p = [0.0; 3];
            for (a, (c, n)) in xyz_cols.iter().zip(["x", "y", "z"]).enumerate() {
                let v = c.map(|c| number(c, n)).transpose()?.flatten();
                let Some(v) = v else {
                    crate::refuse!("{origin}:{line}: a point row needs x, y and z ({n} is empty)");
                };
                p[a] = v * mm;
            }
            Some(p)
        } else {
            None
        };
        let temp_c = temp_col.map(|c| number(c, "temp_c")).transpose()?.flatten();
        if let Some(t) = temp_c.filter(|t| t.abs() > 1e3) {
            crate::refuse!("{origin}:{line}: temp_c {t} is not a temperature in °C");
        }
        let length = length_col
            .map(|c| number(c, "length_mm"))
            .transpose()?
            .flatten()
            .map(|l| l * mm);
        let k = *index.entry(name.to_string()).or_insert_with(|| {
            groups.push(Group {
                kind,
                name: name.to_string(),
                rows: Vec::new(),
                length_mm: None,
            });
            lengths.push(Vec::new());
            groups.len() - 1
        });
        if groups[k].kind != kind {
            crate::refuse!(
                "{origin}:{line}: group `{name}` is a {} group and this row says {}: one kind per group",
                groups[k].kind.id(),
                kind.id()
            );
        }
        groups[k].rows.push(Row {
            q,
            tool,
            sigma_mm,
            xyz,
            temp_c,
            line,
        });
        lengths[k].push(length);
    }
    let warmest = groups
        .iter()
        .flat_map(|g| &g.rows)
        .filter_map(|r| r.temp_c.map(|t| (r.line, t)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    if let Some(w) =
        warmest.and_then(|(line, t)| crate::formats::loading::warm_line(origin, line as u32, t))
    {
        crate::Tell::line(&mut crate::Stderr, &w);
    }
    if let Some(&(line, first)) = copies.first() {
        crate::Tell::line(
            &mut crate::Stderr,
            &format!(
                "warning: {origin}: {} row(s) repeat an earlier row cell for cell (line {line} \
                 repeats line {first}): copies of a row, not constraints measured again, left \
                 out; delete them from the file",
                copies.len()
            ),
        );
    }
    if groups.is_empty() {
        crate::refuse!("{origin}: no rows: measure some constraints first");
    }
    for (g, ls) in groups.iter_mut().zip(&lengths) {
        check_group(g, ls, origin, units.length())?;
    }
    // Radians read as degrees: a session of any size touches its sockets, planes and bars from
    // poses that span far more than ±6.3° (a unit given explicitly is never second-guessed).
    let rows: Vec<&Row<N>> = groups.iter().flat_map(|g| g.rows.iter()).collect();
    let widest = rows
        .iter()
        .flat_map(|r| r.q.iter())
        .fold(0.0f64, |m, q| m.max(q.to_degrees().abs()));
    if units.angle_unit.is_none() && rows.len() >= 8 && widest <= 2.0 * PI + 1e-9 {
        crate::refuse!(
            "{origin}: joint readings look like radians (every reading lies within ±6.28): pass \
             --angle-unit rad (or --angle-unit deg to keep them)"
        );
    }
    let stated: Vec<(u64, f64)> = rows
        .iter()
        .filter(|_| sigma_stated)
        .map(|r| (r.line as u64, r.sigma_mm))
        .collect();
    crate::formats::tiny_sigma::refuse_tiny(&stated, "sigma_mm", origin)?;
    Ok(Session {
        groups,
        sigma_stated,
    })
}

/// The rules of one group: row counts per kind, one positive length per distance group.
fn check_group<const N: usize>(
    g: &mut Group<N>,
    lengths: &[Option<f64>],
    origin: &str,
    unit: LengthUnit,
) -> anyhow::Result<()> {
    let first = g.rows[0].line;
    let n = g.rows.len();
    match g.kind {
        Kind::Socket | Kind::Plane if n < 4 => crate::refuse!(
            "{origin}:{first}: {} group `{}` has {n} rows: at least 4 are needed (touch it in more poses, or drop the group)",
            g.kind.id(),
            g.name
        ),
        Kind::Distance => {
            if n != 2 {
                crate::refuse!(
                    "{origin}:{first}: distance group `{}` has {n} rows: exactly 2 (its two ends) are needed; give each pair its own group name",
                    g.name
                );
            }
            let (Some(a), Some(b)) = (lengths[0], lengths[1]) else {
                crate::refuse!(
                    "{origin}:{first}: distance group `{}` needs length_mm on both rows",
                    g.name
                );
            };
            if a != b {
                crate::refuse!(
                    "{origin}:{first}: distance group `{}` has two lengths ({} and {} {}): write the same length_mm on both rows",
                    g.name,
                    a / unit.mm_per_unit(),
                    b / unit.mm_per_unit(),
                    unit.flag()
                );
            }
            if a <= 0.0 {
                crate::refuse!(
                    "{origin}:{first}: distance group `{}` has length_mm {a}: a length must be > 0",
                    g.name
                );
            }
            g.length_mm = Some(a);
        }
        _ => {}
    }
    Ok(())
}
