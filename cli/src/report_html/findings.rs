//! The findings of `kinecal diagnose --json` read back for the report, with the figures that
//! show them: each correction against its joint angle over the data's range (drawn with
//! [`crate::diagnose::explain::curve`], as `diagnose --plots` draws it) and the held-out RMS
//! as the effects were added.

use crate::diagnose::candidates::{Candidate, CandidateKind};
use crate::diagnose::explain::curve;
use crate::output::numfmt::sig;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The keys of a diagnose report this page shows (docs/formats.md "Command line: exit status and JSON").
#[derive(Clone, Debug, Deserialize)]
pub struct DiagnoseJson {
    pub baseline_validation_rms_mm: f64,
    pub found: Vec<FoundJson>,
    pub final_validation_rms_mm: f64,
    pub noise_floor_mm: f64,
    #[serde(default)]
    pub summary: String,
    #[serde(default)]
    pub poses: Option<usize>,
}

/// One effect found.
#[derive(Clone, Debug, Deserialize)]
pub struct FoundJson {
    pub effect: String,
    /// 1-based.
    pub joint: usize,
    pub values: Vec<f64>,
    pub validation_rms_mm: f64,
    #[serde(default)]
    pub p_value: Option<f64>,
    #[serde(default)]
    pub sentence: String,
    #[serde(default)]
    pub order: Option<u16>,
    #[serde(default)]
    pub step_deg: Option<f64>,
    #[serde(default)]
    pub start_deg: Option<f64>,
    #[serde(default)]
    pub knots: Option<usize>,
    /// Thermal-expansion: the reference temperature (°C).
    #[serde(default)]
    pub reference_c: Option<f64>,
    /// Base-drift: the reference time (s).
    #[serde(default)]
    pub reference_s: Option<f64>,
}

/// A finding as the page shows it.
#[derive(Clone, Debug, Serialize)]
pub struct Finding {
    pub effect: String,
    pub joint: usize,
    pub sentence: String,
    pub validation_rms_mm: String,
    pub p_value: String,
    /// The correction against the joint angle (SVG), when the effect has one in `q`
    /// (inlined by the template module, not serialised).
    #[serde(skip)]
    pub svg: Option<String>,
}

/// The diagnose section: the headline, the findings and the held-out RMS figure.
#[derive(Clone, Debug, Serialize)]
pub struct Findings {
    pub source: String,
    pub summary: String,
    pub baseline_validation_rms_mm: String,
    pub final_validation_rms_mm: String,
    pub noise_floor_mm: String,
    pub found: Vec<Finding>,
    /// Held-out RMS per effect added (SVG; inlined by the template module).
    #[serde(skip)]
    pub svg: Option<String>,
}

/// Reads a diagnose JSON file; refuses (exit 2) what is not one.
pub fn load(path: &Path) -> anyhow::Result<DiagnoseJson> {
    let text = crate::formats::read_text_limited(
        path,
        crate::formats::MAX_SMALL_FILE,
        "the JSON of `kinecal diagnose --json`",
    )?;
    let d: DiagnoseJson = serde_json::from_str(&text).map_err(|e| {
        crate::refused(format!(
            "{}: not the JSON of `kinecal diagnose --json` ({e}): give the file that \
             `kinecal diagnose … --json > J.json` wrote",
            path.display()
        ))
    })?;
    // A model holds at most MAX_EFFECTS effects, so diagnose never finds more: a longer list
    // is no diagnose report (and 20,000 of them would make a page of hundreds of megabytes).
    if d.found.len() > kinecal::model::effects::MAX_EFFECTS {
        crate::refuse!(
            "{}: {} findings, more than a model holds ({}): give the file that `kinecal \
             diagnose … --json > J.json` wrote",
            path.display(),
            d.found.len(),
            kinecal::model::effects::MAX_EFFECTS
        );
    }
    // Figures out of any calibration's range (±1e308) would make the figures' axes overflow.
    let rms = [
        ("baseline_validation_rms_mm", d.baseline_validation_rms_mm),
        ("final_validation_rms_mm", d.final_validation_rms_mm),
        ("noise_floor_mm", d.noise_floor_mm),
    ]
    .into_iter()
    .chain(
        d.found
            .iter()
            .map(|f| ("validation_rms_mm", f.validation_rms_mm)),
    );
    for (key, v) in rms {
        if !(v.is_finite() && v.abs() <= MAX_MM) {
            crate::refuse!(
                "{}: {key} = {v} is out of any calibration's range (|x| ≤ {MAX_MM} mm): give \
                 the file that `kinecal diagnose … --json > J.json` wrote",
                path.display()
            );
        }
    }
    for f in &d.found {
        let huge = f
            .values
            .iter()
            .copied()
            .find(|v| !v.is_finite() || v.abs() > MAX_VALUE);
        let step = [f.start_deg, f.step_deg]
            .into_iter()
            .flatten()
            .find(|v| !v.is_finite() || v.abs() > MAX_VALUE);
        if let Some(v) = huge.or(step) {
            crate::refuse!(
                "{}: the {} finding on joint {} has the value {v}, out of any correction's \
                 range (|x| ≤ {MAX_VALUE}): give the file that `kinecal diagnose … --json > \
                 J.json` wrote",
                path.display(),
                f.effect,
                f.joint
            );
        }
    }
    Ok(d)
}

