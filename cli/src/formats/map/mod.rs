//! Files in other layouts (`--map M.toml`, docs/formats.md "Files in other layouts"): a
//! vendor's measurement, sweep or target file read as it is, turned in memory into the very
//! records kinecal's own layout of the same data gives.
//!
//! The map file is read by [`spec`], the file's lines, delimiter and decimal separator by
//! [`layout`], and [`translate`] writes the file in kinecal's layout, which the measurement
//! reader then reads like any converted file: same checks, same records.

pub mod layout;
pub mod spec;
pub mod translate;

use crate::formats::measurements::{self, Dataset};
use crate::formats::rotation_order::RotationOrder;
use crate::formats::units::{FileKind, UnitArgs};
use kinecal::io::csv::CsvError;
use std::path::Path;

/// A file read through a map.
pub struct Mapped<const N: usize> {
    /// The records, as the converted file would give them before the units door.
    pub dataset: Dataset<N>,
    /// The units the door applies: the map's `joints` and `length` as if given with
    /// `--angle-unit` and `--length-unit` (never second-guessed), otherwise the flags.
    pub units: UnitArgs,
    /// Each record's measured orientation as the file states it (degrees about x, y, z,
    /// before `rotation` is applied); empty without one.
    pub raw_angles: Vec<[f64; 3]>,
    /// The order the map says the file's angles compose in.
    pub rotation: RotationOrder,
}

/// The units in force: the map's, or the flags' where the map says nothing; a flag that
/// contradicts the map is refused (exit 2).
fn units(map: &spec::MapFile, flags: &UnitArgs, map_origin: &str) -> anyhow::Result<UnitArgs> {
    if let (Some(m), Some(f)) = (map.units.joints, flags.angle_unit) {
        if m != f {
            crate::refuse!(
                "--angle-unit {} contradicts {map_origin}'s [units] joints = \"{}\": drop the flag or correct the map",
                f.flag(),
                m.flag()
            );
        }
    }
    if let (Some(m), Some(f)) = (map.units.length, flags.length_unit) {
        if m != f {
            crate::refuse!(
                "--length-unit {} contradicts {map_origin}'s [units] length = \"{}\": drop the flag or correct the map",
                f.flag(),
                m.flag()
            );
        }
    }
    Ok(UnitArgs {
        length_unit: map.units.length.or(flags.length_unit),
        angle_unit: map.units.joints.or(flags.angle_unit),
        map: flags.map.clone(),
    })
}

/// How a target file read through a map writes orientations: the order of its three angles
/// and their unit (what `compensate --cartesian` writes back in).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetAngles {
    pub rotation: RotationOrder,
    pub unit: crate::formats::units::AngleUnit,
}

/// The units in force for a file read with `flags`: with `--map`, the map's where it states
/// them (a contradicting flag is refused, exit 2), and how its target orientations are
/// written; without, the flags and `None`.
pub fn in_force(flags: &UnitArgs) -> anyhow::Result<(UnitArgs, Option<TargetAngles>)> {
    let Some(path) = &flags.map else {
        return Ok((flags.clone(), None));
    };
    let map = spec::MapFile::load(path)?;
    let units = units(&map, flags, &path.display().to_string())?;
    let angles = TargetAngles {
        rotation: map.rotation,
        unit: map
            .units
            .orientation
            .unwrap_or(crate::formats::units::AngleUnit::Deg),
    };
    Ok((units, Some(angles)))
}

/// Reads the file at `data` (a file of `kind`) for an `N`-joint robot through the map at
/// `map_path` (the data
/// file's units not converted yet: see [`Mapped::units`]). Malformed input is refused (exit
/// 2) with a one-line reason naming the file, line and column.
pub fn load<const N: usize>(
    data: &Path,
    map_path: &Path,
    flags: &UnitArgs,
    kind: FileKind,
) -> anyhow::Result<Mapped<N>> {
    let map = spec::MapFile::load(map_path)?;
    let (origin, map_origin) = (data.display().to_string(), map_path.display().to_string());
    let units = units(&map, flags, &map_origin)?;
    let mut bytes = std::fs::read(data)
        .map_err(|e| crate::refused(crate::formats::cannot_read(&origin, &e)))?;
    if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
        bytes.drain(..3);
    }
    let text = String::from_utf8(bytes)
        .map_err(|_| crate::refused(format!("{origin}: not UTF-8 text: not a measurement file")))?;
    let lines = layout::content_lines(&text);
    // A target file's orientation is written in the joints' unit in force, the flag's where
    // the map states none (compensate reads it so).
    let map = spec::MapFile {
        units: spec::MapUnits {
            joints: units.angle_unit,
            ..map.units.clone()
        },
        ..map
    };
    let t = translate::translate(&map, &lines, (N, kind), (&origin, &map_origin))?;
    let shift = t.line_shift;
    let mut dataset = measurements::read_bytes::<N>(t.text.as_bytes()).map_err(|e| {
        let line = e.line.saturating_sub(shift);
        let column = t
            .columns
            .get((e.column as usize).wrapping_sub(1))
            .map_or(e.column, |c| c.file_column() as u16);
        // The file's columns, each under the kinecal name it is read as.
        let width = t.columns.iter().map(|c| c.file_column()).max().unwrap_or(0);
        let mut header = vec![String::new(); width];
        for c in &t.columns {
            header[c.file_column() - 1] = c.name.clone();
        }
        let msg = measurements::describe_error(
            &origin,
            &CsvError { line, column, ..e },
            N,
            Some(&header),
            None,
        );
        crate::refused(format!("{msg} (read with --map {map_origin})"))
    })?;
    for r in &mut dataset.records {
        r.line = r.line.saturating_sub(shift);
    }
    Ok(Mapped {
        dataset,
        units,
        raw_angles: t.raw_angles,
        rotation: map.rotation,
    })
}
