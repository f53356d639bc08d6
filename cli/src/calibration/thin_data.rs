//! Cross-validation of a fit on thin data when nothing was held out. A fit's RMS on the poses
//! it was fitted to understates its error on new poses by about `√((m+p)/(m−p))` for `m`
//! equations and `p` parameters (least squares; 5 % at 20 equations per parameter, and without
//! bound as `m` nears `p`): 10 poses of a 6-joint arm (30 equations, 29 parameters) fit to
//! 0.23 mm yet predict the other poses of the session worse than the nominal robot. Below
//! [`EQUATIONS_PER_PARAMETER`], `identify` leaves each fold of the poses out in turn, fits
//! the others exactly as it fitted all of them, and compares the left-out poses' RMS with
//! that of the model it started from placed on the same others
//! ([`crate::calibration::acceptance`] then judges it as it judges held-out poses).

use crate::calibration::Residuals;
use crate::HostRobot;
use kinecal::Measurement;
use serde::Serialize;

/// Below this many equations (three per position) per estimated parameter a fit that holds
/// nothing out is cross-validated: its identification RMS understates the error on new poses
/// by more than 5 % there.
pub const EQUATIONS_PER_PARAMETER: usize = 20;

/// At most this many folds (leave-one-out below it).
pub const MAX_FOLDS: usize = 10;

/// The cross-validated figures of a fit on thin data.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrossValidated {
    /// How many folds the poses were left out in (each pose once).
    pub folds: usize,
    /// Position RMS over the left-out poses: the model the fit started from, placed (base and
    /// unknown tool registered) on the other poses of each fold. `None` when a fold's other
    /// poses are too few to fit (or to place) the model: too thin to cross-validate.
    pub start_rms_mm: Option<f64>,
    /// The same for the model fitted to the other poses of each fold.
    pub after_rms_mm: Option<f64>,
}

impl CrossValidated {
    /// Both figures, when every fold could be fitted.
    pub fn figures(&self) -> Option<(f64, f64)> {
        Some((self.start_rms_mm?, self.after_rms_mm?))
    }
}

/// Whether a fit of `params` parameters to `poses` poses is thin enough to cross-validate.
pub fn thin(poses: usize, params: usize) -> bool {
    3 * poses < EQUATIONS_PER_PARAMETER * params
}

/// How many poses give `params` parameters [`EQUATIONS_PER_PARAMETER`] equations each.
pub fn enough_poses(params: usize) -> usize {
    (EQUATIONS_PER_PARAMETER * params).div_ceil(3)
}

/// Cross-validates on `data` (observations, `pose_of` each one's pose): pose `k` is left out in
/// fold `k mod folds`; `place` puts the starting model on a fold's other observations and
/// `fit` fits the model to them. The figures are `None` when a fold's placement or fit fails
/// (too few poses left); `None` altogether below 2 poses.
pub fn cross_validate<const N: usize>(
    data: &[Measurement<f64, N>],
    pose_of: &[usize],
    place: impl Fn(&[Measurement<f64, N>]) -> Option<HostRobot<N>>,
    fit: impl Fn(&[Measurement<f64, N>]) -> Option<HostRobot<N>>,
) -> Option<CrossValidated> {
    let poses = pose_of.iter().max().map_or(0, |p| p + 1);
    let folds = poses.min(MAX_FOLDS);
    if folds < 2 || pose_of.len() != data.len() {
        return None;
    }
    let sums = || {
        let (mut start_sq, mut after_sq, mut count) = (0.0, 0.0, 0usize);
        for fold in 0..folds {
            let (mut train, mut test) = (Vec::new(), Vec::new());
            for (m, p) in data.iter().zip(pose_of) {
                if p % folds == fold {
                    test.push(*m);
                } else {
                    train.push(*m);
                }
            }
            let start = place(&train)?;
            let fitted = fit(&train)?;
            let square = |r: Residuals| r.validation_rms_mm.map(|v| v * v * test.len() as f64);
            start_sq += square(Residuals::of(&start, &train, &test))?;
            after_sq += square(Residuals::of(&fitted, &train, &test))?;
            count += test.len();
        }
        let rms = |sq: f64| (sq / count.max(1) as f64).sqrt();
        Some((rms(start_sq), rms(after_sq)))
    };
    let figures = sums();
    Some(CrossValidated {
        folds,
        start_rms_mm: figures.map(|f| f.0),
        after_rms_mm: figures.map(|f| f.1),
    })
}
