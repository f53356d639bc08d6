//! Measurement, sweep and target files through their doors (docs/formats.md, "Measurement
//! CSV"): read (in kinecal's layout, or another through `--map`), a stated base checked
//! ("Base"), the units checked and converted ("Units and the plausibility check"), then the
//! order of the angles of 6-D rows ("The convention check"), points computed from the joints and
//! joints rounded past use ("Rounded and computed points"); measurements lose the rows whose
//! tracker reading did not update ("Stale readings").

use crate::formats::computed_points;
use crate::formats::measurements::{self, Dataset};
use crate::formats::rotation_order::RotationOrder;
use crate::formats::stale;
use crate::formats::units::{accept, convert, FileKind, UnitArgs};
use kinecal::Robot;
use std::path::Path;

/// Loads a file of `kind` in `units`: malformed input and implausible units are refused
/// (exit 2); the records come back in millimetres and degrees. `base_known`: whether
/// `nominal`'s base places the points (otherwise it is fitted for the check).
pub fn load_as<const N: usize, V: kinecal::ValueStorage>(
    path: &Path,
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    kind: FileKind,
) -> anyhow::Result<Dataset<N>> {
    let origin = path.display().to_string();
    if crate::formats::measurements::is_constraint_file(path) {
        crate::refuse!(
            "{origin}: a constraint file (kind column): check, identify, validate, report and diagnose read \
             constraint files; give this command tracker points (x, y, z per row)"
        );
    }
    let measured = kind == FileKind::Measurements;
    let Some(map) = &units.map else {
        let ds = measurements::load::<N>(path)?;
        return accept_dataset(ds, &origin, units, nominal, base_known, kind);
    };
    let m = crate::formats::map::load::<N>(path, map, units, kind)?;
    if measured && base_known {
        placement(&m.dataset, &m.units, nominal, &origin)?;
    }
    let steps = steps_of(&m.dataset, &m.units);
    stated_told(&m.dataset, &m.units, nominal, base_known, &origin, kind);
    let ds = accept(m.dataset, &origin, &m.units, nominal, base_known, kind).map_err(|e| {
        crate::refused(format!(
            "{e} (with --map {}: or state the unit in its [units])",
            map.display()
        ))
    })?;
    if measured {
        let stated = Some((m.raw_angles.as_slice(), m.rotation, map.as_path()));
        convention(&ds, stated, nominal, &origin)?;
        rounded(&ds, &steps, nominal, base_known, &origin)?;
        let ds = told(without_stale(ds, nominal, &origin), &origin);
        return Ok(tables_told(ds, nominal, &origin));
    }
    if kind == FileKind::Targets {
        let stated = Some((m.raw_angles.as_slice(), m.rotation, map.as_path()));
        if m.raw_angles.len() == ds.len() {
            convention(&ds, stated, nominal, &origin)?;
        }
        return Ok(tables_told(ds, nominal, &origin));
    }
    Ok(ds)
}

/// `ds` after the warnings about its columns ([`warm`], [`clock_back`],
/// [`super::pace::warning`]) are told on stderr:
/// the same for a file in kinecal's layout and one read through a map.
fn told<const N: usize>(ds: Dataset<N>, origin: &str) -> Dataset<N> {
    let pace = ds
        .extra_names
        .iter()
        .position(|n| n == crate::formats::measurements::TIME_COLUMN)
        .and_then(|k| {
            let times: Vec<f64> = ds
                .records
                .iter()
                .map(|r| r.extra.get(k).copied().unwrap_or(f64::NAN))
                .collect();
            let moved: Vec<bool> = ds
                .records
                .windows(2)
                .map(|w| {
                    w[0].q_deg
                        .iter()
                        .zip(&w[1].q_deg)
                        .any(|(a, b)| (a - b).abs() > super::pace::MOVE_DEG)
                })
                .collect();
            super::pace::warning(&times, &moved, origin)
        });
    let turned = orientation_elsewhere(&ds.extra_names, origin);
    for w in [warm(&ds, origin), clock_back(&ds, origin), pace, turned]
        .into_iter()
        .flatten()
    {
        crate::Tell::line(&mut crate::Stderr, &w);
    }
    ds
}

