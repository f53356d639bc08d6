//! Cross-validation of a fit on thin data when nothing was held out. A fit's RMS on the poses
//! it was fitted to understates its error on new poses by about `√((m+p)/(m−p))` for `m`
//! equations and `p` parameters (least squares; 5 % at 20 equations per parameter, and without
//! bound as `m` nears `p`): a robot that matches its file exactly, fitted on 40 noisy poses,
//! gives a model that predicts new poses worse than the file. Below
//! [`EQUATIONS_PER_PARAMETER`], `identify` leaves each fold of the poses out in turn
//! ([`crate::calibration::folds`]: repeats of a pose together), places the starting model on
//! the others and fits it there, and compares the left-out poses' RMS of the two
//! ([`crate::calibration::acceptance::judge_cross_validated`]).
//!
//! An effect value (a joint table's knot) that fewer than [`MIN_SUPPORT`] distinct poses move
//! is held at its starting value ([`hold_thin_values`]), in the whole fit and in each fold's:
//! fitted, it rests on one or two poses and on their noise (a UR10 pose at q3 = 3° among
//! 1,500, whose 3.6° table interval held one other pose, was predicted 15.6 mm off without
//! it). Every left-out observation is counted, predicted with the values its fold held: the
//! figure is what a new pose there would see.

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

/// An effect value is estimated when at least this many distinct poses move it, else held.
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
    /// Position RMS over the left-out observations: the model the fit started from, placed
    /// (base and unknown tool registered) on the other poses of each fold. `None` when the
    /// fit could not be cross-validated ([`Self::not_validated`]).
    pub start_rms_mm: Option<f64>,
    /// The same for the model fitted to the other poses of each fold.
    pub after_rms_mm: Option<f64>,
    /// Left-out observations on an effect value fewer than [`MIN_SUPPORT`] other poses of
    /// their fold move: predicted with that value held at its start.
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
}

impl CrossValidated {
    /// Both figures, when the fit could be cross-validated.
    pub fn figures(&self) -> Option<(f64, f64)> {
        Some((self.start_rms_mm?, self.after_rms_mm?))
    }

    /// Why there are no figures.
    pub fn not_validated(&self) -> Option<NotValidated> {
        self.figures()
            .is_none()
            .then_some(NotValidated::FoldsNotFitted)
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

/// One fold's result: squared errors summed over its left-out observations (start, fitted),
/// and how many of them move a value the fold held.
struct Fold {
    start_sq: f64,
    after_sq: f64,
    unsupported: usize,
}

/// Removes from `params` the effect values that fewer than [`MIN_SUPPORT`] distinct poses of
/// `data` move (at `robot`), and returns them: they stay at `robot`'s values.
pub fn hold_thin_values<const N: usize>(
    robot: &HostRobot<N>,
    params: &mut Vec<kinecal::Param>,
    data: &[Measurement<f64, N>],
) -> Vec<kinecal::Param> {
    // Without effect values nothing is held (and no per-observation lists are made: 800,000
    // empty ones are 19 MB).
    if !params
        .iter()
        .any(|p| matches!(p, kinecal::Param::Effect(_)))
    {
        return Vec::new();
    }
    let groups = crate::calibration::folds::pose_groups(data);
    let moves = effect_values_moved(robot, params, data);
    let all: Vec<usize> = (0..data.len()).collect();
    let support = support(params.len(), &moves, &groups, &all);
    let (kept, held) = split_by_support(params, &support);
    *params = kept;
    held
}

/// What [`hold_thin_values`] held, for the report: `None` when nothing was. `effect_values`:
/// how many effect values there were to estimate.
pub fn held_note<const N: usize>(
    robot: &HostRobot<N>,
    held: &[kinecal::Param],
    effect_values: usize,
) -> Option<String> {
    if held.is_empty() {
        return None;
    }
    const SHOWN: usize = 6;
    let mut names: Vec<String> = held
        .iter()
        .take(SHOWN)
        .map(|p| p.name(robot).to_string())
        .collect();
    if held.len() > SHOWN {
        names.push("…".into());
    }
    Some(format!(
        "{} of {effect_values} effect values held at their starting values (a table \
         --effect adds starts at 0), as fewer than \
         {MIN_SUPPORT} poses move each ({}): fitted, they would follow those poses' noise; \
         coarser tables (a larger step) or poses there estimate them",
        held.len(),
        names.join(", ")
    ))
}

/// Each value of `params`'s supporters among the observations `at`: distinct poses (a pose's
/// repeats and reflectors are one).
fn support(
    params: usize,
    moves: &[Vec<usize>],
    groups: &[usize],
    at: &[usize],
) -> Vec<std::collections::BTreeSet<usize>> {
    let mut support: Vec<std::collections::BTreeSet<usize>> = vec![Default::default(); params];
    for &i in at {
        for &k in &moves[i] {
            support[k].insert(groups[i]);
        }
    }
    support
}

/// `params` split into those estimated and those held: an effect value with fewer than
/// [`MIN_SUPPORT`] supporters is held (a value no observation moves has none; the others are
/// never held here).
fn split_by_support(
    params: &[kinecal::Param],
    support: &[std::collections::BTreeSet<usize>],
) -> (Vec<kinecal::Param>, Vec<kinecal::Param>) {
    let mut kept = Vec::new();
    let mut held = Vec::new();
    for (p, s) in params.iter().zip(support) {
        if matches!(p, kinecal::Param::Effect(_)) && s.len() < MIN_SUPPORT {
            held.push(*p);
        } else {
            kept.push(*p);
        }
    }
    (kept, held)
}

/// Cross-validates `parameters` fitted to `data`: `place` puts the starting model on a fold's
/// other observations, `fit` fits the given parameters of the model from there (`None`: it
/// could not, or did not converge). `robot` and `params` are the full fit's: which effect
/// values each observation moves; each fold holds those its other poses do not support
/// ([`MIN_SUPPORT`]). `None` below 2 distinct poses. The folds are fitted on several threads.
pub fn cross_validate<const N: usize>(
    data: &[Measurement<f64, N>],
    (robot, params): (&HostRobot<N>, &[kinecal::Param]),
    parameters: usize,
    seed: u64,
    place: impl Fn(&[Measurement<f64, N>]) -> Option<HostRobot<N>> + Sync,
    fit: impl Fn(&HostRobot<N>, &[kinecal::Param], &[Measurement<f64, N>]) -> Option<HostRobot<N>>
        + Sync,
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
        let support = support(params.len(), &moves, &groups, &train_at);
        let (kept, _) = split_by_support(params, &support);
        let fitted = fit(&start, &kept, &train)?;
        let unsupported = test_at
            .iter()
            .filter(|&&i| moves[i].iter().any(|&k| support[k].len() < MIN_SUPPORT))
            .count();
        let test = subset(data, &test_at);
        let square = |robot: &HostRobot<N>| {
            Residuals::of(robot, &[], &test)
                .validation_rms_mm
                .map_or(0.0, |v| v * v * test.len() as f64)
        };
        Some(Fold {
            start_sq: square(&start),
            after_sq: square(&fitted),
            unsupported,
        })
    });
    let seconds = t0.elapsed().as_secs_f64();
    let failed_folds = results.iter().filter(|r| r.is_none()).count();
    let done: Vec<Fold> = results.into_iter().flatten().collect();
    let unsupported: usize = done.iter().map(|f| f.unsupported).sum();
    let figures = (failed_folds == 0).then(|| {
        let rms = |sq: f64| (sq / data.len() as f64).sqrt();
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
