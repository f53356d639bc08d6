//! The discrepancy workflow: fit the geometry, find where model and data disagree, name the
//! missing effect, add it, and show with held-out poses that the gap shrank.
//!
//! 1. **Geometry.** The base is started by point-set registration when unknown, then base +
//!    MDH rows + tool are fitted by the library's Levenberg–Marquardt; parameters the data
//!    cannot determine are held (its identifiability analysis).
//! 2. **Rounds.** With deterministic k-fold cross-validation (k = 5): every candidate of the
//!    catalogue ([`crate::diagnose::candidates`]) is screened by one linearised step from the
//!    current solution ([`crate::diagnose::cross_validation::Linearised`]), and the best grids of
//!    the most promising joint tables have their knots' phase refined the same way
//!    ([`phase_search_starts`]); the best few (3 effect families) are refitted fold by fold by the
//!    library's Levenberg–Marquardt with a penalty on table knots ([`crate::diagnose::refit`]); a
//!    refit is added only if its per-pose held-out improvement passes the one-sided paired t test
//!    at `α / m` (Bonferroni over the `m` candidates screened in the round, α = 5 %; see
//!    [`crate::diagnose::significance`]) and lowers the held-out RMS by a margin a user notices
//!    (`Config::min_rms_drop`, 2 %); of those, the simplest one within one standard error of the
//!    best is added ([`choose`]). The screen's candidates and the refits' folds are independent
//!    jobs, spread over the cores ([`crate::compute::parallel::map_each`], the catalogue's tables
//!    with the most knots first); no result depends on how they were scheduled.
//! 3. **Stop** when nothing passes (or the best that passes is below the margin: the stop reason
//!    says by how much), when the held-out RMS reaches the noise floor estimated from repeated
//!    poses (if the data have any), or after `max_effects` additions.
//! 4. **Noise floor**: repeated poses, else the final model's cross-validated held-out errors
//!    with the fold fits' share taken out ([`crate::diagnose::significance::held_out_noise`]);
//!    never above the final held-out RMS, nor a refused finding's (a floor a model already
//!    beats on unseen poses is no floor; [`refusal`]).
//!
//! One fit per parameter set: the model the baseline held-out RMS is of ([`Diagnosis::
//! baseline_model`]) is fitted once, and when nothing is added it *is* the final model.

pub mod candidates;
pub mod choice;
pub mod cross_validation;
pub mod explain;
pub mod linear;
pub mod observations;
pub mod phase;
pub mod plausibility;
pub mod pose_columns;
pub mod refit;
pub mod refusal;
pub mod residual_plots;
pub mod row_step;
pub mod search_weights;
pub mod significance;
pub mod table_screen;
pub mod time_trend;
pub mod workflow;
pub mod zero_step;

use crate::HostRobot;
pub use choice::{choose, too_small};
use phase::phase_search;
pub use phase::phase_search_starts;

use crate::calibration::fit_lm;
use crate::compute::parallel;
use crate::diagnose::candidates::{
    catalogue, coverage, shifted, Candidate, CandidateKind, CatalogueConfig,
};
use crate::diagnose::cross_validation::{
    fold_inflation, refit_errors, refit_errors_each, rms, Folds, Linearised,
};
use crate::diagnose::linear::{Problem, TablePenalty};
use crate::diagnose::pose_columns::PoseKinematics;
use crate::diagnose::refit::fit;
use crate::diagnose::significance::{
    held_out_noise, noise_floor_interval, paired_improvement, repeat_noise, PairedTest,
};
use crate::output::numfmt::sig;
use kinecal::identify::lm::LmConfig;
use kinecal::model::param::{Param, ParamSet};
use kinecal::Measurement;
use std::time::Instant;

