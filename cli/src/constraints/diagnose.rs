//! The discrepancy search on a constraint session (`diagnose` on a constraint file): which
//! effect of the catalogue the geometry misses, judged on groups the fit did not see.
//!
//! Every candidate of [`crate::diagnose::candidates::catalogue`] that a constraint session can
//! carry (joint compliance, cyclic errors of orders 1..=`max_order`, joint scales, axis tilts,
//! thermal expansion when the rows carry temperatures; correction tables are left out: a
//! session of tens of groups cannot hold their knots) is added to the model with zero values
//! and fitted with it ([`super::fit`], the shapes with it), by `folds`-fold cross-validation
//! over the identification groups (whole groups, folds drawn by the seed): each group's error
//! is taken against its own shape refitted to the points of the model fitted without it
//! ([`super::shapes::held_out_error`]). A round takes the candidate with the lowest
//! cross-validated RMS when it passes both tests: the paired one-sided t test of the groups'
//! squared errors against the current model's at `alpha` over the number of candidates
//! (Bonferroni), and a drop of the cross-validated RMS by at least [`PRACTICAL`] (a finding a
//! user would notice). Rounds go on from the extended model until none passes or
//! `max_effects` are found.

use super::fit::{candidates, fit, Fitted};
use super::read::Group;
use super::shapes::held_out_error;
use crate::calibration::stats::rms;
use crate::calibration::EffectRequest;
use crate::diagnose::candidates::{catalogue, CandidateKind, CatalogueConfig};
use crate::diagnose::significance::paired_improvement;
use crate::formats::robot_file::RobotFile;
use crate::HostRobot;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Least relative drop of the cross-validated RMS a finding must bring.
pub const PRACTICAL: f64 = 0.05;

/// How the search runs.
#[derive(Clone, Copy, Debug)]
pub struct SearchOptions {
    pub folds: usize,
    pub alpha: f64,
    pub max_order: u16,
    pub max_effects: usize,
    pub seed: u64,
}

/// One round: the best candidate and what it did to the cross-validated RMS.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Round {
    /// The best candidate (an `--effect` request: `joint-cyclic:2:1`) and its label.
    pub effect: String,
    pub label: String,
    pub candidates: usize,
    pub cv_rms_before_mm: f64,
    pub cv_rms_after_mm: f64,
    /// One-sided p of the paired test, and the threshold it had to pass.
    pub p: f64,
    pub threshold: f64,
    pub accepted: bool,
    /// Why a candidate that passed the test was not taken: its fitted size is no arm's (a
    /// thermal expansion outside the materials' range).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub implausible: Option<String>,
}

/// The search's outcome.
#[derive(Clone, Debug)]
pub struct Search {
    pub rounds: Vec<Round>,
    /// The effects found, as `--effect` requests.
    pub found: Vec<EffectRequest>,
    pub cv_rms_geometric_mm: f64,
    pub cv_rms_final_mm: f64,
}

/// `effects` added to `nominal` (zero values) and fitted with the shapes to `groups`.
pub fn fit_with<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    effects: &[EffectRequest],
    groups: &[Group<N>],
) -> anyhow::Result<Fitted<N>> {
    let mut robot = nominal.clone();
    let extra = super::effects::add_effects(&mut robot, effects, groups)?;
    let base_unknown =
        !(file.base_known() && groups.iter().any(|g| g.kind == super::read::Kind::Point));
    let params = candidates(&robot, file, base_unknown, &extra)?;
    fit(&robot, groups, &params)
}

/// Each group's cross-validated error (mm) with `effects`: fitted without its fold.
fn cv_errors<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    effects: &[EffectRequest],
    groups: &[Group<N>],
    fold_of: &[usize],
    folds: usize,
) -> anyhow::Result<Vec<f64>> {
    let mut e = vec![f64::NAN; groups.len()];
    for f in 0..folds {
        let train: Vec<Group<N>> = groups
            .iter()
            .zip(fold_of)
            .filter(|(_, k)| **k != f)
            .map(|(g, _)| g.clone())
            .collect();
        let fitted = fit_with(file, nominal, effects, &train)?;
        for (i, g) in groups.iter().enumerate() {
            if fold_of[i] == f {
                e[i] = held_out_error(&fitted.robot, g);
            }
        }
    }
    Ok(e)
}

/// The catalogue's candidates a constraint session can carry, as `--effect` requests with a
/// label each.
fn requests<const N: usize>(
    nominal: &HostRobot<N>,
    base_known: bool,
    groups: &[Group<N>],
    max_order: u16,
) -> Vec<(EffectRequest, String)> {
    let rows = super::effects::measurements(groups);
    let cfg = CatalogueConfig {
        max_cyclic_order: max_order,
        table_intervals: Vec::new(),
        table_pitches_deg: Vec::new(),
        ..CatalogueConfig::default()
    };
    catalogue(nominal, base_known, &rows, &cfg)
        .into_iter()
        .filter_map(|c| {
            let arg = match c.kind {
                CandidateKind::Cyclic(n) => Some(f64::from(n)),
                CandidateKind::Thermal { reference } => Some(reference),
                CandidateKind::Table { .. } => return None,
                _ => None,
            };
            Some((
                EffectRequest {
                    kind: c.id().to_string(),
                    joint: c.joint,
                    arg,
                },
                c.label(),
            ))
        })
        .collect()
}

