//! Cross-validation of a fit on thin data when nothing was held out. A fit's RMS on the poses
//! it was fitted to understates its error on new poses by about `√((m+p)/(m−p))` for `m`
//! equations and `p` parameters (least squares; 5 % at 20 equations per parameter, and without
//! bound as `m` nears `p`): a robot that matches its file exactly, fitted on 40 noisy poses,
//! gives a model that predicts new poses worse than the file. Below
//! [`EQUATIONS_PER_PARAMETER`], `identify` leaves each fold of the poses out in turn
//! ([`crate::calibration::folds`]: repeats of a pose together), places the starting model on
//! the others and fits it there, and compares the left-out poses' RMS of the two
//! ([`crate::calibration::acceptance::judge_cross_validated`]). A left-out observation is
//! not counted where its fold's other poses do not support the model: on an effect value (a
//! joint table's knot) that fewer than [`MIN_SUPPORT`] of them move. A fit there rests on one
//! or two poses (a UR10 pose at q3 = 3° among 1,500, whose 3.6° table interval held one other
//! pose, was predicted 15.6 mm off without it), which the full fit, with that pose, does not.
//! When fewer than half are supported the effects are finer than the data, and nothing is
//! cross-validated (a warning says so).

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
/// many distinct other poses of its fold.
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
    /// Position RMS over the counted left-out observations: the model the fit started from,
    /// placed (base and unknown tool registered) on the other poses of each fold. `None`
    /// when the fit could not be cross-validated ([`Self::not_validated`]).
    pub start_rms_mm: Option<f64>,
    /// The same for the model fitted to the other poses of each fold.
    pub after_rms_mm: Option<f64>,
    /// Left-out observations on an effect value fewer than [`MIN_SUPPORT`] other poses of
    /// their fold move, not counted.
    pub unsupported: usize,
    /// Left-out observations in all.
    pub observations: usize,
    /// Folds whose other poses could not be fitted: too few equations, or the fit did not
    /// converge.
    pub failed_folds: usize,
    /// Wall time of the folds' fits (s).
    pub seconds: f64,
}

/// Why a thin fit was not cross-validated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NotValidated {
    /// A fold's other poses could not be fitted.
    FoldsNotFitted,
    /// Fewer than half the left-out observations are supported: the effects are finer than
    /// the data.
    Unsupported,
}

impl CrossValidated {
    /// Both figures, when the fit could be cross-validated.
    pub fn figures(&self) -> Option<(f64, f64)> {
        Some((self.start_rms_mm?, self.after_rms_mm?))
    }

    /// Why there are no figures.
    pub fn not_validated(&self) -> Option<NotValidated> {
        if self.failed_folds > 0 {
            Some(NotValidated::FoldsNotFitted)
        } else if self.figures().is_none() {
            Some(NotValidated::Unsupported)
        } else {
            None
        }
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

/// How many poses of `per_pose` equations give `params` parameters
/// [`EQUATIONS_PER_PARAMETER`] equations each.
pub fn enough_poses(params: usize, per_pose: f64) -> usize {
    poses_for(EQUATIONS_PER_PARAMETER * params, per_pose)
}

/// How many poses of `per_pose` equations give `equations`.
pub fn poses_for(equations: usize, per_pose: f64) -> usize {
    (equations as f64 / per_pose.max(1.0)).ceil() as usize
}

/// One fold's result: squared errors summed over its counted left-out observations (start,
/// fitted), how many were counted and how many were not supported.
struct Fold {
    start_sq: f64,
    after_sq: f64,
    counted: usize,
    unsupported: usize,
}

/// Cross-validates `parameters` fitted to `data`: `place` puts the starting model on a fold's
/// other observations, `fit` fits the model from there (`None`: it could not, or did not
/// converge). `robot` and `params` are the full fit's: which effect values each observation
/// moves. `None` below 2 distinct poses. The folds are fitted on several threads.
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
    let results = crate::compute::parallel::map_each(&each, |&f| -> Option<Fold> {
        let (test_at, train_at) = folds.split(f);
        let train = subset(data, &train_at);
        let start = place(&train)?;
        let fitted = fit(&start, &train)?;
        // Each effect value's supporters: distinct poses (a pose's repeats and reflectors
        // are one).
        let mut support: Vec<std::collections::BTreeSet<usize>> =
            vec![Default::default(); params.len()];
        for &i in &train_at {
            for &k in &moves[i] {
                support[k].insert(groups[i]);
            }
        }
        let (counted, unsupported): (Vec<usize>, Vec<usize>) = test_at
            .iter()
            .partition(|&&i| moves[i].iter().all(|&k| support[k].len() >= MIN_SUPPORT));
        let counted = subset(data, &counted);
        let square = |robot: &HostRobot<N>| {
            Residuals::of(robot, &[], &counted)
                .validation_rms_mm
                .map_or(0.0, |v| v * v * counted.len() as f64)
        };
        Some(Fold {
            start_sq: square(&start),
            after_sq: square(&fitted),
            counted: counted.len(),
            unsupported: unsupported.len(),
        })
    });
    let seconds = t0.elapsed().as_secs_f64();
    let failed_folds = results.iter().filter(|r| r.is_none()).count();
    let done: Vec<Fold> = results.into_iter().flatten().collect();
    let counted: usize = done.iter().map(|f| f.counted).sum();
    let unsupported: usize = done.iter().map(|f| f.unsupported).sum();
    // Figures from every fold, and from at least half of the left-out observations: fewer
    // say where the data support the model, not how it predicts.
    let figures = (failed_folds == 0 && 2 * counted >= data.len()).then(|| {
        let rms = |sq: f64| (sq / counted as f64).sqrt();
        (
            rms(done.iter().map(|f| f.start_sq).sum()),
            rms(done.iter().map(|f| f.after_sq).sum()),
        )
    });
    Some(CrossValidated {
        folds: folds.k,
        equations: equations(data),
        parameters,
        start_rms_mm: figures.map(|f| f.0),
        after_rms_mm: figures.map(|f| f.1),
        unsupported,
        observations: data.len(),
        failed_folds,
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
