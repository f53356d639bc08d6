//! The size of a fitted arm against the robot file's: no arm's links change length by a fifth,
//! so a fit that stretched or shrank them that far was fitted to points in another length unit
//! than the one stated (metres read as millimetres "calibrate" a UR10 to 0.0005 mm, its links
//! a thousandth as long) or to another robot's data. `identify` and `diagnose` report such a
//! fit as no calibration (exit 3) instead of reporting its tiny error as one; the unit stated
//! is not replaced (a unit given is never second-guessed).

use crate::output::numfmt::sig;
use kinecal::Robot;

/// The largest relative change of the links' summed lengths that a calibration can make.
pub const MOST_CHANGE: f64 = 0.2;

/// Σ (|a| + |d|) over the joints' rows (mm): the arm's size without base and tool.
pub fn link_lengths<const N: usize, V: kinecal::ValueStorage>(robot: &Robot<f64, N, V>) -> f64 {
    robot.joints().iter().map(|j| j.a.abs() + j.d.abs()).sum()
}

/// Why `fitted` cannot be a calibration of `nominal`, or `None`: the reason, as the rest of a
/// sentence that starts "the fit".
pub fn resized<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
) -> Option<String> {
    let (was, is) = (link_lengths(nominal), link_lengths(fitted));
    let ratio = is / was;
    if was <= 0.0 || !is.is_finite() || (ratio - 1.0).abs() <= MOST_CHANGE {
        return None;
    }
    Some(format!(
        "made the arm's links {} times as long as the robot file says (Σ|a|+|d| {} → {} mm): no \
         arm changes size, so the points are in another length unit than the one stated (give \
         --length-unit, or length in the --map file) or the robot file describes another robot",
        sig(ratio, 2),
        sig(was, 4),
        sig(is, 4)
    ))
}