/// Why `effects` fitted to every one of `groups` are no arm's: a thermal expansion outside
/// [`crate::calibration::thermal::MOST_SHRINK_PER_K`] ..
/// [`crate::calibration::thermal::MOST_EXPANSION_PER_K`] (a constraint session gives it no σ;
/// the tracker search refuses the same, `diagnose::plausibility`).
fn implausible<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    effects: &[EffectRequest],
    groups: &[Group<N>],
) -> Option<String> {
    use crate::calibration::thermal::{within_materials, MOST_EXPANSION_PER_K, MOST_SHRINK_PER_K};
    let fitted = fit_with(file, nominal, effects, groups).ok()?;
    let (_, c, _) = fitted.robot.effects().thermal()?;
    (!within_materials(c) || !c.is_finite()).then(|| {
        format!(
            "the thermal expansion would be {} ppm per kelvin, outside the {} to {} ppm of an \
             arm's material: the temp_c column does not follow the arm's temperature",
            crate::output::numfmt::sig(c * 1e6, 3),
            crate::output::numfmt::sig(MOST_SHRINK_PER_K * 1e6, 2),
            crate::output::numfmt::sig(MOST_EXPANSION_PER_K * 1e6, 3)
        )
    })
}

/// An `--effect` request as the command line writes it (1-based joint; thermal expansion on
/// joint 0 with its reference temperature).
pub fn request_text(r: &EffectRequest) -> String {
    if r.kind == crate::formats::robot_file::THERMAL {
        return match r.arg {
            Some(t) => format!("{}:0:{t}", r.kind),
            None => r.kind.clone(),
        };
    }
    match r.arg {
        Some(a) => format!("{}:{}:{a}", r.kind, r.joint + 1),
        None => format!("{}:{}", r.kind, r.joint + 1),
    }
}

/// Searches `groups` (the identification groups) for the effects the geometry of `nominal`
/// misses (see the module).
pub fn search<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    groups: &[Group<N>],
    opts: &SearchOptions,
) -> anyhow::Result<Search> {
    let folds = opts.folds.clamp(2, groups.len().max(2));
    if groups.len() < 2 * folds {
        crate::refuse!(
            "diagnose: {} identification groups for {folds} folds: measure more groups or give \
             fewer --folds (each fold needs 2 groups)",
            groups.len()
        );
    }
    let mut order: Vec<usize> = (0..groups.len()).collect();
    order.shuffle(&mut Xoshiro256PlusPlus::seed_from_u64(opts.seed));
    let mut fold_of = vec![0; groups.len()];
    for (pos, &i) in order.iter().enumerate() {
        fold_of[i] = pos % folds;
    }
    let all = requests(nominal, file.base_known(), groups, opts.max_order);
    let mut found: Vec<EffectRequest> = Vec::new();
    let mut current = cv_errors(file, nominal, &found, groups, &fold_of, folds)?;
    let geometric = rms(&current);
    let mut rounds = Vec::new();
    while found.len() < opts.max_effects {
        let open: Vec<&(EffectRequest, String)> = all
            .iter()
            .filter(|(r, _)| {
                !found
                    .iter()
                    .any(|f| f.kind == r.kind && f.joint == r.joint && f.arg == r.arg)
            })
            .collect();
        if open.is_empty() {
            break;
        }
        let mut best: Option<(usize, Vec<f64>)> = None;
        for (k, (req, _)) in open.iter().enumerate() {
            let mut with = found.clone();
            with.push(req.clone());
            // A candidate the fit cannot take (nothing of it seen) is no finding.
            let Ok(e) = cv_errors(file, nominal, &with, groups, &fold_of, folds) else {
                continue;
            };
            if e.iter().all(|x| x.is_finite())
                && best.as_ref().is_none_or(|(_, b)| rms(&e) < rms(b))
            {
                best = Some((k, e));
            }
        }
        let Some((k, e)) = best else {
            break;
        };
        let sq = |v: &[f64]| v.iter().map(|x| x * x).collect::<Vec<f64>>();
        let test = paired_improvement(&sq(&current), &sq(&e));
        let threshold = opts.alpha / open.len() as f64;
        let (before, after) = (rms(&current), rms(&e));
        let passed = test.p < threshold && after <= (1.0 - PRACTICAL) * before;
        let implausible = if passed {
            let mut with = found.clone();
            with.push(open[k].0.clone());
            implausible(file, nominal, &with, groups)
        } else {
            None
        };
        let accepted = passed && implausible.is_none();
        rounds.push(Round {
            effect: request_text(&open[k].0),
            label: open[k].1.clone(),
            candidates: open.len(),
            cv_rms_before_mm: before,
            cv_rms_after_mm: after,
            p: test.p,
            threshold,
            accepted,
            implausible,
        });
        if !accepted {
            break;
        }
        found.push(open[k].0.clone());
        current = e;
    }
    Ok(Search {
        rounds,
        found,
        cv_rms_geometric_mm: geometric,
        cv_rms_final_mm: rms(&current),
    })
}
