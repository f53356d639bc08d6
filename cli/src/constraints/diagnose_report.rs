//! The report of `diagnose` on a constraint file: the rounds of the search, what was found,
//! the groups' error before and after (cross-validated and held out), and its text.

use super::diagnose::Round;
use crate::output::numfmt::sig;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

/// The held-out groups' RMS (mm): the nominal robot, the geometric fit, the extended model.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct HeldOut {
    pub groups: usize,
    pub nominal_mm: f64,
    pub geometric_mm: f64,
    pub extended_mm: f64,
}

/// An effect found, in the order added.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FoundEffect {
    /// An id of docs/formats.md "Effects".
    pub effect: String,
    /// 1-based (thermal expansion, which acts on no joint, is listed on joint 1).
    pub joint: usize,
    /// The `--effect` request that adds it.
    pub request: String,
    /// Its values in the extended model (name → value).
    pub values: BTreeMap<String, f64>,
    /// The cross-validated RMS (mm) once it was added.
    pub validation_rms_mm: f64,
}

/// `diagnose` on a constraint file.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintDiagnoseReport {
    pub count_unit: String,
    pub n_identification: usize,
    pub n_validation: usize,
    pub folds: usize,
    /// What `baseline_validation_rms_mm` and `final_validation_rms_mm` are over: `held-out
    /// groups` when groups were held out, else `cross-validated groups`.
    pub validation: String,
    /// The geometric fit's and the extended model's RMS (mm) on those groups.
    pub baseline_validation_rms_mm: f64,
    pub final_validation_rms_mm: f64,
    /// What the rows' stated σ alone would leave in the same RMS sense (mm): a socket group
    /// `σ√(3(K−1)/K)`, a plane `σ√((K−3)/K)`, a distance `σ`, a point `σ√3`.
    pub noise_floor_mm: f64,
    /// Whether the file states σ (`sigma_mm`); else the floor is of the default σ.
    pub sigma_stated: bool,
    /// With stated σ: χ²/dof of the extended model fitted to every identification group
    /// (absent with fewer than 10 degrees of freedom).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2_per_dof: Option<f64>,
    /// What a wrong row may be in this session (the text's advice).
    #[serde(skip)]
    pub causes: String,
    /// Cross-validated RMS over the identification groups (mm), geometry alone and with what
    /// was found: each group against its own shape refitted to the model fitted without it.
    pub cv_rms_geometric_mm: f64,
    pub cv_rms_final_mm: f64,
    pub rounds: Vec<Round>,
    pub found: Vec<FoundEffect>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOut>,
    /// The extended model predicts the held-out groups worse than the geometric fit.
    pub held_out_worse: bool,
    /// Why the geometric fit is no calibration of these data (the arm stretched, a joint
    /// turned, a tool point misplaced, the constraints far from met), or absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resized: Option<String>,
    pub out: Option<String>,
}

impl ConstraintDiagnoseReport {
    /// χ²/dof of the extended model when the rows stay far from their constraints
    /// ([`crate::constraints::outliers::chi2_far`], above 1).
    fn unexplained_chi2(&self) -> Option<f64> {
        self.chi2_per_dof
            .filter(|c| *c > 1.0 && crate::constraints::outliers::chi2_far(*c))
    }
}

crate::reports::judged_report!(ConstraintDiagnoseReport, |r| !r.held_out_worse
    && r.resized.is_none());

impl fmt::Display for ConstraintDiagnoseReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} identification groups, {}-fold cross-validation: RMS {} mm with the geometry alone",
            self.n_identification,
            self.folds,
            sig(self.cv_rms_geometric_mm, 4)
        )?;
        for r in &self.rounds {
            writeln!(
                f,
                "  {} {} ({}): cross-validated RMS {} -> {} mm, p = {} (needs < {})",
                if r.accepted {
                    "found"
                } else {
                    "best, not taken:"
                },
                r.effect,
                r.label,
                sig(r.cv_rms_before_mm, 4),
                sig(r.cv_rms_after_mm, 4),
                sig(r.p, 2),
                sig(r.threshold, 2)
            )?;
            if let Some(why) = &r.implausible {
                writeln!(f, "    refused: {why}")?;
            }
        }
        writeln!(
            f,
            "noise floor of the {} σ: {} mm",
            if self.sigma_stated {
                "stated"
            } else {
                "default (no sigma_mm given)"
            },
            sig(self.noise_floor_mm, 4)
        )?;
        if self.rounds.iter().any(|r| r.implausible.is_some()) {
            writeln!(
                f,
                "an effect would fit, but its size is no arm's (refused above): check the column \
                 it reads before calibrating with it"
            )?;
        } else if let Some(c) = self.unexplained_chi2() {
            writeln!(
                f,
                "the rows are {}× farther from their constraints than the stated σ explain \
                 (χ²/dof {}{}), and no effect of the catalogue explains {}: check the rows \
                 ({}), then sigma_mm",
                sig(c.sqrt(), 3),
                sig(c, 3),
                if self.found.is_empty() {
                    ""
                } else {
                    " with what was found"
                },
                if self.found.is_empty() {
                    "it"
                } else {
                    "the rest"
                },
                self.causes
            )?;
        } else if self.found.is_empty() {
            writeln!(f, "nothing significant is missing from the geometry")?;
        }
        if let Some(h) = &self.held_out {
            writeln!(
                f,
                "{} held-out groups: RMS {} mm nominal, {} mm geometric, {} mm with what was found",
                h.groups,
                sig(h.nominal_mm, 4),
                sig(h.geometric_mm, 4),
                sig(h.extended_mm, 4)
            )?;
        }
        if let Some(o) = &self.out {
            writeln!(f, "model written to {o}")?;
        }
        Ok(())
    }
}
