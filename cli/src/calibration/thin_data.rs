//! Cross-validation of a fit on thin data when nothing was held out. A fit's RMS on the poses
//! it was fitted to understates its error on new poses by about `√((m+p)/(m−p))` for `m`
//! equations and `p` parameters (least squares; 5 % at 20 equations per parameter, and without
//! bound as `m` nears `p`): a robot that matches its file exactly, fitted on 40 noisy poses,
//! gives a model that predicts new poses worse than the file. Below
//! [`EQUATIONS_PER_PARAMETER`], `identify` leaves each fold of the poses out in turn
//! ([`crate::calibration::folds`]: repeats of a pose together), places the starting model on
//! the others and fits it there, and compares the left-out poses' RMS of the two
//! ([`crate::calibration::acceptance::judge_cross_validated`]). A left-out pose is not
//! counted where its fold's other poses do not support it: outside their joint ranges, or on
//! an effect value (a joint table's knot) that fewer than [`MIN_SUPPORT`] of them move. What a
//! fit does there is extrapolation, which the full fit, covering those poses, does not do (a
//! UR10 pose at q3 = 3° among 1,500, whose 3.6° table interval held only one other pose, was
//! predicted 15.6 mm off without it).

use crate::calibration::folds::{subset, Folds};
use crate::calibration::Residuals;
use crate::HostRobot;
use kinecal::Measurement;
use serde::Serialize;

/// Below this many equations (three per position, three more per orientation) per estimated
/// parameter a fit that holds nothing out is cross-validated: its identification RMS
/// understates the error on new poses by more than 5 % there.
pub const EQUATIONS_PER_PARAMETER: usize = 20;

/// At most this many folds (leave-one-out below it).
pub const MAX_FOLDS: usize = 10;

/// A left-out observation counts when each effect value it moves is moved by at least this
/// many of its fold's other observations.
pub const MIN_SUPPORT: usize = 3;

/// The cross-validated figures of a fit on thin data.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrossValidated {
    /// How many folds the poses were left out in (each pose once).
    pub folds: usize,
    /// Equations of the fit (three per position, three per orientation) and its estimated
    /// parameters.
    pub equations: usize,
    pub parameters: usize,
    /// Position RMS over the left-out poses: the model the fit started from, placed (base and
    /// unknown tool registered) on the other poses of each fold. `None` when a fold's other
    /// poses are too few to fit (or to place) the model: too thin to cross-validate.
    pub start_rms_mm: Option<f64>,
    /// The same for the model fitted to the other poses of each fold.
    pub after_rms_mm: Option<f64>,
    /// Left-out observations their fold's other poses do not support (outside their joint
    /// ranges, or on an effect value fewer than [`MIN_SUPPORT`] of them move), not counted.
    pub outside: usize,
    /// Wall time of the folds' fits (s).
    pub seconds: f64,
}

impl CrossValidated {
    /// Both figures, when every fold could be fitted.
    pub fn figures(&self) -> Option<(f64, f64)> {
        Some((self.start_rms_mm?, self.after_rms_mm?))
    }
}

/// The equations of `data`: three per position, three more per orientation.
pub fn equations<const N: usize>(data: &[Measurement<f64, N>]) -> usize {
    data.iter()
        .map(|m| if m.orientation.is_some() { 6 } else { 3 })
        .sum()
}

/// Whether `equations` for `params` parameters are thin enough to cross-validate.
pub fn thin(equations: usize, params: usize) -> bool {
    equations < EQUATIONS_PER_PARAMETER * params
}

/// How many more observations like the average of `data`'s give `params` parameters
/// [`EQUATIONS_PER_PARAMETER`] equations each: the poses to measure, in all.
pub fn enough_poses(params: usize, per_pose: f64) -> usize {
    ((EQUATIONS_PER_PARAMETER * params) as f64 / per_pose.max(1.0)).ceil() as usize
}