/// Column sets that hold a probe's orientation under other names than `rx_deg`, `ry_deg`,
/// `rz_deg`: compensate's target columns, radians, a vendor's A, B, C or W, P, R, roll, pitch,
/// yaw, and quaternions. A file with one of them and no `rx_deg` was calibrated as positions
/// alone without a word: it is warned about (not refused: the columns may mean something
/// else, and `check` has no `--positions-only`).
const ORIENTATION_LOOKALIKES: [&[&str]; 8] = [
    &["rx", "ry", "rz"],
    &["rx_rad", "ry_rad", "rz_rad"],
    &["rot_x", "rot_y", "rot_z"],
    &["a", "b", "c"],
    &["w", "p", "r"],
    &["roll", "pitch", "yaw"],
    &["qw", "qx", "qy", "qz"],
    &["q_w", "q_x", "q_y", "q_z"],
];

/// The warning for extra columns `names` of `origin` that look like an orientation kinecal
/// does not read (and no `rx_deg`), or `None`.
fn orientation_elsewhere(names: &[String], origin: &str) -> Option<String> {
    let has = |c: &str| names.iter().any(|n| n.eq_ignore_ascii_case(c));
    if has("rx_deg") {
        return None;
    }
    let set = ORIENTATION_LOOKALIKES
        .iter()
        .find(|set| set.iter().all(|c| has(c)))?;
    let listed = set.join(", ");
    let how = if set.len() == 4 {
        "a quaternion"
    } else {
        "angles or a rotation vector (UR's rx, ry, rz)"
    };
    Some(format!(
        "warning: {origin}: columns {listed} look like the probe's orientation as {how}, which \
         kinecal reads only from rx_deg, ry_deg, rz_deg (degrees, R = Rz·Ry·Rx): they are \
         ignored and the positions calibrated alone; to use them, convert them to those \
         columns (or name angles in a --map with their unit and rotation order)"
    ))
}

/// A dataset already read in kinecal's layout (a file, or arrays handed over by the Python
/// package) through the same doors as a file: the stated base, the units, the angle order.
/// `origin` names it in a refusal.
pub fn accept_dataset<const N: usize, V: kinecal::ValueStorage>(
    ds: Dataset<N>,
    origin: &str,
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    kind: FileKind,
) -> anyhow::Result<Dataset<N>> {
    let measured = kind == FileKind::Measurements;
    if measured && base_known {
        placement(&ds, units, nominal, origin)?;
    }
    let steps = steps_of(&ds, units);
    stated_told(&ds, units, nominal, base_known, origin, kind);
    let ds = accept(ds, origin, units, nominal, base_known, kind)?;
    if measured {
        convention(&ds, None, nominal, origin)?;
        rounded(&ds, &steps, nominal, base_known, origin)?;
        let ds = told(without_stale(ds, nominal, origin), origin);
        return Ok(tables_told(ds, nominal, origin));
    }
    if kind == FileKind::Targets {
        if units.angle_unit.is_none() {
            target_radians(&ds, nominal, origin)?;
        }
        convention(&ds, None, nominal, origin)?;
        return Ok(tables_told(ds, nominal, origin));
    }
    Ok(ds)
}

/// Refuses (exit 2) pose targets whose `rx`, `ry`, `rz` (read as degrees, the unit not given)
/// the nominal model's orientations at the seeds explain [`crate::formats::convention::CLEAR_RATIO`]
/// times better read as radians, in whichever order.
fn target_radians<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    nominal: &Robot<f64, N, V>,
    origin: &str,
) -> anyhow::Result<()> {
    use crate::formats::convention::{scores, CLEAR_RATIO, FLOOR_DEG};
    let [Some(x), Some(y), Some(z)] = ["rx", "ry", "rz"].map(|c| ds.extra(c)) else {
        return Ok(());
    };
    let q: Vec<[f64; N]> = ds.records.iter().map(|r| r.q_deg).collect();
    let deg: Vec<[f64; 3]> = (0..ds.len()).map(|i| [x[i], y[i], z[i]]).collect();
    let rad: Vec<[f64; 3]> = deg.iter().map(|a| a.map(f64::to_degrees)).collect();
    let best = |a: &[[f64; 3]]| {
        scores(&q, a, nominal).and_then(|s| s.into_iter().map(|(_, v)| v).reduce(f64::min))
    };
    if let (Some(as_deg), Some(as_rad)) = (best(&deg), best(&rad)) {
        if as_rad * CLEAR_RATIO <= as_deg && as_deg > FLOOR_DEG {
            crate::refuse!(
                "{origin}: rx, ry, rz look like radians (the nominal orientations at the seeds \
                 leave {:.3}° RMS read as radians, {:.3}° as degrees): convert them to degrees, \
                 give --angle-unit rad when the joints are in radians too, or read the file \
                 with --map M.toml whose [units] say orientation = \"rad\"",
                as_rad,
                as_deg
            );
        }
    }
    Ok(())
}