/// Largest RMS or noise floor accepted, millimetres (a kilometre: far beyond any arm).
const MAX_MM: f64 = 1e6;

/// Largest finding value (or table start and step) accepted: corrections are radians,
/// millimetres or ratios, far below this.
const MAX_VALUE: f64 = 1e6;

/// The candidate of a finding, checked against a robot of `joints` joints (refused, exit 2,
/// when it does not fit).
fn candidate(f: &FoundJson, joints: usize, origin: &str) -> anyhow::Result<Candidate> {
    if f.effect == "thermal-expansion" {
        let reference = f.reference_c.filter(|t| t.is_finite()).unwrap_or(20.0);
        if f.values.len() != 1 {
            crate::refuse!("{origin}: the thermal-expansion finding needs 1 value");
        }
        return Ok(Candidate {
            kind: CandidateKind::Thermal { reference },
            joint: 0,
        });
    }
    if f.effect == "base-drift" {
        let reference = f.reference_s.filter(|t| t.is_finite()).unwrap_or(0.0);
        if f.values.len() != 3 {
            crate::refuse!("{origin}: the base-drift finding needs 3 values");
        }
        return Ok(Candidate {
            kind: CandidateKind::Drift { reference },
            joint: 0,
        });
    }
    if !(1..=joints).contains(&f.joint) {
        crate::refuse!(
            "{origin}: a finding on joint {} of a robot with {joints} joints: give the diagnose \
             JSON of this robot's data",
            f.joint
        );
    }
    let kind = match f.effect.as_str() {
        "joint-compliance" => CandidateKind::Compliance,
        "joint-scale" => CandidateKind::Scale,
        "axis-tilt" => CandidateKind::Tilt,
        "joint-cyclic" => CandidateKind::Cyclic(f.order.unwrap_or(1).max(1)),
        "joint-table" => match (f.start_deg, f.step_deg, f.knots) {
            (Some(a), Some(s), Some(k)) if a.is_finite() && s.is_finite() && s > 0.0 => {
                CandidateKind::Table {
                    start: a.to_radians(),
                    step: s.to_radians(),
                    knots: k,
                }
            }
            _ => crate::refuse!(
                "{origin}: the joint-table finding on joint {} lacks start_deg, step_deg or knots",
                f.joint
            ),
        },
        other => crate::refuse!("{origin}: unknown effect '{other}' in `found`"),
    };
    let need = match kind {
        CandidateKind::Cyclic(_) => 2,
        CandidateKind::Table { knots, .. } => knots,
        _ => 1,
    };
    if f.values.len() < need || f.values.iter().any(|v| !v.is_finite()) {
        crate::refuse!(
            "{origin}: the {} finding on joint {} has {} values, needs {need} finite ones",
            f.effect,
            f.joint,
            f.values.len()
        );
    }
    Ok(Candidate {
        kind,
        joint: f.joint - 1,
    })
}

/// The page's diagnose section for `d` (read from `origin`), with corrections drawn over
/// `q_range_deg[j]`, the range of joint j in the report's data.
pub fn findings(
    d: &DiagnoseJson,
    origin: &str,
    q_range_deg: &[(f64, f64)],
) -> anyhow::Result<Findings> {
    let mut found = Vec::new();
    for f in &d.found {
        let c = candidate(f, q_range_deg.len(), origin)?;
        let (lo, hi) = q_range_deg[c.joint];
        let pts: Vec<(f64, f64)> = curve(&c, &f.values, lo.to_radians(), hi.to_radians())
            .into_iter()
            .map(|(q, dq)| (q.to_degrees(), dq.to_degrees()))
            .collect();
        let svg = if pts.len() > 1 {
            Some(super::plots::lines(
                &format!("{} on joint {}", f.effect, f.joint),
                &format!("q{} (°)", f.joint),
                "correction (°)",
                &[("correction".to_string(), pts)],
            )?)
        } else {
            None
        };
        found.push(Finding {
            effect: f.effect.clone(),
            joint: f.joint,
            sentence: f.sentence.clone(),
            validation_rms_mm: sig(f.validation_rms_mm, 4),
            p_value: f.p_value.map_or("-".into(), |p| sig(p, 2)),
            svg,
        });
    }
    let steps: Vec<(f64, f64)> = std::iter::once(d.baseline_validation_rms_mm)
        .chain(d.found.iter().map(|f| f.validation_rms_mm))
        .enumerate()
        .map(|(k, v)| (k as f64, v))
        .collect();
    let svg = if steps.len() > 1 {
        let floor = vec![
            (0.0, d.noise_floor_mm),
            ((steps.len() - 1) as f64, d.noise_floor_mm),
        ];
        Some(super::plots::lines(
            "held-out RMS as effects are added",
            "effects added",
            "held-out RMS (mm)",
            &[
                ("model".to_string(), steps),
                ("noise floor".to_string(), floor),
            ],
        )?)
    } else {
        None
    };
    Ok(Findings {
        source: origin.to_string(),
        summary: d.summary.clone(),
        baseline_validation_rms_mm: sig(d.baseline_validation_rms_mm, 4),
        final_validation_rms_mm: sig(d.final_validation_rms_mm, 4),
        noise_floor_mm: sig(d.noise_floor_mm, 3),
        found,
        svg,
    })
}
