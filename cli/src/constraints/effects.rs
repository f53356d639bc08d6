//! Effects on a constraint session: `--effect` requests added to a model over the rows'
//! joint ranges and temperatures (what `identify` and `diagnose` on a constraint file add).

use super::read::Group;
use crate::calibration::add_effect;
use crate::HostRobot;
use kinecal::Param;

/// The `--effect` requests added to `nominal` with zero values, each table or cyclic term over
/// the joint range of the identification rows; returns the parameters that are not effect
/// values (an axis tilt's). Thermal expansion needs a `temp_c` on every row (its reference is
/// the rows' mean temperature unless given).
pub fn add_effects<const N: usize>(
    nominal: &mut HostRobot<N>,
    requests: &[crate::calibration::EffectRequest],
    ident: &[Group<N>],
) -> anyhow::Result<Vec<Param>> {
    let rows = measurements(ident);
    let mut extra = Vec::new();
    for req in requests {
        if req.kind == crate::calibration::drift::DRIFT {
            crate::refuse!(
                "--effect base-drift: a constraint session has no tracker to drift (the arm \
                 measures its own sockets, planes and lengths): leave it out"
            );
        }
        if req.kind == crate::formats::robot_file::THERMAL {
            if rows.iter().all(|m| m.temp_c.is_none()) {
                crate::refuse!(
                    "--effect {}: the constraint file has no temp_c column: add the arm's \
                     temperature (°C) to every row",
                    req.kind
                );
            }
            extra.extend(crate::calibration::thermal::add(nominal, req, &rows)?);
            continue;
        }
        let range = if req.joint < N {
            crate::calibration::inputs::joint_range(&rows, req.joint)
        } else {
            (0.0, 0.0)
        };
        extra.extend(add_effect(nominal, req, range)?);
    }
    extra.retain(|p| !matches!(p, Param::Effect(_)));
    Ok(extra)
}

/// The rows as measurements (joint readings and temperatures) for the acceptance check's joint
/// ranges and the thermal-expansion term's reference.
pub fn measurements<const N: usize>(groups: &[Group<N>]) -> Vec<kinecal::Measurement<f64, N>> {
    groups
        .iter()
        .flat_map(|g| g.rows.iter())
        .map(|r| {
            let mut m = kinecal::Measurement::from_deg(&r.q.map(f64::to_degrees), &[0.0; 3]);
            m.temp_c = r.temp_c;
            // No time: base-drift is refused on constraint sessions (no tracker to drift).
            m
        })
        .collect()
}
