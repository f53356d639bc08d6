//! Why targets were not reached, when they look given in another frame than the model's.
//!
//! A model with a `[base]` takes targets in the measurement frame (the tracker's); targets in
//! the robot base frame (as a controller lists them) lie metres from where the arm can reach,
//! and every row comes back `unreachable`. The seed of each row says where the arm is meant to
//! be: if the unreached targets lie far from the model's tool at their seeds, but near it once
//! the model's `[base]` places them, they were given in the robot base frame.

use super::Row;
use crate::calibration::stats::quantile;
use crate::output::numfmt::sig;
use kinecal::{ForwardKinematics, Robot};

/// Below this median distance (mm) between the unreached targets and the model's tool at
/// their seeds the seeds belong to the targets: nothing to say about frames.
pub const NEAR_SEED_MM: f64 = 50.0;

/// The hint for the rows `rows` of which `unreached` were not reached by `robot` (a model
/// whose file has a `[base]` when `base_known`), or `None` when the unreached targets lie
/// near their seeds.
pub(super) fn frame_hint<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    rows: &[Row],
    unreached: &[bool],
    base_known: bool,
) -> Option<String> {
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
