//! The report of `kinecal diagnose`, built from a [`Diagnosis`] ([`DiagnoseReport::of`]).

use crate::calibration::Residuals;
use crate::diagnose::candidates::CandidateKind;
use crate::diagnose::explain::{explain, Explanation};
use crate::diagnose::workflow::{Diagnosed, Holdout};
use crate::diagnose::{distinct_figures, floor_phrase, percent, Diagnosis, NoiseSource};
use crate::output::numfmt::sig;
use crate::reports::identify::{ObservationSummary, PointResiduals};
use kinecal::Measurement;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

pub use crate::diagnose::workflow::DEFAULT_STALL_RMS_MM;

/// `kinecal diagnose`: what is missing from the model, how sure, and the search behind it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiagnoseReport {
    /// Cross-validated held-out RMS of the starting (geometric) model (mm).
    pub baseline_validation_rms_mm: f64,
    /// The effects added, in the order added (empty: nothing significant is missing).
    pub found: Vec<FoundEffect>,
    pub final_validation_rms_mm: f64,
    /// Measurement noise in the held-out RMS sense (mm).
    pub noise_floor_mm: f64,
    pub noise_floor_source: String,
    pub noise_floor_interval_mm: [f64; 2],
    pub noise_floor_dof: f64,
    pub noise_sigma_mm: f64,
    /// The search read orientations (6-D rows): its RMS figures and noise floor are per
    /// observation with the orientation weighted in, not position RMS (those are under
    /// `observations`).
    pub figures_include_orientations: bool,
    /// The points carry σ that differ between their axes or rows and no 6-D rows weigh
    /// orientations in (then `figures_include_orientations` says it): the search's RMS figures
    /// and noise floor are weighted by them, not position RMS (those are under `observations`).
    pub figures_sigma_weighted: bool,
    /// The headline.
    pub summary: String,
    /// One sentence per effect found.
    pub sentences: Vec<String>,
    pub folds: usize,
    pub fit_rms_mm: f64,
    pub effective_parameters: f64,
    /// Geometric parameters the data cannot determine.
    pub unidentifiable: Vec<String>,
    pub stop_reason: String,
    pub rounds: Vec<RoundReport>,
    pub geometry_seconds: f64,
    pub seconds: f64,
    /// Poses searched (without the held-out ones).
    pub poses: usize,
    /// The geometric model fits the data (`false`: nothing is diagnosed, exit 3).
    pub converged: bool,
    /// Why the geometric fit is no calibration of the robot file's arm: it stretched or shrank
    /// its links or moved a joint's parameter beyond a calibration (`calibration::arm_size`), or
    /// gross outliers pulled it (`calibration::outliers`); then `converged` is false.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resized: Option<String>,
    /// A finding refused (implausible, or not told from its twin) that would have left less
    /// than 1/√2 of what the final model leaves (`diagnose::refusal`): the data hold an error the model cannot take, and
    /// the diagnosis is no calibration (exit 3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unexplained: Option<String>,
    /// Errors on the poses kept out of the whole search (`--holdout`, `--validate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holdout: Option<HoldoutReport>,
    /// With held-out poses: the final model predicts them worse than the nominal robot
    /// (placed as identify places it): exit 3.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out_worse: Option<bool>,
    /// With held-out poses: the verdict on them and its likely reasons.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acceptance: Option<crate::calibration::acceptance::Acceptance>,
    /// With 6-D, σ-weighted or several-reflector data: the geometry and the extended model
    /// fitted to all observations (the model `--out` writes; crate::diagnose::observations).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observations: Option<ObservationsReport>,
    /// The extended model's robot file, when written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub out: Option<String>,
    /// SVG files written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plots: Option<Vec<String>>,
    /// Where the noise floor comes from (the text's wording).
    #[serde(skip)]
    pub noise_source: NoiseSource,
    /// The family-wise false-alarm rate of each round.
    #[serde(skip)]
    pub alpha: f64,
}

