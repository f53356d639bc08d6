//! A fit that held the geometry (`identify --only base,tool`, `--fix geometry`) on a
//! robot file whose geometry no longer describes the arm: a model of another robot of the same
//! type, or of this one before it changed. The parameters estimated register the model onto the
//! session, the fit converges, and its held-out poses are "predicted better than by the starting
//! model", which is as wrong: a UR10 model of robot B re-fitted with `--only base,tool` on a
//! session of robot A predicted the held-out poses to 4.19 mm at 0.02 mm noise, where the
//! nominal robot leaves 2.02 mm (exit 0 before). Judged as `validate` judges a model
//! ([`super::recalibration`]): the session's poses are left out fold by fold and predicted by
//! the file's model with the estimated parameters fitted on the others, and by the whole
//! geometry calibrated again on them; when the first leaves
//! [`super::recalibration::CHANGED_RATIO`] times the second and
//! [`super::recalibration::CHANGED_MIN_MM`] more (`Recalibration::geometry_changed`), the fit is
//! no calibration (exit 3). Left-out poses, so a few
//! poses (a re-mastering from 10 planned poses) cannot calibrate the whole geometry well
//! enough to refuse anything.

use super::recalibration::recalibrate_geometry;
use crate::HostRobot;
use kinecal::{Measurement, Param};

/// Whether `params` leave some of the joint rows' geometry (`alpha`, `a`, `theta`, `d`) held.
pub fn holds_geometry<const N: usize>(params: &[Param]) -> bool {
    (0..N as u8).any(|j| {
        [Param::Alpha(j), Param::A(j), Param::Theta(j), Param::D(j)]
            .iter()
            .any(|p| !params.contains(p))
    })
}

/// The reason a fit of `params` to `data`, which held some of the geometry of `fitted`, is no
/// calibration, or `None` (see the module).
pub fn reason<const N: usize>(
    fitted: &HostRobot<N>,
    params: &[Param],
    data: &[Measurement<f64, N>],
) -> Option<String> {
    if !holds_geometry::<N>(params) || data.is_empty() {
        return None;
    }
    // At most as many observations as base_moved refits on, evenly spaced.
    let sample = super::every_kth(data, super::base_moved::SAMPLE);
    let r = recalibrate_geometry(fitted, params, &sample)?;
    let (m, g) = (r.model_rms_mm, r.recalibrated_rms_mm);
    r.geometry_changed().then(|| {
        use crate::output::numfmt::sig;
        format!(
            "held the robot file's geometry, which no longer describes this arm: left out fold \
             by fold ({} folds), the session's poses are predicted to {} mm by it with the \
             estimated parameters refitted, and to {} mm by the geometry calibrated again (the \
             robot changed since that model's calibration, or the file is another robot's); \
             calibrate the geometry too (add geometry to --only, or leave it out of --fix)",
            r.folds,
            sig(m, 3),
            sig(g, 3)
        )
    })
}