/// Cross-validates `parameters` fitted to `data`: `place` puts the starting model on a fold's
/// other observations, `fit` fits the model from there. The figures are `None` when a fold's
/// placement or fit fails (too few poses left); `None` altogether below 2 distinct poses. The
/// folds are fitted on several threads.
pub fn cross_validate<const N: usize>(
    data: &[Measurement<f64, N>],
    (robot, params): (&HostRobot<N>, &[kinecal::Param]),
    parameters: usize,
    seed: u64,
    place: impl Fn(&[Measurement<f64, N>]) -> Option<HostRobot<N>> + Sync,
    fit: impl Fn(&HostRobot<N>, &[Measurement<f64, N>]) -> Option<HostRobot<N>> + Sync,
) -> Option<CrossValidated> {
    let t0 = std::time::Instant::now();
    let groups = crate::calibration::folds::pose_groups(data);
    let distinct = groups.iter().max().map_or(0, |g| g + 1);
    if distinct < 2 {
        return None;
    }
    let folds = Folds::new(data, distinct.min(MAX_FOLDS), seed);
    let moves = effect_values_moved(robot, params, data);
    let each: Vec<usize> = (0..folds.k).collect();
    // Per fold: the squared errors summed over its counted left-out observations (start,
    // fitted), how many were counted, how many lay outside the fold's ranges.
    let sums = crate::compute::parallel::map_each(&each, |&f| {
        let (test_at, train_at) = folds.split(f);
        let train = subset(data, &train_at);
        let start = place(&train)?;
        let fitted = fit(&start, &train)?;
        let ranges = joint_ranges(&train);
        let mut support = vec![0usize; params.len()];
        for &i in &train_at {
            for &k in &moves[i] {
                support[k] += 1;
            }
        }
        let (inside, outside): (Vec<_>, Vec<_>) = test_at.iter().partition(|&&i| {
            within(&ranges, &data[i]) && moves[i].iter().all(|&k| support[k] >= MIN_SUPPORT)
        });
        let inside = subset(data, &inside);
        let square = |robot: &HostRobot<N>| {
            Residuals::of(robot, &[], &inside)
                .validation_rms_mm
                .map_or(0.0, |v| v * v * inside.len() as f64)
        };
        Some((square(&start), square(&fitted), inside.len(), outside.len()))
    });
    let seconds = t0.elapsed().as_secs_f64();
    let outside = sums.iter().flatten().map(|s| s.3).sum();
    let figures = sums
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .and_then(|sums| {
            let count: usize = sums.iter().map(|s| s.2).sum();
            let rms = |sq: f64| (sq / count as f64).sqrt();
            (count > 0).then(|| {
                (
                    rms(sums.iter().map(|s| s.0).sum()),
                    rms(sums.iter().map(|s| s.1).sum()),
                )
            })
        });
    Some(CrossValidated {
        folds: folds.k,
        equations: equations(data),
        parameters,
        start_rms_mm: figures.map(|f| f.0),
        after_rms_mm: figures.map(|f| f.1),
        outside,
        seconds,
    })
}

/// For each observation of `data`, the indices into `params` of the effect values whose
/// identification Jacobian column is not zero there (at `robot`): a joint table's knots near
/// its readings, every value of a term that acts everywhere.
fn effect_values_moved<const N: usize>(
    robot: &HostRobot<N>,
    params: &[kinecal::Param],
    data: &[Measurement<f64, N>],
) -> Vec<Vec<usize>> {
    let effects: Vec<(usize, kinecal::Param)> = params
        .iter()
        .enumerate()
        .filter(|(_, p)| matches!(p, kinecal::Param::Effect(_)))
        .map(|(k, p)| (k, *p))
        .collect();
    if effects.is_empty() {
        return vec![Vec::new(); data.len()];
    }
    crate::compute::parallel::map_parts(data, |part| {
        let mut fk = kinecal::ForwardKinematics::<f64, N>::new();
        part.iter()
            .map(|m| {
                if fk
                    .compute_at(robot, &m.q, m.tool as usize, m.conditions())
                    .is_none()
                {
                    return Vec::new();
                }
                effects
                    .iter()
                    .filter(|(_, p)| fk.column(robot, *p).is_ok_and(|c| c.norm() > 0.0))
                    .map(|(k, _)| *k)
                    .collect()
            })
            .collect::<Vec<_>>()
    })
    .into_iter()
    .flatten()
    .collect()
}

/// Each joint's range over `data` (rad). No margin: a joint table extrapolates beyond its
/// covered range (160 mm at a UR10's home pose just outside a fold's range).
fn joint_ranges<const N: usize>(data: &[Measurement<f64, N>]) -> [(f64, f64); N] {
    let mut r = [(f64::INFINITY, f64::NEG_INFINITY); N];
    for m in data {
        for (r, q) in r.iter_mut().zip(&m.q) {
            *r = (r.0.min(*q), r.1.max(*q));
        }
    }
    r
}

/// Whether every joint reading of `m` lies within `ranges`.
fn within<const N: usize>(ranges: &[(f64, f64); N], m: &Measurement<f64, N>) -> bool {
    ranges
        .iter()
        .zip(&m.q)
        .all(|((lo, hi), q)| (*lo..=*hi).contains(q))
}
