//! Units given explicitly as kinecal's own (mm, degrees) that a file evidently is not in: the
//! plausibility check of [`super::units`] never second-guesses a unit given, so the file is
//! read as stated; but every reason that follows would blame the robot file or the axes, so the
//! units the file looks like are said in a warning.

use super::measurements::Record;
use super::units::{suspect, AngleUnit, FileKind, LengthUnit, UnitArgs};
use kinecal::Robot;

/// The warning for units given explicitly as kinecal's own (mm, degrees) that the file
/// evidently is not in: never second-guessed into a refusal, but said, since every reason
/// that follows (the robot file, the axes) would blame something else. (Stated radians or
/// metres are not questioned: the other direction is the plausibility check's.)
pub fn stated_otherwise<const N: usize, V: kinecal::ValueStorage>(
    records: &[Record<N>],
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    origin: &str,
    kind: FileKind,
) -> Option<String> {
    let default_stated = matches!(units.length_unit, None | Some(LengthUnit::Mm))
        && matches!(units.angle_unit, None | Some(AngleUnit::Deg))
        && (units.length_unit.is_some() || units.angle_unit.is_some());
    if !default_stated {
        return None;
    }
    let open = UnitArgs {
        length_unit: None,
        angle_unit: None,
        map: None,
    };
    let s = suspect(records, &open, nominal, base_known)?;
    // Only what was stated: a free unit was judged above.
    let contradicts = (s.length.is_some() && units.length_unit.is_some())
        || (s.angle.is_some() && units.angle_unit.is_some());
    contradicts.then(|| {
        let m = s.message(origin, kind);
        // "ORIGIN: WHAT (EVIDENCE)" without the flags to pass: the stated units are kept.
        let said = m.find("): pass ").map_or(m.as_str(), |k| &m[..=k]);
        let mut how = Vec::new();
        if s.length.is_some() {
            how.push("--length-unit m (a map's length = \"m\")");
        }
        if s.angle.is_some() {
            how.push("--angle-unit rad (a map's joints = \"rad\")");
        }
        format!(
            "warning: {said}, although the units given say otherwise: they are kept; if the \
             file is in those units, give {}",
            how.join(" and ")
        )
    })
}