/// Settings of the search; the defaults are the ones the test matrix was run with.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// Cross-validation folds.
    pub folds: usize,
    /// Family-wise false-alarm rate per round (Bonferroni over the candidates screened).
    pub alpha: f64,
    pub catalogue: CatalogueConfig,
    /// How many of the best screened candidates are refitted fold by fold.
    pub refit_best: usize,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// Seed of the folds.
    pub seed: u64,
    pub penalty: TablePenalty,
    /// Iteration limit of each refit.
    pub refit_iterations: u32,
    /// With a noise floor from repeated poses: stop once the held-out RMS is within this factor.
    pub floor_tolerance: f64,
    /// Besides being significant, an addition must lower the held-out RMS by at least this
    /// fraction (0.02: 0.100 → 0.098 mm, a change a user sees in the report's three digits):
    /// a real but negligible gain is not worth a model term, and a term that gains almost
    /// nothing is a term whose size the data hardly determine.
    pub min_rms_drop: f64,
    /// The largest size of each kind of finding that is accepted
    /// ([`plausibility::implausible`]).
    pub plausible: plausibility::Limits,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            folds: 5,
            alpha: 0.05,
            catalogue: CatalogueConfig::default(),
            refit_best: 3,
            max_effects: 12,
            seed: 0,
            penalty: TablePenalty::default(),
            refit_iterations: 20,
            floor_tolerance: 1.05,
            min_rms_drop: 0.02,
            plausible: plausibility::Limits::default(),
        }
    }
}

/// One candidate after the screen of a round.
#[derive(Clone, Debug)]
pub struct Screened {
    pub candidate: Candidate,
    /// Held-out RMS predicted by the linearised step (mm).
    pub linear_rms_mm: f64,
}

/// One candidate refitted fold by fold and tested.
#[derive(Clone, Debug)]
pub struct Tested {
    pub candidate: Candidate,
    /// Number of parameters the candidate adds.
    pub parameters: usize,
    pub validation_rms_mm: f64,
    pub test: PairedTest,
}

/// What happened in one round.
#[derive(Clone, Debug)]
pub struct Round {
    /// Held-out RMS of the model the round started from (mm).
    pub start_rms_mm: f64,
    pub screened: Vec<Screened>,
    pub tested: Vec<Tested>,
    /// `α / m`.
    pub threshold: f64,
    /// Index into `tested` of the one added (or refused, see `refused`).
    pub chosen: Option<usize>,
    /// Why the chosen candidate was refused: physically implausible, or a twin of another
    /// cause the data cannot tell it from (`twin`); then nothing was added this round and its
    /// family is held back, [`held_back`].
    pub refused: Option<String>,
    /// Index into `tested` of the twin ([`choice::twin`]) when that is why it was refused.
    pub twin: Option<usize>,
    pub seconds: f64,
}

/// An effect the search added.
#[derive(Clone, Debug)]
pub struct Found<const N: usize> {
    pub candidate: Candidate,
    /// Held-out RMS before and after adding it (mm).
    pub before_rms_mm: f64,
    pub validation_rms_mm: f64,
    pub test: PairedTest,
    /// The p-value threshold it passed (`α / m`) and `m`.
    pub threshold: f64,
    pub candidates_compared: usize,
    /// The full-data fits without and with it (for plots).
    pub before: HostRobot<N>,
    pub after: HostRobot<N>,
}

/// Where the noise floor estimate comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseSource {
    /// Scatter of repeated poses (identical joint readings).
    RepeatedPoses,
    /// The final model's cross-validated held-out errors less the fold fits' share.
    HeldOut,
}

