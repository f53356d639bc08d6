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
/// Compared in the nominal flange frame ([`flange_points`]), for stated points at least
/// [`TOOL_SIGN_MM`] from every other (`d` = the distance to the nearest other):
/// - every fitted point within [`TOOL_SLIP_MARGIN`]·`d` of a stated point, those stated points
///   all different and not each its own: the labels are exchanged (two reflectors swapped, or
///   three in a cycle);
/// - two points fitted within [`TOOL_SLIP_MARGIN`]·`d` of each other: one reflector is logged
///   under both names.
///
/// A probe mounted a few millimetres from where the file states it moves every point alike, so
/// no point takes another's place: one point may come near another's stated point, but the
/// labels are read as exchanged only when the points as a whole are a reordering of the stated
/// ones.
pub fn mixed_up<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
    names: &[String],
) -> Option<String> {
    let points = flange_points(nominal, fitted);
    let n = points.len();
    if n < 2 || names.len() != n {
        return None;
    }
    if points
        .iter()
        .any(|(a, b)| !(a.norm().is_finite() && b.norm().is_finite()))
    {
        return None;
    }
    let stated = |k: usize| points[k].0;
    let found = |k: usize| points[k].1;
    // Each stated point's distance to the nearest other: the scale of a mix-up.
    let spacing: Vec<f64> = (0..n)
        .map(|k| {
            (0..n)
                .filter(|&j| j != k)
                .map(|j| (stated(k) - stated(j)).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    if spacing.iter().any(|d| *d < TOOL_SIGN_MM) {
        return None;
    }
    let nearest: Vec<Option<usize>> = (0..n)
        .map(|k| {
            (0..n)
                .min_by(|&a, &b| {
                    (found(k) - stated(a))
                        .norm()
                        .total_cmp(&(found(k) - stated(b)).norm())
                })
                .filter(|&j| (found(k) - stated(j)).norm() <= TOOL_SLIP_MARGIN * spacing[j])
        })
        .collect();
    let taken: Option<Vec<usize>> = nearest.iter().copied().collect();
    if let Some(taken) = taken {
        let mut sorted = taken.clone();
        sorted.sort_unstable();
        sorted.dedup();
        let moved: Vec<usize> = (0..n).filter(|&k| taken[k] != k).collect();
        if sorted.len() == n && !moved.is_empty() {
            let pairs: Vec<String> = moved
                .iter()
                .map(|&k| {
                    format!(
                        "{:?} at {} mm, the robot file's {:?}",
                        names[k],
                        point_text(&found(k)),
                        names[taken[k]]
                    )
                })
                .collect();
            return Some(format!(
                "put each reflector at another's stated point in the flange frame ({}): the \
                 data's labels of the reflectors are exchanged; check which reflector each \
                 column set measured, and name the columns as the robot file's [[tools]] do",
                pairs.join("; ")
            ));
        }
    }
    (0..n)
        .flat_map(|k| (k + 1..n).map(move |j| (k, j)))
        .find(|&(k, j)| {
            (found(k) - found(j)).norm() <= TOOL_SLIP_MARGIN * spacing[k].min(spacing[j])
        })
        .map(|(k, j)| {
            format!(
                "put reflectors {:?} and {:?} at one point, {} mm in the flange frame, where \
                 the robot file states them {} mm apart: one reflector is logged under both \
                 names; check which reflector each column set measured",
                names[k],
                names[j],
                point_text(&found(k)),
                crate::output::numfmt::sig((stated(k) - stated(j)).norm(), 3),
            )
        })
}
