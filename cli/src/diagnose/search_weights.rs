//! The weights the search reads its observations with: those `identify` settles on
//! ([`crate::calibration::weights`]: the stated σ plus error floors for what the geometry
//! cannot explain), at the geometric fit, rescaled so that a point's residual stays in
//! millimetres.
//!
//! The search ([`super::diagnose`]) screens, cross-validates and tests on every observation's
//! weighted residual (the point's rows and, for a 6-D observation, the orientation's). Its
//! figures are root-mean-square errors per observation: the weights are divided by the median
//! of the points' weights, so that with equal σ a point's residual is its distance in mm and an
//! orientation's is its angle times the ratio of the points' effective uncertainty to the
//! orientations' (mm per rad). Data with neither σ nor orientations keep unit weights: the
//! figures are plain distances, as before.
//!
//! The floors are decided once, at the geometric fit (the evidence the search must weigh is
//! what the geometry leaves), and kept through the search so that the held-out errors of every
//! round compare. The orientation factor `identify` chooses by cross-validation is not applied
//! here (it serves the prediction of positions, not the search); the final fit to all
//! observations ([`super::observations`]) chooses it.

use crate::calibration::weights::{self, weighted_fit, Floors, Stated, Weighting};
use crate::calibration::Fit;
use crate::HostRobot;
use crate::HostValues;
use kinecal::Measurement;

/// How the search's observations were weighted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchWeights {
    /// Error floors at the geometric fit (None: the stated weights alone).
    pub floors: Option<Floors>,
    /// What every weight was divided by (the median point weight).
    pub scale: f64,
}

impl SearchWeights {
    /// Weights `data` (observations with their stated weights, `stated` their σ) as the
    /// search reads them.
    pub fn apply<const N: usize>(&self, data: &mut [Measurement<f64, N>], stated: &[Stated]) {
        if let Some(f) = &self.floors {
            weights::apply(data, stated, f);
        }
        for m in data.iter_mut() {
            m.weight /= self.scale;
            m.orientation_weight /= self.scale;
        }
    }
}

/// The median of the points' mean weights (1 when there are none or it is not positive).
fn median_point_weight<const N: usize>(data: &[Measurement<f64, N>]) -> f64 {
    let mut w: Vec<f64> = data.iter().map(|m| m.weight.mean()).collect();
    if w.is_empty() {
        return 1.0;
    }
    let mid = w.len() / 2;
    let (_, m, _) = w.select_nth_unstable_by(mid, f64::total_cmp);
    if m.is_finite() && *m > 0.0 {
        *m
    } else {
        1.0
    }
}

/// The weights of the search for `data` (`pose_of[i]`: pose of observation `i`): with
/// `balance` (6-D or σ-weighted data, as [`Weighting::of`] decides) the floors of the geometry
/// `fit_geometry` fits, then the median point weight. `data` is left weighted.
pub fn search_weights<const N: usize, F>(
    data: &mut [Measurement<f64, N>],
    pose_of: &[usize],
    stated: &[Stated],
    how: Weighting,
    fit_geometry: F,
) -> anyhow::Result<SearchWeights>
where
    F: Fn(&[Measurement<f64, N>]) -> anyhow::Result<HostRobot<N>>,
{
    let floors = if how.balance {
        let how = Weighting {
            orientation_cv: false,
            ..how
        };
        let run = |d: &[Measurement<f64, N>]| -> anyhow::Result<Fit<N, HostValues>> {
            Ok(Fit::plain(fit_geometry(d)?, 0, 0, Vec::new()))
        };
        weighted_fit(data, pose_of, stated, how, run)?.1.floors
    } else {
        None
    };
    let scale = median_point_weight(data);
    let w = SearchWeights { floors, scale };
    for m in data.iter_mut() {
        m.weight /= scale;
        m.orientation_weight /= scale;
    }
    Ok(w)
}