/// The outcome of the workflow.
#[derive(Clone, Debug)]
pub struct Diagnosis<const N: usize> {
    /// Why the geometric fit is no calibration of the robot file's arm: it stretched or shrank
    /// the links or moved a joint's parameter beyond a calibration (`calibration::arm_size`:
    /// points in another length unit than stated, data against the file's conventions, or
    /// another robot; the workflow adds gross outliers, `calibration::outliers`); then nothing
    /// is diagnosed (exit 3).
    pub resized: Option<String>,
    /// Geometry fitted to all poses by the library's LM (base when unknown, rows, tool): where
    /// the search starts from.
    pub geometric: HostRobot<N>,
    /// The starting parameter set (geometry without the held parameters, plus the nominal
    /// model's own effects) fitted to all poses by the search's fit: the model
    /// `baseline_validation_rms_mm` is of. When nothing is added, `model` is this very fit.
    pub baseline_model: HostRobot<N>,
    /// Geometric parameters the data cannot determine (held at nominal).
    pub unidentifiable: Vec<Param>,
    /// The final parameter set (geometry without the held parameters, the nominal model's
    /// effects and those added), in the refits' order.
    pub params: Vec<Param>,
    pub baseline_validation_rms_mm: f64,
    /// Per-pose held-out squared errors of the geometric model and of the final one (mm²).
    pub baseline_errors: Vec<f64>,
    pub final_errors: Vec<f64>,
    pub found: Vec<Found<N>>,
    pub final_validation_rms_mm: f64,
    /// The extended model, fitted to all poses.
    pub model: HostRobot<N>,
    /// Joints (0-based) whose `beta` is free in the model (axis-tilt).
    pub free_tilt: Vec<usize>,
    /// Noise floor in the held-out RMS sense, `√3 σ` (mm), and per-coordinate σ; never above
    /// `final_validation_rms_mm`.
    pub noise_floor_mm: f64,
    pub noise_sigma_mm: f64,
    pub noise_source: NoiseSource,
    /// Approximate 95 % interval of the noise floor (mm) and the degrees of freedom behind it.
    pub noise_floor_interval_mm: [f64; 2],
    pub noise_dof: f64,
    /// The searched observations include orientations (6-D rows): every RMS figure of the
    /// search and its noise floor are per observation, the point's residual in mm with the
    /// orientation's weighted in ([`crate::diagnose::search_weights`]), not position RMS.
    pub orientations_weighted_in: bool,
    /// The points' coordinates are weighted unequally (stated σ that differ between axes or
    /// rows): the figures are σ-weighted distances, not position RMS.
    pub positions_weighted: bool,
    /// Family-wise false-alarm rate of each round.
    pub alpha: f64,
    /// Residual RMS of the final model on all poses (mm) and its effective parameter count.
    pub fit_rms_mm: f64,
    pub effective_parameters: f64,
    pub rounds: Vec<Round>,
    pub stop_reason: String,
    /// When the search stopped because its best significant candidate lowered the held-out RMS
    /// by less than [`Config::min_rms_drop`]: that candidate and its relative drop.
    pub below_margin: Option<(Candidate, f64)>,
    pub folds: Folds,
    pub geometry_seconds: f64,
    pub seconds: f64,
}

impl<const N: usize> Found<N> {
    /// One sentence: what is missing (its size as the final `model` holds it), how much it
    /// helps, how sure.
    pub fn sentence(&self, model: &HostRobot<N>, noise_floor_mm: f64) -> String {
        let values = self.candidate.values(model);
        let [before, after, floor] =
            distinct_figures([self.before_rms_mm, self.validation_rms_mm, noise_floor_mm]);
        let alpha = self.threshold * self.candidates_compared as f64;
        format!(
            "{}: cross-validated RMS {before} → {after} mm, {} (one-sided paired t test p = {}, below the {} % family-wise threshold {} over {} candidates)",
            self.candidate.meaning(&values),
            floor_phrase(noise_floor_mm, &floor),
            sig(self.test.p, 2),
            percent(alpha),
            sig(self.threshold, 2),
            self.candidates_compared
        )
    }
}

/// Figures for one sentence, with significant digits (at least 3, at most 9): as many as it
/// takes for figures that differ to print differently ("0.0178 → 0.0174", not "0.018 → 0.018";
/// "0.29720 → 0.29724"), all with the same number of digits; a figure that is not finite
/// prints as `-`.
pub fn distinct_figures<const K: usize>(x: [f64; K]) -> [String; K] {
    let mut digits = 3;
    while digits < 9 {
        let s = x.map(|v| sig(v, digits));
        let clash = (0..K).any(|i| {
            (0..i).any(|j| x[i].is_finite() && x[j].is_finite() && x[i] != x[j] && s[i] == s[j])
        });
        if !clash {
            return s;
        }
        digits += 1;
    }
    x.map(|v| sig(v, digits))
}

