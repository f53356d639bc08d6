//! Why targets were not reached, when they look given in another frame than the model's.
//!
//! A model with a `[base]` takes targets in the measurement frame (the tracker's); targets in
//! the robot base frame (as a controller lists them) lie metres from where the arm can reach,
//! and every row comes back `unreachable`. The seed of each row says where the arm is meant to
//! be: if the unreached targets lie far from the model's tool at their seeds, but near it once
//! the model's `[base]` places them, they were given in the robot base frame.

use super::Row;
use crate::calibration::stats::quantile;
use crate::formats::measurements::Dataset;
use crate::output::numfmt::sig;
use kinecal::{ForwardKinematics, Robot};

/// Below this median distance (mm) between the unreached targets and the model's tool at
/// their seeds the seeds belong to the targets: nothing to say about frames.
pub const NEAR_SEED_MM: f64 = 50.0;

/// The hint for the rows `rows` of which `unreached` were not reached by `robot` (a model
/// whose file has a `[base]` when `base_known`), or `None` when the unreached targets lie
/// near their seeds or are fewer than half the rows (a frame is a whole file's: a few targets
/// out of reach are just out of reach).
pub(super) fn frame_hint<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    rows: &[Row],
    unreached: &[bool],
    base_known: bool,
) -> Option<String> {
    if 2 * unreached.iter().filter(|u| **u).count() < rows.len() {
        return None;
    }
    let mut fk = ForwardKinematics::<f64, N>::new();
    let base = robot.base();
    let (mut as_given, mut placed) = (Vec::new(), Vec::new());
    for (row, _) in rows.iter().zip(unreached).filter(|(_, u)| **u) {
        let Ok(seed) = <[f64; N]>::try_from(row.seed.as_slice()) else {
            continue;
        };
        let at_seed = fk.compute(robot, &seed);
        as_given.push((at_seed - row.point).norm());
        placed.push((at_seed - base.point(&row.point)).norm());
    }
    let far = quantile(&as_given, 0.5);
    if as_given.is_empty() || far.is_nan() || far < NEAR_SEED_MM {
        return None;
    }
    let count = as_given.len();
    let near = quantile(&placed, 0.5);
    Some(if base_known && near < 0.25 * far {
        format!(
            "hint: the {count} unreached targets lie a median {} mm from the model's tool at \
             their seeds, {} mm once the model's [base] places them: they look given in the \
             robot base frame; give them in the measurement frame of the [base]",
            sig(far, 3),
            sig(near, 3)
        )
    } else {
        format!(
            "hint: the {count} unreached targets lie a median {} mm from the model's tool at \
             their seeds: check that they are in the {} and that the seeds are the arm's \
             joints for them",
            sig(far, 3),
            if base_known {
                "measurement frame of the model's [base]"
            } else {
                "robot base frame (the model has no [base])"
            }
        )
    })
}

/// The hint for targets of `targets` (mm, degrees) that were not reached (`unreached`) as
/// points of the reflector `names[chosen]` of `model` (all its reflectors) when they lie near
/// another reflector at their seeds: "give --tool NAME". `None` with one reflector, or when
/// no other reflector is four times nearer and within [`NEAR_SEED_MM`].
pub fn other_reflector<const N: usize, V: kinecal::ValueStorage>(
    model: &Robot<f64, N, V>,
    names: &[String],
    chosen: usize,
    targets: &Dataset<N>,
    unreached: &[bool],
) -> Option<String> {
    if names.len() < 2 || names.len() != model.tool_point_count() {
        return None;
    }
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut distances = vec![Vec::new(); names.len()];
    for (r, _) in targets.records.iter().zip(unreached).filter(|(_, u)| **u) {
        let q = r.q_deg.map(f64::to_radians);
        let target = nalgebra::Vector3::from(r.xyz_mm);
        for (k, d) in distances.iter_mut().enumerate() {
            if let Some(p) = fk.compute_point(model, &q, k) {
                d.push((p - target).norm());
            }
        }
    }
    let median: Vec<f64> = distances.iter().map(|d| quantile(d, 0.5)).collect();
    let own = *median.get(chosen)?;
    let (best, near) = median
        .iter()
        .enumerate()
        .filter(|(k, m)| *k != chosen && m.is_finite())
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    (*near < NEAR_SEED_MM && *near < 0.25 * own).then(|| {
        format!(
            "hint: the {} unreached targets lie a median {} mm from reflector {:?} at their seeds \
             ({} mm from {:?}): they look like {:?}'s points; give --tool {}",
            distances[chosen].len(),
            sig(*near, 3),
            names[best],
            sig(own, 3),
            names[chosen],
            names[best],
            names[best]
        )
    })
}
