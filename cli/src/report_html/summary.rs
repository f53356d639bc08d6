//! The summary of `kinecal report` (a [`crate::reports::Report`]): the figures of the HTML page it wrote, as one JSON object
//! (`--json`) or a few lines of text.

use super::iso9283::Accuracy;
use super::params::ParamRow;
use super::stats::SetFigures;
use crate::calibration::{Correlation, Residuals};
use crate::output::numfmt::sig;
use crate::reports::identify::PointResiduals;
use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};
use std::collections::BTreeMap;
use std::fmt;

/// `kinecal report`: what the page shows, by the keys of `identify` where they are the same.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReportSummary {
    /// The page written.
    pub out: Option<String>,
    /// Its size (bytes).
    pub bytes: usize,
    /// Time to compute and render it.
    pub seconds: f64,
    pub n_identification: usize,
    pub n_validation: usize,
    /// Nominal and identified model as `identify` reports them (same keys and values).
    pub before: Residuals,
    pub after: Residuals,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_point: Option<BTreeMap<String, PointResiduals>>,
    /// Per axis and total, per set.
    pub sets: Vec<SetSummary>,
    /// ISO 9283 figures by key (`iso.identification.before`, …: set, and the model that
    /// commands: before = nominal, after = calibrated).
    pub iso9283: BTreeMap<String, Accuracy>,
    /// Every parameter of the model (JSON: name → row).
    #[serde(serialize_with = "rows_by_name")]
    pub parameters: Vec<ParamRow>,
    pub correlations: Vec<Correlation>,
    /// Largest distance (mm) at the identification poses between the points predicted by
    /// identify's fit from the robot file (whose 1-σ the table shows) and by the model.
    pub refit_max_mm: f64,
    /// Diagnose findings shown.
    pub findings: usize,
    /// Figures on the page.
    pub figures: usize,
    /// The model is a calibration of these data (`false`: exit 3): it fits the identification
    /// poses, predicts the held-out ones no worse than the nominal robot, and holds on the
    /// session of `--validate-json`.
    pub converged: bool,
    /// The page's verdict: "calibrated", or why not.
    pub verdict: String,
}

/// Both models on one set of observations.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SetSummary {
    /// `identification` or `validation`.
    pub set: String,
    pub observations: usize,
    pub before: SetFigures,
    pub after: SetFigures,
}

fn rows_by_name<S: Serializer>(rows: &[ParamRow], s: S) -> Result<S::Ok, S::Error> {
    let mut m = s.serialize_map(Some(rows.len()))?;
    for r in rows {
        m.serialize_entry(&r.name, r)?;
    }
    m.end()
}

impl ReportSummary {
    /// The line on stderr of a page whose verdict is not "calibrated" (exit 3): the model
    /// (`model`), the verdict and its identification RMS.
    pub fn error_line(&self, model: &std::path::Path) -> String {
        format!(
            "error: {}: {} (identification RMS {} mm; exit 3, the page says so)",
            model.display(),
            self.verdict,
            crate::output::numfmt::sig(self.after.identification_rms_mm, 4)
        )
    }
}

impl crate::reports::Report for ReportSummary {
    fn to_json(&self) -> serde_json::Value {
        crate::reports::with_accepted(crate::reports::json_value(self), self)
    }
    fn converged(&self) -> bool {
        self.converged
    }
    fn non_finite(&self) -> Option<String> {
        crate::reports::finite::first_non_finite(self)
    }
}

impl fmt::Display for ReportSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let g = |v: Option<f64>| v.map_or("-".to_string(), |x| sig(x, 4));
        writeln!(
            f,
            "{} identification poses, {} held out; RMS before {} / {} mm, after {} / {} mm \
             (identification / held out)",
            self.n_identification,
            self.n_validation,
            g(Some(self.before.identification_rms_mm)),
            g(self.before.validation_rms_mm),
            g(Some(self.after.identification_rms_mm)),
            g(self.after.validation_rms_mm),
        )?;
        let held = self
            .parameters
            .iter()
            .filter(|p| matches!(p.status, super::params::Status::Held { .. }))
            .count();
        writeln!(
            f,
            "{} parameters ({held} held at nominal), {} findings, {} figures",
            self.parameters.len(),
            self.findings,
            self.figures
        )?;
        if let Some(out) = &self.out {
            writeln!(
                f,
                "wrote {out} ({} KB in {} s)",
                sig(self.bytes as f64 / 1000.0, 3),
                sig(self.seconds, 2)
            )?;
        }
        Ok(())
    }
}
