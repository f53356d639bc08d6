//! A finding refused (as implausible, or as the twin of another cause) that the data still
//! need.
//!
//! A refused candidate passed the paired test and the margin: the held-out errors it left are
//! real errors the model does not describe, not noise. When no later effect of its family (nor
//! of its twin's) was added and it reached less than the final model does, the refusal stands;
//! its cross-validated RMS then bounds the noise floor (a floor that a model reaches on poses
//! it did not see is no floor), and when it would have left less than
//! [`BLOCKS`] of what the final model leaves, what the model lacks is larger than what it
//! found: a joint read with the wrong sign or unit (a table of 371° on a joint whose sign is
//! flipped), a tracker moved during the session, a `temp_c` column that is not the arm's. Such
//! a diagnosis is no calibration (exit 3, docs/formats.md "Command line: exit status and JSON").

use super::candidates::{Candidate, CandidateKind};
use super::{Found, Round};
use crate::output::numfmt::sig;

/// A standing refusal whose held-out RMS is below this share of the final model's blocks the
/// diagnosis (1/√2: it would halve the mean squared error the final model leaves).
pub const BLOCKS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// A refused candidate no later effect of its family replaced.
#[derive(Clone, Debug, PartialEq)]
pub struct Standing {
    pub candidate: Candidate,
    /// Why it was refused ([`super::plausibility::implausible`], [`super::choice::twin_reason`]).
    pub reason: String,
    /// The twin it could not be told from, when that is why it was refused.
    pub twin: Option<Candidate>,
    /// Cross-validated RMS of the model it was tested against, and with it (mm).
    pub before_rms_mm: f64,
    pub validation_rms_mm: f64,
}

/// The standing refusal with the lowest cross-validated RMS, if any: refused in `rounds`, no
/// effect of its family or its twin's among `found`, and below `final_rms_mm`, what the final
/// model reaches (one that reached more was replaced by what was found since).
pub fn standing<const N: usize>(
    rounds: &[Round],
    found: &[Found<N>],
    final_rms_mm: f64,
) -> Option<Standing> {
    let replaced = |c: &Candidate| found.iter().any(|f| f.candidate.same_effect(c));
    rounds
        .iter()
        .filter_map(|r| {
            let t = r.tested.get(r.chosen?)?;
            Some(Standing {
                candidate: t.candidate,
                reason: r.refused.clone()?,
                twin: r.twin.and_then(|j| r.tested.get(j)).map(|t| t.candidate),
                before_rms_mm: r.start_rms_mm,
                validation_rms_mm: t.validation_rms_mm,
            })
        })
        .filter(|s| !replaced(&s.candidate) && !s.twin.as_ref().is_some_and(replaced))
        .filter(|s| s.validation_rms_mm < final_rms_mm)
        .min_by(|a, b| a.validation_rms_mm.total_cmp(&b.validation_rms_mm))
}

/// The lowest cross-validated RMS a standing refusal reached (infinite without one).
pub fn least_rms<const N: usize>(rounds: &[Round], found: &[Found<N>], final_rms_mm: f64) -> f64 {
    standing(rounds, found, final_rms_mm).map_or(f64::INFINITY, |s| s.validation_rms_mm)
}

impl Standing {
    /// Whether it blocks a diagnosis whose final model leaves `final_rms_mm` ([`BLOCKS`]).
    pub fn blocks(&self, final_rms_mm: f64) -> bool {
        self.validation_rms_mm < BLOCKS * final_rms_mm
    }

    /// What the headline says of it: the cross-validated RMS it would reach.
    pub fn clause(&self) -> String {
        format!(
            "{} would lower it to {} mm but is refused, as said below",
            self.candidate.label(),
            sig(self.validation_rms_mm, 4)
        )
    }

    /// Why the diagnosis is no calibration when it [`Self::blocks`], and what to check.
    pub fn unexplained(&self) -> String {
        let check = if self.twin.is_some() {
            "measure poses spread over the workspace, or hold the temperature, to tell them \
             apart"
                .to_string()
        } else {
            match self.candidate.kind {
                CandidateKind::Table { .. }
                | CandidateKind::Cyclic(_)
                | CandidateKind::Scale
                | CandidateKind::Compliance => format!(
                    "joint {}'s readings do not follow the robot file: check their sign, unit \
                     and zero (kinecal check), and that the set-up did not move",
                    self.candidate.joint + 1
                ),
                CandidateKind::Tilt => "the data do not follow the robot file's axes: check \
                     the joints' order and signs (kinecal check)"
                    .to_string(),
                CandidateKind::Thermal { .. } => {
                    "check that temp_c is the arm's temperature in °C".to_string()
                }
                CandidateKind::Drift { .. } => {
                    "split the file where the set-up moved, or check that t_s is in seconds"
                        .to_string()
                }
            }
        };
        format!(
            "what the model leaves is no noise: {} would lower the cross-validated RMS from {} \
             to {} mm but is refused ({}); {check}",
            self.candidate.label(),
            sig(self.before_rms_mm, 4),
            sig(self.validation_rms_mm, 4),
            self.reason
        )
    }
}
