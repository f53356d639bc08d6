//! The JSON of `kinecal validate --json` read back for the report (`report --validate-json
//! V.json`): the model and the nominal robot on another session, both registered the same
//! way, and the verdict (docs/formats.md, "Validation on another session").

use super::page::{Cell, Validation, ValidationRow};
use crate::output::numfmt::sig;
use crate::reports::validate::{Figures, ValidateReport};
use std::path::Path;

/// Reads a validate JSON file; refuses (exit 2) what is not one.
pub fn load(path: &Path) -> anyhow::Result<ValidateReport> {
    let text = crate::formats::read_text_limited(
        path,
        crate::formats::MAX_SMALL_FILE,
        "the JSON of `kinecal validate --json`",
    )?;
    serde_json::from_str(&text).map_err(|e| {
        crate::refused(format!(
            "{}: not the JSON of `kinecal validate --json` ({e}): give the file that \
             `kinecal validate … --json > V.json` wrote",
            path.display()
        ))
    })
}

/// The keys of a row's cells (`validate.<model|nominal>.<key>`), in the table's order.
pub const KEYS: [&str; 8] = [
    "rms", "mean", "max", "p95", "rms_x", "rms_y", "rms_z", "rms_deg",
];

fn row(model: &str, f: &Figures) -> ValidationRow {
    let values = [
        Some(f.rms_mm),
        Some(f.mean_mm),
        Some(f.max_mm),
        Some(f.p95_mm),
        Some(f.rms_x_mm),
        Some(f.rms_y_mm),
        Some(f.rms_z_mm),
        f.rms_deg,
    ];
    ValidationRow {
        model: model.into(),
        cells: KEYS
            .iter()
            .zip(values)
            .map(|(k, v)| Cell {
                key: format!("validate.{model}.{k}"),
                text: v.map_or("-".into(), |v| sig(v, 4)),
            })
            .collect(),
    }
}

/// The section of `v`, read from `origin`.
pub fn section(v: &ValidateReport, origin: &str) -> Validation {
    let cell = |key: String, v: f64| Cell {
        key,
        text: sig(v, 4),
    };
    Validation {
        source: origin.to_string(),
        data_file: v.data_file.clone(),
        model_file: v.model_file.clone(),
        register: v.register.clone(),
        registered: if v.registered.is_empty() {
            "nothing".into()
        } else {
            v.registered.join(", ")
        },
        poses: v.poses,
        worse_than_nominal: v.worse_than_nominal
            || v.data_mismatch
            || v.changed_since_calibration
            || !v.gross_outliers.is_empty()
            || v.wrapped_readings.is_some(),
        data_mismatch: v.data_mismatch,
        other_verdict: v.data_mismatch
            || v.changed_since_calibration
            || !v.gross_outliers.is_empty()
            || v.wrapped_readings.is_some(),
        verdict: v.verdict.clone(),
        rows: vec![row("model", &v.model), row("nominal", &v.nominal)],
        points: v
            .per_point
            .iter()
            .map(|(name, p)| {
                [
                    Cell {
                        key: format!("validate.point.{name}"),
                        text: name.clone(),
                    },
                    cell(format!("validate.point.{name}.model.rms"), p.model.rms_mm),
                    cell(
                        format!("validate.point.{name}.nominal.rms"),
                        p.nominal.rms_mm,
                    ),
                ]
            })
            .collect(),
    }
}
