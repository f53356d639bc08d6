//! Reflectors whose labels in the data are not the robot file's: two reflectors' columns
//! exchanged (`x_B…` holding reflector C's points), or one reflector logged under two names.
//! Each tool point is fitted freely, so a fit meets such data exactly (the simulated swap of B
//! and C fits to 0.033 mm) and writes a model with the names on the wrong points; only where
//! the points settle tells the mistake. `identify` and `diagnose` report it as no calibration
//! (exit 3), naming the columns to check.

use super::arm_size::{flange_points, point_text, TOOL_SIGN_MM, TOOL_SLIP_MARGIN};
use kinecal::Robot;

/// Why the fitted tool points of `fitted` cannot carry the `[[tools]]` names `names` the robot
/// file gives `nominal`'s points: the rest of a sentence that starts "the fit", or `None`.
/// Compared in the nominal flange frame ([`flange_points`]), and only for stated points at
/// least [`TOOL_SIGN_MM`] apart (`d` = their distance):
/// - a point fitted within [`TOOL_SLIP_MARGIN`]·`d` of another's stated point and further from
///   its own: the two reflectors' columns are exchanged (or one is logged under the other's
///   name);
/// - two points fitted within [`TOOL_SLIP_MARGIN`]·`d` of each other: one reflector is logged
///   under both names.
///
/// A reflector that sits a few millimetres from where the file states it (the real UR10's is
/// 16 mm nearer the flange) moves far less than the distance between two reflectors.
pub fn mixed_up<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
    names: &[String],
) -> Option<String> {
    let points = flange_points(nominal, fitted);
    if points.len() < 2 || names.len() != points.len() {
        return None;
    }
    let finite = |k: usize| points[k].0.norm().is_finite() && points[k].1.norm().is_finite();
    let apart = |k: usize, j: usize| (points[k].0 - points[j].0).norm();
    let pairs = (0..points.len())
        .flat_map(|k| (0..points.len()).map(move |j| (k, j)))
        .filter(|&(k, j)| k != j && finite(k) && finite(j) && apart(k, j) >= TOOL_SIGN_MM);
    for (k, j) in pairs.clone() {
        let (own, found) = points[k];
        let other = points[j].0;
        let d = apart(k, j);
        if (found - other).norm() <= TOOL_SLIP_MARGIN * d
            && (found - other).norm() < (found - own).norm()
        {
            return Some(format!(
                "put reflector {:?}'s point at {} mm in the flange frame, next to the robot \
                 file's {:?} at {} mm and {} mm from its own {}: the data's columns of {:?} \
                 hold {:?}'s points (labels exchanged, or one reflector logged under two \
                 names); check which reflector each column set measured, and name them as \
                 the robot file's [[tools]] do",
                names[k],
                point_text(&found),
                names[j],
                point_text(&other),
                crate::output::numfmt::sig((found - own).norm(), 3),
                point_text(&own),
                names[k],
                names[j],
            ));
        }
    }
    pairs
        .filter(|&(k, j)| k < j)
        .find(|&(k, j)| (points[k].1 - points[j].1).norm() <= TOOL_SLIP_MARGIN * apart(k, j))
        .map(|(k, j)| {
            format!(
                "put reflectors {:?} and {:?} at one point, {} mm in the flange frame, where \
                 the robot file states them {} mm apart: one reflector is logged under both \
                 names; check which reflector each column set measured",
                names[k],
                names[j],
                point_text(&points[k].1),
                crate::output::numfmt::sig(apart(k, j), 3),
            )
        })
}