/// One effect the search added.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FoundEffect {
    /// The effect id (docs/formats.md), `axis-tilt` included.
    pub effect: String,
    /// 1-based (0 for `thermal-expansion` and `base-drift`, which act on no joint).
    pub joint: usize,
    pub values: Vec<f64>,
    /// Held-out RMS after adding it (mm).
    pub validation_rms_mm: f64,
    pub before_validation_rms_mm: f64,
    pub p_value: f64,
    pub p_threshold: f64,
    pub candidates_compared: usize,
    pub sentence: String,
    /// Joint-cyclic: the harmonic order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order: Option<u16>,
    /// Joint-table: knot spacing and first knot (degrees), knot count.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub step_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub knots: Option<usize>,
    /// Thermal-expansion: the reference temperature T0 (°C) its value `c` (per kelvin) is from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_c: Option<f64>,
    /// Base-drift: the reference time t0 (s) its velocity (mm per second) is from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_s: Option<f64>,
    /// The finding in a technician's words with its size, period, where it acts and the share
    /// of the held-out gap it closed ([`crate::diagnose::explain`]); present when the report
    /// was made with the search's data ([`DiagnoseReport::with_explanations`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub explanation: Option<Explanation>,
}

/// One round of the search.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RoundReport {
    pub start_validation_rms_mm: f64,
    /// Candidates screened.
    pub candidates: usize,
    pub p_threshold: f64,
    /// The five best of the linearised screen.
    pub screen_best: Vec<Screened>,
    pub refitted: Vec<Refitted>,
    /// The candidate added (null: none).
    pub added: Option<String>,
    /// The candidate the test chose but that was refused, as physically implausible or as the
    /// twin of another cause, and why (absent when none was).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refused: Option<Refused>,
    pub seconds: f64,
}

/// A significant candidate refused for its implausible size, or as a twin.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Refused {
    pub candidate: String,
    pub reason: String,
}

/// A candidate of the screen.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Screened {
    pub candidate: String,
    pub linearised_validation_rms_mm: f64,
}

/// A candidate refitted fold by fold and tested.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Refitted {
    pub candidate: String,
    pub validation_rms_mm: f64,
    pub p_value: f64,
}

/// The geometry and the extended model fitted to all observations of the searched poses
/// (orientations, the stated σ, every reflector), with their errors there and on the held-out
/// poses: `before` the geometry, `after` the extended model (the keys of `identify`'s).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObservationsReport {
    /// What the observations were and how they were weighted (`identify`'s `observations`).
    #[serde(flatten)]
    pub summary: ObservationSummary,
    pub before: Residuals,
    pub after: Residuals,
    /// With several reflectors: `before`/`after` per reflector name.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_point: Option<BTreeMap<String, PointResiduals>>,
    /// Geometric parameters all observations cannot determine.
    pub unidentifiable: Vec<String>,
    /// χ² per degree of freedom of the stated σ at the extended model (≈ 1 when they fit).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2_per_dof: Option<f64>,
}

/// Errors on the poses kept out of the whole search.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HoldoutReport {
    pub poses: usize,
    /// The nominal robot, placed as identify places it (mm): what the calibration is judged
    /// against.
    pub start_rms_mm: f64,
    /// The starting model as the search fitted it (mm).
    pub geometric_rms_mm: f64,
    /// The final model (mm).
    pub final_rms_mm: f64,
    /// The noise floor was lowered to `final_rms_mm`.
    pub noise_floor_capped: bool,
}

impl From<&Holdout> for HoldoutReport {
    fn from(h: &Holdout) -> Self {
        Self {
            poses: h.poses,
            start_rms_mm: h.start_rms_mm,
            geometric_rms_mm: h.geometric_rms_mm,
            final_rms_mm: h.final_rms_mm,
            noise_floor_capped: h.noise_floor_capped,
        }
    }
}

impl DiagnoseReport {
    /// The report of the workflow's result `w` ([`crate::diagnose::workflow::run`]) with
    /// `--stall-rms-mm` `stall_rms_mm`: the findings explained on the searched poses, the
    /// held-out errors and their verdict, the fit to all observations; nothing written.
    pub fn of_workflow<const N: usize>(w: &Diagnosed<N>, stall_rms_mm: f64) -> Self {
        let d = &w.diagnosis;
        let mut report = Self::with_stall_limit(d, stall_rms_mm).with_explanations(d, &w.search);
        report.acceptance = w.acceptance.clone();
        report.held_out_worse = w.acceptance.as_ref().map(|a| a.held_out_worse);
        report.holdout = w.holdout.as_ref().map(HoldoutReport::from);
        report.poses = w.search_poses;
        report.observations = w.all_observations.as_ref().map(|a| ObservationsReport {
            summary: ObservationSummary::new(
                &a.observed,
                a.observations,
                a.deg_weight_mm,
                &a.fit.weighting,
            ),
            before: a.before,
            after: a.after,
            per_point: PointResiduals::per_point(
                &a.observed.names,
                (&a.fit.geometric, &a.fit.model),
                (&a.fit.weighted, &a.held),
            ),
            unidentifiable: a.fit.unidentifiable.clone(),
            chi2_per_dof: a.fit.chi2_per_dof,
        });
        report
    }