/// The warning of [`crate::formats::stated_units`] about `ds` (as read), told on stderr.
fn stated_told<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    origin: &str,
    kind: FileKind,
) {
    use crate::formats::stated_units::stated_otherwise;
    if let Some(w) = stated_otherwise(&ds.records, units, nominal, base_known, origin, kind) {
        crate::Tell::line(&mut crate::Stderr, &w);
    }
}

/// The steps `ds` (as read, in `units`) is written with.
fn steps_of<const N: usize>(ds: &Dataset<N>, units: &UnitArgs) -> computed_points::Steps<N> {
    let radians = units.angle() == crate::formats::units::AngleUnit::Rad;
    computed_points::Steps::of(ds, units.length().mm_per_unit(), radians)
}

/// Refuses computed points and joints rounded past use ([`computed_points`]); tells the
/// warning about coarse joints on stderr.
fn rounded<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    steps: &computed_points::Steps<N>,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    origin: &str,
) -> anyhow::Result<()> {
    if let Some(w) = computed_points::check(ds, steps, nominal, base_known, origin)? {
        crate::Tell::line(&mut crate::Stderr, &w);
    }
    Ok(())
}

/// `ds` after the lines about joint tables of `nominal` whose knots miss its readings
/// ([`super::table_reach`]) are told on stderr (sweeps are not corrected by tables: none).
fn tables_told<const N: usize, V: kinecal::ValueStorage>(
    ds: Dataset<N>,
    nominal: &Robot<f64, N, V>,
    origin: &str,
) -> Dataset<N> {
    for line in super::table_reach::lines(&ds, nominal, origin, None) {
        crate::Tell::line(&mut crate::Stderr, &line);
    }
    ds
}

/// Above this `temp_c` (°C) a file is warned about: a room logged in degrees Fahrenheit reads
/// 65–80, while air around a robot being calibrated is cooler. An arm's own sensors (motors,
/// links) can read that warm, so it is not refused
/// ([`crate::formats::observations::MAX_TEMP_C`] is what no arm reaches).
pub const WARM_C: f64 = 50.0;