/// A rate as a percentage without trailing zeros ("5", "2.5").
pub fn percent(rate: f64) -> String {
    let s = sig(100.0 * rate, 3);
    if s.contains('.') && !s.contains('e') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// "noise floor 0.0346 mm", or what stands for it when no floor could be estimated.
pub fn floor_phrase(floor_mm: f64, text: &str) -> String {
    if floor_mm.is_finite() {
        format!("noise floor {text} mm")
    } else {
        "noise floor not estimated".to_string()
    }
}

impl<const N: usize> Diagnosis<N> {
    /// Held-out poses outside the search (a holdout or validation file) reached
    /// `held_out_rms_mm` with the final model: a noise floor above it is contradicted by those
    /// poses (their errors are noise plus the model's), so it is lowered to it. Returns whether
    /// it was.
    pub fn cap_noise_floor(&mut self, held_out_rms_mm: f64) -> bool {
        if !(held_out_rms_mm.is_finite() && self.noise_floor_mm > held_out_rms_mm) {
            return false;
        }
        self.noise_floor_mm = held_out_rms_mm;
        self.noise_sigma_mm = held_out_rms_mm / 3f64.sqrt();
        self.noise_floor_interval_mm[0] = self.noise_floor_interval_mm[0].min(held_out_rms_mm);
        true
    }
}

/// Whether `c`'s family is held back after refusals (`refused`: each refused candidate with the
/// number of effects found when it was refused; `found` effects now): when it was refused twice,
/// or once and nothing has been added since.
pub fn held_back(refused: &[(Candidate, usize)], c: &Candidate, found: usize) -> bool {
    let at: Vec<usize> = refused
        .iter()
        .filter(|(r, _)| r.same_effect(c))
        .map(|(_, at)| *at)
        .collect();
    match at.as_slice() {
        [] => false,
        [once] => *once == found,
        _ => true,
    }
}

/// Fits the geometry: base started by registration when unknown, then LM over base (when
/// unknown), rows, tool and the betas of `free_tilt`. Returns the robot and the held parameters.
pub fn fit_geometry<const N: usize>(
    nominal: &HostRobot<N>,
    base_known: bool,
    free_tilt: &[usize],
    data: &[Measurement<f64, N>],
) -> anyhow::Result<(HostRobot<N>, Vec<Param>)> {
    let mut start = nominal.clone();
    if !base_known {
        crate::compute::registration::place_base(&mut start, data)?;
    }
    let mut params: Vec<Param> = ParamSet::<64>::full(N, !base_known)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    for j in free_tilt {
        params.push(Param::Beta(*j as u8));
    }
    params.extend(observation_params(nominal, data));
    let fitted = fit_lm(&start, &params, data, LmConfig::default())?;
    let held: Vec<Param> = params
        .iter()
        .copied()
        .filter(|p| {
            fitted
                .unidentifiable
                .contains(&p.name(&fitted.robot).to_string())
        })
        .collect();
    Ok((fitted.robot, held))
}

/// Parameters only what `data` observe beyond one point determine: with 6-D observations the
/// measured frame's axes in the flange, with observations of further tool points their
/// offsets (as `identify` frees them).
pub fn observation_params<const N: usize>(
    robot: &HostRobot<N>,
    data: &[Measurement<f64, N>],
) -> Vec<Param> {
    let mut out = Vec::new();
    if data.iter().any(|m| m.orientation.is_some()) {
        out.extend([Param::ToolRx, Param::ToolRy, Param::ToolRz]);
    }
    for k in 1..robot.tool_point_count() {
        if data.iter().any(|m| m.tool as usize == k) {
            out.extend((0..3).map(|a| Param::ToolPoint(k as u8, a)));
        }
    }
    out
}

/// The observations of one pose: consecutive observations with the same joint readings and
/// distinct tool points (a repeat of a point starts a new pose). The paired test compares
/// poses, not observations: the points of one pose share its joint errors.
pub fn observation_poses<const N: usize>(data: &[Measurement<f64, N>]) -> Vec<usize> {
    let mut out = Vec::with_capacity(data.len());
    let mut start = 0;
    for (i, m) in data.iter().enumerate() {
        let same =
            i > 0 && m.q == data[start].q && !data[start..i].iter().any(|o| o.tool == m.tool);
        if !same {
            start = i;
        }
        out.push(out.last().map_or(0, |&p: &usize| p + usize::from(!same)));
    }
    out
}

/// Per-pose sums of per-observation values (`pose_of` from [`observation_poses`]).
fn per_pose(values: &[f64], pose_of: &[usize]) -> Vec<f64> {
    if pose_of.last().is_none_or(|&p| p + 1 == values.len()) {
        return values.to_vec();
    }
    let mut out = vec![0.0; pose_of.last().map_or(0, |p| p + 1)];
    for (v, p) in values.iter().zip(pose_of) {
        out[*p] += v;
    }
    out
}

/// Where the search is, for a progress display ([`diagnose_with_progress`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// Fitting the geometry (base start, LM with identifiability analysis).
    Geometry,
    /// The starting model's held-out errors (one refit per fold).
    Baseline,
    /// Round `round` (1-based) screens `candidates` candidates by one linearised step each.
    Screen {
        /// The round, from 1.
        round: usize,
        /// Candidates screened.
        candidates: usize,
    },
    /// Round `round` refits the best `families` candidates in every fold.
    Refit {
        /// The round, from 1.
        round: usize,
        /// Candidates refitted (one per family).
        families: usize,
    },
}

