//! Seeds beyond the joint limits: moved onto them, and a command that is then a jump from the
//! controller's reading marked `limited`.

use super::Row;
use crate::formats::measurements::Dataset;
use crate::formats::origin::Origin;
use crate::HostRobot;
use kinecal::compensate::{Solution, Status};

/// Marks `limited` every row whose command lies more than `max_step` (rad) from its seed as the
/// file gave it (a seed beyond a joint limit, moved onto it by [`onto_limits`]): from the
/// controller's reading that command is a jump, which `ok` must never be.
pub(super) fn no_jumps<const N: usize>(
    mut results: Vec<(Status, Option<Solution<f64, N>>)>,
    rows: &[Row],
    max_step: f64,
) -> Vec<(Status, Option<Solution<f64, N>>)> {
    for ((status, sol), row) in results.iter_mut().zip(rows) {
        let (Some(reading), Some(sol)) = (&row.reading, sol) else {
            continue;
        };
        let jump = sol
            .q
            .iter()
            .zip(reading)
            .any(|(q, r)| (q - r).abs() > max_step * (1.0 + 1e-9));
        if jump && *status == Status::Ok {
            *status = Status::Limited;
        }
    }
    results
}

/// Moves every seed reading beyond `robot`'s joint limits onto the limit and returns the
/// warning that says so: a controller does not stand beyond its limits, and a command solved
/// from there was written beyond them too (a seed at 175.26° on a ±170° joint gave 173.26°,
/// status `limited`). The commands then stay inside the limits.
pub(super) fn onto_limits<const N: usize>(
    rows: &mut [Row],
    robot: &HostRobot<N>,
    targets: &Dataset<N>,
    origin: &Origin,
) -> Option<String> {
    let mut outside = Vec::new();
    for (row, record) in rows.iter_mut().zip(&targets.records) {
        for (j, joint) in robot.joints().iter().enumerate() {
            let q = row.seed[j];
            let on = q.clamp(joint.lower, joint.upper);
            if on != q {
                outside.push((record.line, j, q, joint));
                row.reading.get_or_insert_with(|| row.seed.clone());
                row.seed[j] = on;
            }
        }
    }
    let &(line, j, q, joint) = outside.first()?;
    let deg = |v: f64| crate::number_text(v.to_degrees());
    Some(format!(
        "warning: {origin}: {} seed reading(s) beyond the model's joint limits (line {line}: \
         q{} = {}° against {}° to {}°): those targets are solved from the limit and their \
         commands stay inside it (status limited where the command lies more than \
         --max-step-deg from the reading); a controller does not stand beyond its limits: check the \
         seeds' convention (a joint's zero, a turn of ±360°)",
        outside.len(),
        j + 1,
        deg(q),
        deg(joint.lower),
        deg(joint.upper)
    ))
}