    /// The report of `d`, judged with the default `--stall-rms-mm`
    /// ([`DEFAULT_STALL_RMS_MM`]); no held-out poses, nothing written.
    pub fn of<const N: usize>(d: &Diagnosis<N>) -> Self {
        Self::with_stall_limit(d, DEFAULT_STALL_RMS_MM)
    }

    /// The report of `d`; the geometric fit counts as converged when its held-out RMS is at
    /// most `stall_rms_mm`.
    pub fn with_stall_limit<const N: usize>(d: &Diagnosis<N>, stall_rms_mm: f64) -> Self {
        let found = d
            .found
            .iter()
            .map(|f| {
                let c = &f.candidate;
                let (mut order, mut step_deg, mut start_deg, mut knots) = (None, None, None, None);
                let mut reference_c = None;
                let mut reference_s = None;
                match c.kind {
                    CandidateKind::Cyclic(n) => order = Some(n),
                    CandidateKind::Table {
                        start,
                        step,
                        knots: k,
                    } => {
                        // As the robot file writes them: the shortest decimals that read
                        // back to the same radians (3.6, not 3.6000000000000005).
                        step_deg = Some(crate::formats::robot_file::deg_short(step));
                        start_deg = Some(crate::formats::robot_file::deg_short(start));
                        knots = Some(k);
                    }
                    CandidateKind::Thermal { reference } => reference_c = Some(reference),
                    CandidateKind::Drift { reference } => reference_s = Some(reference),
                    _ => {}
                }
                let thermal = matches!(
                    c.kind,
                    CandidateKind::Thermal { .. } | CandidateKind::Drift { .. }
                );
                FoundEffect {
                    effect: c.id().to_string(),
                    joint: if thermal { 0 } else { c.joint + 1 },
                    values: c.values(&d.model),
                    validation_rms_mm: f.validation_rms_mm,
                    before_validation_rms_mm: f.before_rms_mm,
                    p_value: f.test.p,
                    p_threshold: f.threshold,
                    candidates_compared: f.candidates_compared,
                    sentence: f.sentence(&d.model, d.noise_floor_mm),
                    order,
                    step_deg,
                    start_deg,
                    knots,
                    reference_c,
                    reference_s,
                    explanation: None,
                }
            })
            .collect();
        let rounds = d
            .rounds
            .iter()
            .map(|r| RoundReport {
                start_validation_rms_mm: r.start_rms_mm,
                candidates: r.screened.len(),
                p_threshold: r.threshold,
                screen_best: r
                    .screened
                    .iter()
                    .take(5)
                    .map(|s| Screened {
                        candidate: s.candidate.label(),
                        linearised_validation_rms_mm: s.linear_rms_mm,
                    })
                    .collect(),
                refitted: r
                    .tested
                    .iter()
                    .map(|t| Refitted {
                        candidate: t.candidate.label(),
                        validation_rms_mm: t.validation_rms_mm,
                        p_value: t.test.p,
                    })
                    .collect(),
                added: r
                    .chosen
                    .filter(|_| r.refused.is_none())
                    .map(|i| r.tested[i].candidate.label()),
                refused: r.refused.as_ref().and_then(|why| {
                    Some(Refused {
                        candidate: r.tested.get(r.chosen?)?.candidate.label(),
                        reason: why.clone(),
                    })
                }),
                seconds: r.seconds,
            })
            .collect();
        let fits = crate::diagnose::workflow::geometry_fits(d, stall_rms_mm);
        Self {
            baseline_validation_rms_mm: d.baseline_validation_rms_mm,
            found,
            final_validation_rms_mm: d.final_validation_rms_mm,
            noise_floor_mm: d.noise_floor_mm,
            noise_floor_source: match d.noise_source {
                NoiseSource::RepeatedPoses => "repeated poses",
                NoiseSource::HeldOut => "held-out errors of the final model less the fold fits' share, sum |r|^2 / (3n + sum tr B_f)",
            }
            .to_string(),
            noise_floor_interval_mm: d.noise_floor_interval_mm,
            noise_floor_dof: d.noise_dof,
            noise_sigma_mm: d.noise_sigma_mm,
            figures_include_orientations: d.orientations_weighted_in,
            figures_sigma_weighted: d.positions_weighted && !d.orientations_weighted_in,
            summary: summary(d),
            sentences: d
                .found
                .iter()
                .map(|f| f.sentence(&d.model, d.noise_floor_mm))
                .collect(),
            folds: d.folds.k,
            fit_rms_mm: d.fit_rms_mm,
            effective_parameters: d.effective_parameters,
            unidentifiable: d
                .unidentifiable
                .iter()
                .map(|p| p.name(&d.geometric).to_string())
                .collect(),
            // A refused geometric fit is why nothing was searched: said where scripts look.
            stop_reason: d.resized.as_ref().map_or_else(
                || d.stop_reason.clone(),
                |why| format!("the geometric fit {why}: nothing is diagnosed"),
            ),
            rounds,
            geometry_seconds: d.geometry_seconds,
            seconds: d.seconds,
            poses: d.folds.of.len(),
            converged: fits,
            resized: d.resized.clone(),
            unexplained: crate::diagnose::refusal::standing(
                &d.rounds,
                &d.found,
                d.final_validation_rms_mm,
            )
            .filter(|r| fits && r.blocks(d.final_validation_rms_mm))
            .map(|r| r.unexplained()),
            holdout: None,
            held_out_worse: None,
            acceptance: None,
            observations: None,
            out: None,
            plots: None,
            noise_source: d.noise_source,
            alpha: d.alpha,
        }
    }