/// Runs the whole workflow on `data` for the `nominal` model (its effects, if any, are kept
/// and refitted; `free_tilt` are joints whose beta is already free).
pub fn diagnose<const N: usize>(
    nominal: &HostRobot<N>,
    base_known: bool,
    free_tilt: &[usize],
    data: &[Measurement<f64, N>],
    cfg: &Config,
) -> anyhow::Result<Diagnosis<N>> {
    diagnose_with_progress(nominal, base_known, free_tilt, data, cfg, &mut |_| {})
}

/// [`diagnose`], telling `on_progress` where the search is before each stage.
pub fn diagnose_with_progress<const N: usize>(
    nominal: &HostRobot<N>,
    base_known: bool,
    free_tilt: &[usize],
    data: &[Measurement<f64, N>],
    cfg: &Config,
    on_progress: &mut dyn FnMut(Progress),
) -> anyhow::Result<Diagnosis<N>> {
    let t0 = Instant::now();
    anyhow::ensure!(
        data.len() >= 2 * cfg.folds.max(2),
        "{} poses are too few for {}-fold cross-validation",
        data.len(),
        cfg.folds
    );
    on_progress(Progress::Geometry);
    let (geometric, held) = fit_geometry(nominal, base_known, free_tilt, data)?;
    let resized = crate::calibration::arm_size::resized(nominal, &geometric);
    let geometry_seconds = t0.elapsed().as_secs_f64();
    let mut params: Vec<Param> = ParamSet::<64>::full(N, !base_known)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    params.extend(free_tilt.iter().map(|j| Param::Beta(*j as u8)));
    params.extend(observation_params(nominal, data));
    params.retain(|p| !held.contains(p));
    params.extend((0..geometric.effects().values().len()).map(|k| Param::Effect(k as u16)));
    let mut problem = Problem::new(&geometric, &params, cfg.penalty)?;
    // The one fit of the starting parameter set: the baseline's model, and the final model
    // when nothing is added.
    let mut current_fit = fit(&geometric, &problem, data, cfg.refit_iterations)?;
    let baseline_model = current_fit.robot.clone();
    let mut current = current_fit.robot.clone();
    let folds = Folds::new(data, cfg.folds, cfg.seed);
    on_progress(Progress::Baseline);
    let baseline_errors = refit_errors(&current, &problem, data, &folds, cfg.refit_iterations)?;
    let baseline_rms = rms(&baseline_errors);
    let repeat = repeat_noise(data);
    let pose_of = observation_poses(data);
    let mut errors = baseline_errors.clone();
    let mut free_tilt: Vec<usize> = free_tilt.to_vec();
    let mut found: Vec<Found<N>> = Vec::new();
    // Candidates refused (physically implausible, or twins), with the number of effects found
    // by then.
    // A refused family is held back until another effect has been added (its fit was made with
    // that effect still missing: a compliance at its limit reads beyond it while a table is
    // missing); refused a second time, it is dropped.
    let mut refused: Vec<(Candidate, usize)> = Vec::new();
    let mut rounds = Vec::new();
    let stop_reason;
    let mut below_margin = None;
    loop {
        let cur_rms = rms(&errors);
        if let Some((sigma, _)) = repeat {
            if cur_rms <= cfg.floor_tolerance * 3f64.sqrt() * sigma {
                stop_reason = format!(
                    "the held-out RMS {} mm reached the noise floor of the repeated poses ({} mm)",
                    sig(cur_rms, 4),
                    sig(3f64.sqrt() * sigma, 4)
                );
                break;
            }
        }
        if found.len() >= cfg.max_effects {
            stop_reason = format!("{} effects added (the limit)", found.len());
            break;
        }
        let tr = Instant::now();
        let cands: Vec<Candidate> = catalogue(&current, base_known, data, &cfg.catalogue)
            .into_iter()
            .filter(|c| {
                !c.present_in(&current, &free_tilt)
                    && !found.iter().any(|f| f.candidate.same_effect(c))
                    && !held_back(&refused, c, found.len())
            })
            .collect();
        if cands.is_empty() {
            stop_reason = "no candidate left".into();
            break;
        }
        on_progress(Progress::Screen {
            round: rounds.len() + 1,
            candidates: cands.len(),
        });
        let lin = Linearised::new(&current, &problem, data, &folds);
        let lin_base = rms(&lin.baseline());
        let kinematics = PoseKinematics::new(&current, data);
        let screen = |c: &Candidate| {
            let mut robot_c = current.clone();
            // A candidate the model has no room for (effect capacity) is not compared.
            let extra = c.add_to(&mut robot_c).ok()?;
            let cols = kinematics.columns(&robot_c, &extra);
            let table = matches!(c.kind, CandidateKind::Table { .. }).then_some(cfg.penalty);
            Some(Screened {
                candidate: *c,
                linear_rms_mm: lin.screen_rms(&cols, extra.len(), table),
            })
        };
        // The tables with the most knots first (the screen's cost grows with them).
        let size = |c: &Candidate| match c.kind {
            CandidateKind::Table { knots, .. } => knots,
            _ => 1,
        };
        let mut screened: Vec<Screened> = parallel::map_each_largest_first(&cands, size, screen)
            .into_iter()
            .flatten()
            .collect();
        // The knots' phase: the best grids of the most promising tables shifted along the
        // joint, screened the same way (and counted in m below).
        let starts = phase_search_starts(&screened, &cfg.catalogue, cfg.refit_best + 2, data.len());
        let (lo, hi) = coverage(data);
        let catalogue_screened = screened.len();
        phase_search(
            starts,
            &mut screened,
            (&lo, &hi),
            data.len(),
            &cfg.catalogue,
            screen,
        );
        screened.sort_by(|a, b| a.linear_rms_mm.total_cmp(&b.linear_rms_mm));
        // The catalogue's candidates count; the phase bisection fits a candidate's phase (its
        // kept grids replace their start within the family, the others are not candidates).
        let m = catalogue_screened;
        let threshold = cfg.alpha / m as f64;
        // Refit the best member of each of the best few families (one effect kind on one joint:
        // the grids of a table are one family), so that a simple effect is not crowded out by
        // several resolutions of a table that contains it.
        let mut families: Vec<Candidate> = Vec::new();
        for s in screened.iter().filter(|s| s.linear_rms_mm < lin_base) {
            if families.len() >= cfg.refit_best {
                break;
            }
            if !families.iter().any(|f| f.same_effect(&s.candidate)) {
                families.push(s.candidate);
            }
        }
        // The families' fold refits are independent: all of them at once, over the cores.
        let mut models = Vec::with_capacity(families.len());
        for c in &families {
            let mut robot_c = current.clone();
            let extra = c.add_to(&mut robot_c)?;
            let parameters = extra.len();
            let mut p = problem.params.clone();
            p.extend(extra);
            let problem_c = Problem::new(&robot_c, &p, cfg.penalty)?;
            models.push((robot_c, problem_c, parameters));
        }
        let starts: Vec<(&HostRobot<N>, &Problem)> =
            models.iter().map(|(r, p, _)| (r, p)).collect();
        on_progress(Progress::Refit {
            round: rounds.len() + 1,
            families: starts.len(),
        });
        let held_out = refit_errors_each(&starts, data, &folds, cfg.refit_iterations)?;
        let tested: Vec<Tested> = families
            .iter()
            .zip(&models)
            .zip(&held_out)
            .map(|((c, (_, _, parameters)), e)| Tested {
                candidate: *c,
                parameters: *parameters,
                validation_rms_mm: rms(e),
                test: paired_improvement(&per_pose(&errors, &pose_of), &per_pose(e, &pose_of)),
            })
            .collect();
        let mut fits: Vec<_> = models
            .into_iter()
            .zip(held_out)
            .map(|((r, p, _), e)| (r, p, e))
            .collect();
        let errs: Vec<&[f64]> = fits.iter().map(|f| f.2.as_slice()).collect();
        let max_rms = (1.0 - cfg.min_rms_drop) * cur_rms;
        let chosen = choose(&tested, &errs, threshold, max_rms);
        let twin = chosen.and_then(|i| choice::twin(&tested, &errs, (threshold, max_rms), i));
        rounds.push(Round {
            start_rms_mm: cur_rms,
            screened,
            tested: tested.clone(),
            threshold,
            chosen,
            refused: None,
            twin: None,
            seconds: tr.elapsed().as_secs_f64(),
        });
        let Some(i) = chosen else {
            below_margin = too_small(&tested, threshold, cur_rms).map(|(t, d)| (t.candidate, d));
            stop_reason = match below_margin {
                Some((c, drop)) => format!(
                    "the best significant candidate, {}, lowers the held-out RMS by only {} % \
                     (an effect is added from {} %)",
                    c.label(),
                    sig(100.0 * drop, 3),
                    sig(100.0 * cfg.min_rms_drop, 3)
                ),
                None => "no remaining candidate improves the held-out error significantly".into(),
            };
            break;
        };
        let last = fits.len() - 1;
        let (robot_c, problem_c, e) = fits.swap_remove(i);
        let after_fit = fit(&robot_c, &problem_c, data, cfg.refit_iterations)?;
        let after = after_fit.robot.clone();
        let t = &tested[i];
        let values = t.candidate.values(&after);
        if let Some(why) = plausibility::implausible(&t.candidate, &values, &cfg.plausible) {
            // Significant but no physical effect of its kind: refused, and its family is held
            // back until another effect has been added ([`held_back`]).
            refused.push((t.candidate, found.len()));
            if let Some(r) = rounds.last_mut() {
                r.refused = Some(why);
            }
            continue;
        }
        // The data cannot tell the chosen one from its twin: only a plausible twin vetoes it
        // (one whose full-data fit fails counts as plausible). `swap_remove` moved the last
        // fit to `i`.
        let plausible_twin = twin.filter(|&j| {
            let (robot, problem, _) = &fits[if j == last { i } else { j }];
            let c = &tested[j].candidate;
            fit(robot, problem, data, cfg.refit_iterations).map_or(true, |f| {
                plausibility::implausible(c, &c.values(&f.robot), &cfg.plausible).is_none()
            })
        });
        if let Some(j) = plausible_twin {
            // An effect the data cannot tell from another of a different cause: neither is
            // named, and both families are held back as refused ones are.
            refused.extend([
                (tested[i].candidate, found.len()),
                (tested[j].candidate, found.len()),
            ]);
            if let Some(r) = rounds.last_mut() {
                r.refused = Some(choice::twin_reason(&tested[i], &tested[j]));
                r.twin = Some(j);
            }
            continue;
        }
        if t.candidate.kind == CandidateKind::Tilt {
            free_tilt.push(t.candidate.joint);
        }
        found.push(Found {
            candidate: t.candidate,
            before_rms_mm: cur_rms,
            validation_rms_mm: t.validation_rms_mm,
            test: t.test,
            threshold,
            candidates_compared: m,
            before: current.clone(),
            after: after.clone(),
        });
        current = after;
        current_fit = after_fit;
        problem = problem_c;
        errors = e;
    }
    // The final model: with nothing added, the baseline's own fit (not a second fit of the
    // same parameters); with effects added, the last fit continued to convergence (a model
    // with a new parameter set, so no figure of the same set is reported for it elsewhere).
    let final_fit = if found.is_empty() {
        current_fit
    } else {
        fit(&current, &problem, data, cfg.refit_iterations)?
    };
    let effective_parameters = final_fit.effective_parameters(&problem, data);
    let n = data.len();
    let final_rms = rms(&errors);
    // The noise floor, in the held-out RMS sense (√3 σ).
    // (√(rows per observation) σ: 3 rows per position, 6 per 6-D observation.)
    let mut rows_per_observation = 3.0;
    let (floor, dof, noise_source) = match repeat {
        Some((s, dof)) => (3f64.sqrt() * s, dof as f64, NoiseSource::RepeatedPoses),
        None => {
            let inflation = fold_inflation(&final_fit.robot, &problem, data, &folds);
            rows_per_observation = inflation.coordinates as f64 / n as f64;
            let (s, nu) = held_out_noise(errors.iter().sum(), &inflation);
            // The Satterthwaite ν leaves out the covariances between folds (optimistic): it
            // is capped at the residual's degrees of freedom, rows − p_eff.
            let residual_dof = inflation.coordinates as f64 - effective_parameters;
            (
                rows_per_observation.sqrt() * s,
                nu.min(residual_dof.max(1.0)),
                NoiseSource::HeldOut,
            )
        }
    };
    let mut interval = noise_floor_interval(floor, dof);
    // Held-out errors are noise plus a fit's error: the floor cannot lie above what the final
    // model reaches on poses it did not see. (By construction for the held-out estimate; for
    // repeated poses a cap when their scatter happens to exceed it.) Nor above what a standing
    // refused finding (implausible, or a twin) reached on them ([`refusal`]).
    let reached = final_rms.min(refusal::least_rms(&rounds, &found, final_rms));
    let noise_floor_mm = if floor.is_finite() && floor > reached {
        interval[0] = interval[0].min(reached);
        if reached < final_rms {
            interval[1] = interval[1].min(reached);
        }
        reached
    } else {
        floor
    };
    Ok(Diagnosis {
        geometric,
        resized,
        baseline_model,
        unidentifiable: held,
        params: problem.params.clone(),
        baseline_validation_rms_mm: baseline_rms,
        baseline_errors,
        final_validation_rms_mm: final_rms,
        final_errors: errors,
        found,
        below_margin,
        model: final_fit.robot,
        free_tilt,
        noise_floor_mm,
        noise_sigma_mm: noise_floor_mm / rows_per_observation.sqrt(),
        noise_source,
        noise_floor_interval_mm: interval,
        noise_dof: dof,
        orientations_weighted_in: data.iter().any(|m| m.orientation.is_some()),
        positions_weighted: data
            .iter()
            .any(|m| m.weight.iter().any(|w| (w - 1.0).abs() > 1e-6)),
        alpha: cfg.alpha,
        fit_rms_mm: (final_fit.ssr / n as f64).sqrt(),
        effective_parameters,
        rounds,
        stop_reason,
        folds,
        geometry_seconds,
        seconds: t0.elapsed().as_secs_f64(),
    })
}