/// The warning for a `temp_c` column that reaches [`WARM_C`], naming the warmest row's line.
fn warm<const N: usize>(ds: &Dataset<N>, origin: &str) -> Option<String> {
    let k = ds
        .extra_names
        .iter()
        .position(|n| n == crate::formats::measurements::TEMPERATURE_COLUMN)?;
    let (line, t) = ds
        .records
        .iter()
        .filter_map(|r| r.extra.get(k).map(|t| (r.line, *t)))
        .filter(|(_, t)| t.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    warm_line(origin, line, t)
}

/// The warning for the warmest `temp_c` of a file, `t` on line `line`, when it exceeds
/// [`WARM_C`] (measurement files here; constraint files in `constraints::read`).
pub fn warm_line(origin: &str, line: u32, t: f64) -> Option<String> {
    (t > WARM_C).then(|| {
        format!(
            "warning: {origin}: temp_c reaches {t} °C (line {line}): kinecal reads °C; if the \
             column is in degrees Fahrenheit, convert it, (F − 32) × 5/9"
        )
    })
}

/// A step back in `t_s` shorter than this (s) is a clock's jitter, not rows out of time order.
pub const CLOCK_JITTER_S: f64 = 1.0;
/// Dates: a few rows out of order (at most 1 % of the steps) are not named (the real series A
/// appends ten rows of earlier days at its end).
pub use super::pace::DATED_S;

/// The warning for a `t_s` column that goes back in time along the rows (rows sorted by
/// something else, or sessions with clocks of their own joined), naming the largest step
/// back; for dates ([`DATED_S`]) only when more than 1 % of the steps go back.
/// `diagnose`'s drift check reads the rows' order as time, and `base-drift` reads `t_s` as one
/// clock: either is misled.
fn clock_back<const N: usize>(ds: &Dataset<N>, origin: &str) -> Option<String> {
    let k = ds
        .extra_names
        .iter()
        .position(|n| n == crate::formats::measurements::TIME_COLUMN)?;
    let times: Vec<(u32, f64)> = ds
        .records
        .iter()
        .filter_map(|r| r.extra.get(k).map(|t| (r.line, *t)))
        .filter(|(_, t)| t.is_finite())
        .collect();
    let dated = times.iter().any(|(_, t)| t.abs() > DATED_S);
    let backs: Vec<((u32, f64), (u32, f64))> = times
        .windows(2)
        .filter(|w| w[1].1 < w[0].1 - CLOCK_JITTER_S)
        .map(|w| (w[0], w[1]))
        .collect();
    // Dates are one clock for every session: a few rows out of order (the real series A
    // appends ten of earlier days) mislead nothing; rows sorted by something else still
    // mislead the drift check.
    if dated && backs.len() * 100 <= times.len() {
        return None;
    }
    let ((_, from), (line, to)) = *backs
        .iter()
        .max_by(|a, b| (a.0 .1 - a.1 .1).total_cmp(&(b.0 .1 - b.1 .1)))?;
    Some(format!(
        "warning: {origin}: t_s goes back in time {} time{} along the rows (the largest step \
         from {from} s to {to} s, line {line}): rows sorted by something else, or sessions \
         with clocks of their own joined; diagnose's drift check reads the rows' order as time \
         and base-drift reads t_s as one clock: sort the rows by time, or give each session a \
         file of its own",
        backs.len(),
        if backs.len() == 1 { "" } else { "s" }
    ))
}

/// Measurements without the rows whose tracker reading did not update ([`stale`]), the
/// warning that names them told on stderr.
fn without_stale<const N: usize, V: kinecal::ValueStorage>(
    ds: Dataset<N>,
    nominal: &Robot<f64, N, V>,
    origin: &str,
) -> Dataset<N> {
    let (ds, warning) = stale::leave_out(ds, nominal, origin);
    if let Some(w) = warning {
        crate::Tell::line(&mut crate::Stderr, &w);
    }
    ds
}

/// A measurement file (`check`, `identify`, `diagnose`) in mm and degrees; see [`load_as`].
pub fn load_measurements<const N: usize, V: kinecal::ValueStorage>(
    path: &Path,
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
) -> anyhow::Result<Dataset<N>> {
    load_as(path, units, nominal, base_known, FileKind::Measurements)
}

/// A sweep file (`frames`: the base is always unknown there) in mm and degrees.
pub fn load_sweeps<const N: usize, V: kinecal::ValueStorage>(
    path: &Path,
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
) -> anyhow::Result<Dataset<N>> {
    load_as(path, units, nominal, false, FileKind::Sweeps)
}

/// A target file (`compensate`) in mm and degrees: the seeds must bring `model` (its base, or
/// the identity when it has none: targets in the robot base frame) near the targets.
pub fn load_targets<const N: usize, V: kinecal::ValueStorage>(
    path: &Path,
    units: &UnitArgs,
    model: &Robot<f64, N, V>,
) -> anyhow::Result<Dataset<N>> {
    load_as(path, units, model, true, FileKind::Targets)
}

/// Refuses (exit 2) a measurement file whose stated base misplaces it: run before the units
/// door on the values as written, read in the units assumed (`units`), since a base metres
/// off would otherwise look like a unit mistake (points beyond the arm's reach).
fn placement<const N: usize, V: kinecal::ValueStorage>(
    raw: &Dataset<N>,
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    origin: &str,
) -> anyhow::Result<()> {
    let mut assumed = raw.clone();
    convert(&mut assumed, units);
    if let Some(p) = crate::formats::placement::check(&assumed, nominal) {
        crate::refuse!("{}", p.message(origin));
    }
    Ok(())
}

/// Refuses (exit 2) a measurement file (in mm and degrees) whose angles compose in another
/// order than the one assumed. `stated`: the file's angles as
/// written (degrees), the order the map gives them and the map file, for a file read with
/// `--map`; without, the angles are the file's `rx_deg`, `ry_deg`, `rz_deg` in kinecal's order.
fn convention<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    stated: Option<(&[[f64; 3]], RotationOrder, &Path)>,
    nominal: &Robot<f64, N, V>,
    origin: &str,
) -> anyhow::Result<()> {
    let (angles, assumed, map) = match stated {
        Some((a, o, m)) => (a.to_vec(), o, Some(m)),
        None => {
            let names = match ds.extra("rx_deg") {
                Some(_) => ["rx_deg", "ry_deg", "rz_deg"],
                None => ["rx", "ry", "rz"],
            };
            let cols = names.map(|c| ds.extra(c));
            match cols {
                [Some(x), Some(y), Some(z)] => (
                    (0..ds.len()).map(|i| [x[i], y[i], z[i]]).collect(),
                    RotationOrder::KINECAL,
                    None,
                ),
                _ => (Vec::new(), RotationOrder::KINECAL, None),
            }
        }
    };
    // Only files with orientations have an angle order to check.
    if !angles.is_empty() && angles.len() == ds.len() {
        let q: Vec<[f64; N]> = ds.records.iter().map(|r| r.q_deg).collect();
        if let Some(m) = crate::formats::convention::check(&q, &angles, assumed, nominal) {
            crate::refuse!("{}", m.message(origin, map));
        }
    }
    Ok(())
}