    /// The report with every finding explained ([`crate::diagnose::explain`]) on `data`, the
    /// poses the search of `d` ran on (in its row order: pose numbers refer to it). Data of
    /// another length than the search's leave the findings unexplained.
    pub fn with_explanations<const N: usize>(
        mut self,
        d: &Diagnosis<N>,
        data: &[Measurement<f64, N>],
    ) -> Self {
        if data.len() == d.folds.of.len() {
            for (r, f) in self.found.iter_mut().zip(&d.found) {
                r.explanation = Some(explain(f, &d.model, data, d.noise_floor_mm));
            }
        }
        self
    }

    /// The report as `serde_json` sees it (what `--json` prints).
    pub fn to_value(&self) -> serde_json::Value {
        super::json_value(self)
    }
}

/// Above this knot spacing (degrees) of the finest joint table the search could offer, a
/// "nothing missing" headline says how coarse it was: gear and encoder tables repeat every few
/// degrees (the UR10 series' 3.6°), and 40 poses of an ER20 allowed no table finer than 34°, so a
/// table of 28 knots stayed in a "noise floor" of 0.49 mm (the tracker's was 0.017 mm).
pub const COARSE_TABLE_DEG: f64 = 5.0;

/// The clause a "nothing missing" headline ends with when the poses allowed no joint table
/// finer than [`COARSE_TABLE_DEG`] (four poses per knot interval): an error that changes over
/// less travel stays in the noise floor. Empty otherwise.
fn coarse_tables<const N: usize>(d: &Diagnosis<N>) -> String {
    let finest = d
        .rounds
        .iter()
        .flat_map(|r| &r.screened)
        .filter_map(|s| match s.candidate.kind {
            CandidateKind::Table { step, .. } => Some(step.to_degrees()),
            _ => None,
        })
        .fold(f64::INFINITY, f64::min);
    if d.rounds.is_empty() || finest <= COARSE_TABLE_DEG {
        return String::new();
    }
    let offered = if finest.is_finite() {
        format!(
            "the finest joint table these poses allow has knots every {}°",
            sig(finest, 3)
        )
    } else {
        "these poses allow no joint table".to_string()
    };
    format!(
        "; {offered} (four poses per knot interval): a joint error that changes over less \
         travel stays in the noise floor; more poses resolve it"
    )
}

/// What the search's figures are with 6-D rows (see [`Diagnosis::orientations_weighted_in`]).
pub const WEIGHTED_IN: &str = "per observation, the orientation's residual weighted in as the \
    point's mm: not position RMS, which `observations` gives";

/// What the search's figures are with σ that differ between the points' axes or rows.
pub const SIGMA_WEIGHTED: &str = "per point, weighted by the stated σ: not position RMS, which \
    `observations` gives";

/// What the search's figures are when they are no position RMS: with 6-D rows
/// (`orientations`), or σ that differ between the points' axes or rows (`sigma`).
pub fn weighting(orientations: bool, sigma: bool) -> Option<&'static str> {
    if orientations {
        Some(WEIGHTED_IN)
    } else if sigma {
        Some(SIGMA_WEIGHTED)
    } else {
        None
    }
}

/// The headline: what is missing, or that nothing is.
pub fn summary<const N: usize>(d: &Diagnosis<N>) -> String {
    let [base, fin, floor] = distinct_figures([
        d.baseline_validation_rms_mm,
        d.final_validation_rms_mm,
        d.noise_floor_mm,
    ]);
    let weighted = weighting(d.orientations_weighted_in, d.positions_weighted)
        .map_or(String::new(), |w| format!(" ({w})"));
    let floor = format!("{}{weighted}", floor_phrase(d.noise_floor_mm, &floor));
    // A significant finding refused (implausible, or a twin): said in the headline, never
    // "nothing significant is missing". The noise floor is left to its own line: the refusal
    // bounds it, and the headline would give the same figure twice.
    if let Some(r) =
        crate::diagnose::refusal::standing(&d.rounds, &d.found, d.final_validation_rms_mm)
    {
        let said = r.clause();
        return match d.found.len() {
            0 if r.twin.is_some() => format!(
                "No effect is named: the data cannot tell two causes apart; cross-validated \
                 RMS {base} mm{weighted}; {said}."
            ),
            0 => format!(
                "No plausible effect explains what the geometric model leaves: cross-validated \
                 RMS {base} mm{weighted}; {said}."
            ),
            n => format!(
                "{n} effect(s) missing from the model: cross-validated RMS {base} → {fin} \
                 mm{weighted}; {said}."
            ),
        };
    }
    if d.found.is_empty() {
        // Why nothing was added: the test found nothing, or the search did not get to test.
        let why = if d.rounds.is_empty() {
            format!("no candidate was tested: {}", d.stop_reason)
        } else {
            format!(
                "no candidate improved the held-out error at the {} % family-wise level",
                percent(d.alpha)
            )
        };
        format!(
            "Nothing significant is missing from the model: cross-validated RMS {base} mm, \
             {floor} ({why}){}.",
            coarse_tables(d)
        )
    } else {
        format!(
            "{} effect(s) missing from the model: cross-validated RMS {base} → {fin} mm, {floor}.",
            d.found.len(),
        )
    }
}

impl DiagnoseReport {
    /// Why nothing is diagnosed, or the diagnosis is no calibration, as the command's error
    /// line says it (exit 3); `None` when neither (the held-out verdict is told apart).
    pub fn error_line(&self, stall_rms_mm: f64) -> Option<String> {
        if let Some(why) = &self.resized {
            return Some(format!(
                "the geometric fit {why}; nothing is diagnosed (exit 3)"
            ));
        }
        if !self.converged {
            // A geometric model that cannot reach the data is not "missing an effect": the
            // data or the model are wrong, and a noise floor of metres is no finding.
            return Some(format!(
                "the geometric model does not fit the data (held-out RMS {} mm, above \
                 --stall-rms-mm {}): check the units (--length-unit, --angle-unit), coupled \
                 joints ([[couplings]], see `kinecal check`), the tool and the base; nothing is \
                 diagnosed (exit 3)",
                sig(self.baseline_validation_rms_mm, 4),
                sig(stall_rms_mm, 3)
            ));
        }
        self.unexplained
            .as_ref()
            .map(|u| format!("{u}; the model is no calibration of these data (exit 3)"))
    }
}

impl super::Report for DiagnoseReport {
    fn to_json(&self) -> serde_json::Value {
        super::with_accepted(self.to_value(), self)
    }
    fn converged(&self) -> bool {
        self.converged && self.held_out_worse != Some(true) && self.unexplained.is_none()
    }
    fn non_finite(&self) -> Option<String> {
        super::finite::first_non_finite(self)
    }
}

impl fmt::Display for DiagnoseReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} poses, {}-fold cross-validation",
            self.poses, self.folds
        )?;
        if let Some(why) = &self.resized {
            return writeln!(f, "The geometric fit {why}: nothing is diagnosed.");
        }
        if !self.converged {
            return writeln!(
                f,
                "The geometric model does not fit these data (held-out RMS {} mm): nothing can be \
                 diagnosed until the units, couplings, tool or base are right.",
                sig(self.baseline_validation_rms_mm, 4)
            );
        }
        writeln!(f, "{}", self.summary)?;
        for (k, s) in self.sentences.iter().enumerate() {
            match self.found.get(k).and_then(|e| e.explanation.as_ref()) {
                Some(e) => {
                    writeln!(f, "  {}. {}", k + 1, capitalised(&e.text))?;
                    writeln!(f, "     The search: {s}")?;
                }
                None => writeln!(f, "  {}. {s}", k + 1)?,
            }
        }
        if self.noise_floor_mm.is_finite() {
            let iv = self.noise_floor_interval_mm;
            let [floor, lo, hi] = distinct_figures([self.noise_floor_mm, iv[0], iv[1]]);
            let interval = if iv.iter().all(|x| x.is_finite()) && iv[0] < iv[1] {
                format!(" (approximately 95 % within {lo}–{hi} mm)")
            } else {
                String::new()
            };
            let source = match self.noise_source {
                NoiseSource::RepeatedPoses => "from the scatter of the repeated poses",
                NoiseSource::HeldOut => {
                    "from the held-out errors less what the fold fits add to them (it also holds whatever the model still misses)"
                }
            };
            let weighted = weighting(
                self.figures_include_orientations,
                self.figures_sigma_weighted,
            )
            .map_or(String::new(), |w| format!(" ({w})"));
            writeln!(f, "noise floor {floor} mm{interval}{weighted}, {source}")?;
        }
        for r in self.rounds.iter().filter_map(|r| r.refused.as_ref()) {
            writeln!(f, "refused: {} ({})", r.candidate, r.reason)?;
        }
        writeln!(f, "stopped: {}", self.stop_reason)?;
        if let Some(h) = &self.holdout {
            if let Some(w) = weighting(
                self.figures_include_orientations,
                self.figures_sigma_weighted,
            ) {
                writeln!(f, "held-out figures below: {w}")?;
            }
            if self.found.is_empty() {
                // One model: nothing was added to the starting model as refitted.
                writeln!(
                    f,
                    "held-out poses ({}), not searched: {} mm with the starting model refitted (nothing added)",
                    h.poses,
                    sig(h.geometric_rms_mm, 4)
                )?;
            } else {
                let [g, fin] = distinct_figures([h.geometric_rms_mm, h.final_rms_mm]);
                writeln!(
                    f,
                    "held-out poses ({}), not searched: starting model refitted {g} mm → extended model {fin} mm",
                    h.poses
                )?;
            }
            if h.noise_floor_capped {
                writeln!(
                    f,
                    "  (the noise floor above is lowered to the RMS these poses reached: their errors are the noise plus the model's, so the noise is no larger)"
                )?;
            }
        }
        if let Some(o) = &self.observations {
            writeln!(f, "{o}")?;
        }
        writeln!(f, "{:.2} s", self.seconds)
    }
}

impl fmt::Display for ObservationsReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut kinds = Vec::new();
        let o = &self.summary;
        if o.six_d {
            kinds.push("orientations".to_string());
        }
        if o.sigma {
            kinds.push("the stated σ".to_string());
        }
        if o.points > 1 {
            kinds.push(format!("{} reflectors", o.points));
        }
        write!(
            f,
            "fitted to all {} observations ({}): geometry {} mm → extended model {} mm",
            o.identification_observations,
            kinds.join(", "),
            sig(self.before.identification_rms_mm, 4),
            sig(self.after.identification_rms_mm, 4)
        )?;
        if let (Some(b), Some(a)) = (
            self.before.identification_rms_deg,
            self.after.identification_rms_deg,
        ) {
            write!(f, ", {}° → {}°", sig(b, 4), sig(a, 4))?;
        }
        if let (Some(b), Some(a)) = (self.before.validation_rms_mm, self.after.validation_rms_mm) {
            write!(f, "; held out {} mm → {} mm", sig(b, 4), sig(a, 4))?;
            if let (Some(b), Some(a)) = (
                self.before.validation_rms_deg,
                self.after.validation_rms_deg,
            ) {
                write!(f, ", {}° → {}°", sig(b, 4), sig(a, 4))?;
            }
        }
        if let Some(c) = self.chi2_per_dof {
            write!(f, "; χ²/dof {}", sig(c, 3))?;
        }
        Ok(())
    }
}

/// `text` with its first letter in upper case.
fn capitalised(text: &str) -> String {
    let mut c = text.chars();
    match c.next() {
        Some(first) => first.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}
