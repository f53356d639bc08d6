//! The calibration report of a constraint session (`kinecal report` on a constraint file):
//! the nominal robot and the calibrated model on the same groups, split as `identify` split
//! them (whole groups held out by its rule and seed), per kind, with the shapes the model fits,
//! the parameters it changed and what these constraints cannot determine; one self-contained
//! HTML page ([`crate::report_html::constraint_page`]) and its figures as a summary.

use super::constraints::{constraints, measurements, residuals, split_groups};
use crate::calibration::acceptance::{judge, Acceptance};
use crate::calibration::inputs::HoldoutArgs;
use crate::calibration::Residuals;
use crate::constraints::fit::shapes_of;
use crate::constraints::read::{by_kind, Group, Session};
use crate::constraints::report::Constraints;
use crate::constraints::shapes::{errors, held_out_error, points, rms};
use crate::formats::robot_file::RobotFile;
use crate::output::numfmt::sig;
use crate::HostRobot;
use serde::Serialize;
use std::fmt;
use std::time::Instant;

/// What the report reads: the robot file and its nominal model, the calibrated model, the
/// session, and how the page names its sources (label, value).
pub struct Inputs<const N: usize> {
    pub file: RobotFile,
    pub nominal: HostRobot<N>,
    pub model: HostRobot<N>,
    pub session: Session<N>,
    pub data_origin: String,
    pub sources: Vec<(String, String)>,
}

/// How the groups were split (as given to `identify`) and when a model is no calibration.
pub struct Options {
    pub holdout: HoldoutArgs,
    pub seed: u64,
    /// A model that misses the identification rows by more than this RMS (mm) is not a
    /// calibration of these data.
    pub stall_rms_mm: f64,
}

/// One kind of constraint among the held-out groups: each group against its own refitted
/// shape (a distance's length error), RMS over the groups.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct HeldOutKind {
    pub kind: String,
    pub groups: usize,
    pub before_rms_mm: f64,
    pub after_rms_mm: f64,
}

/// A parameter the model changed: its value in the robot file and in the model (mm or
/// degrees; an effect's value in its own unit).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Change {
    pub name: String,
    pub unit: String,
    pub nominal: f64,
    pub model: f64,
}

/// `kinecal report` on a constraint file: what the page shows.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintReportSummary {
    /// The page written.
    pub out: Option<String>,
    pub bytes: usize,
    pub seconds: f64,
    pub count_unit: String,
    pub n_identification: usize,
    pub n_validation: usize,
    pub n_identification_rows: usize,
    pub n_validation_rows: usize,
    /// The nominal robot and the model, by `identify`'s keys on a constraint file.
    pub before: Residuals,
    pub after: Residuals,
    /// Per kind on the identification groups, and the shapes the model fits to them.
    pub constraints: Constraints,
    /// Per kind on the held-out groups.
    pub held_out: Vec<HeldOutKind>,
    pub changed: Vec<Change>,
    /// What these identification groups cannot determine at the nominal model (held by
    /// `identify`).
    pub cannot_determine: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acceptance: Option<Acceptance>,
    /// The model predicts the held-out groups worse than the nominal robot.
    pub held_out_worse: Option<bool>,
    /// The model is a calibration of these data (`false`: exit 3).
    pub converged: bool,
    pub figures: usize,
}

/// The page and its summary.
pub struct Built {
    pub html: String,
    pub summary: ConstraintReportSummary,
}

/// Judges `inputs.model` against the nominal robot on the session and renders the page.
pub fn report<const N: usize>(options: &Options, inputs: Inputs<N>) -> anyhow::Result<Built> {
    let t0 = Instant::now();
    let Inputs {
        file,
        nominal,
        model,
        session,
        data_origin,
        sources,
    } = inputs;
    crate::constraints::shapes::check_lengths(&nominal, &session.groups, &data_origin)?;
    let (ident, valid) = split_groups(session, &options.holdout, options.seed)?;
    if ident.is_empty() {
        crate::refuse!("--holdout leaves no groups to identify from: hold out fewer");
    }
    let (before_shapes, after_shapes) = (shapes_of(&nominal, &ident), shapes_of(&model, &ident));
    let before = residuals(&nominal, &ident, &before_shapes, &valid);
    let after = residuals(&model, &ident, &after_shapes, &valid);
    let acceptance = judge(
        (
            before.validation_rms_mm,
            after.validation_rms_mm,
            after.identification_rms_mm,
        ),
        &measurements(&ident),
        &measurements(&valid),
        Vec::new(),
    );
    let held_out_worse = acceptance.as_ref().map(|a| a.held_out_worse);
    let checked = crate::constraints::check::check(
        &file,
        &nominal,
        &Session {
            groups: ident.clone(),
        },
        &data_origin,
    )?;
    let row_errors = |robot: &HostRobot<N>, shapes: &[crate::constraints::shapes::Shape]| {
        ident
            .iter()
            .zip(shapes)
            .flat_map(|(g, s)| errors(g, &points(robot, g), s))
            .map(f64::abs)
            .collect::<Vec<f64>>()
    };
    let (e_before, e_after) = (
        row_errors(&nominal, &before_shapes),
        row_errors(&model, &after_shapes),
    );
    let mut summary = ConstraintReportSummary {
        out: None,
        bytes: 0,
        seconds: 0.0,
        count_unit: "groups".into(),
        n_identification: ident.len(),
        n_validation: valid.len(),
        n_identification_rows: ident.iter().map(|g| g.rows.len()).sum(),
        n_validation_rows: valid.iter().map(|g| g.rows.len()).sum(),
        converged: after.identification_rms_mm <= options.stall_rms_mm
            && held_out_worse != Some(true),
        before,
        after,
        constraints: constraints(&ident, (&nominal, &before_shapes), (&model, &after_shapes)),
        held_out: held_out_kinds(&nominal, &model, &valid),
        changed: changes(&file, &nominal, &model),
        cannot_determine: checked.cannot_determine,
        acceptance,
        held_out_worse,
        figures: 1,
    };
    let html = crate::report_html::constraint_page::render(
        &file.name,
        &sources,
        &summary,
        (&e_before, &e_after),
    )?;
    summary.bytes = html.len();
    summary.seconds = t0.elapsed().as_secs_f64();
    Ok(Built { html, summary })
}

/// Per kind of the held-out groups: RMS of the groups' errors for the nominal robot and the
/// model.
fn held_out_kinds<const N: usize>(
    nominal: &HostRobot<N>,
    model: &HostRobot<N>,
    valid: &[Group<N>],
) -> Vec<HeldOutKind> {
    by_kind(valid)
        .into_iter()
        .map(|(kind, of)| {
            let e = |r: &HostRobot<N>| {
                rms(&of
                    .iter()
                    .map(|&k| held_out_error(r, &valid[k]))
                    .collect::<Vec<f64>>())
            };
            HeldOutKind {
                kind: kind.id().into(),
                groups: of.len(),
                before_rms_mm: e(nominal),
                after_rms_mm: e(model),
            }
        })
        .collect()
}

/// The model's parameters whose value differs from the robot file's.
fn changes<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    model: &HostRobot<N>,
) -> Vec<Change> {
    crate::calibration::model_params(model, &file.tilt_joints())
        .into_iter()
        .filter_map(|p| {
            let (a, b) = (
                kinecal::model::param::value(nominal, p)?,
                kinecal::model::param::value(model, p)?,
            );
            let (unit, k) = match p {
                kinecal::Param::Effect(_) => ("", 1.0),
                _ if p.is_length() => ("mm", 1.0),
                _ => ("deg", 180.0 / std::f64::consts::PI),
            };
            (a != b).then(|| Change {
                name: p.name(model).to_string(),
                unit: unit.into(),
                nominal: a * k,
                model: b * k,
            })
        })
        .collect()
}

impl crate::reports::Report for ConstraintReportSummary {
    fn to_json(&self) -> serde_json::Value {
        crate::reports::json_value(self)
    }
    fn converged(&self) -> bool {
        self.converged
    }
    fn non_finite(&self) -> Option<String> {
        crate::reports::finite::first_non_finite(self)
    }
}

impl fmt::Display for ConstraintReportSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(out) = &self.out {
            writeln!(f, "wrote {out} ({} bytes)", self.bytes)?;
        }
        writeln!(
            f,
            "{} identification groups ({} rows): RMS {} -> {} mm",
            self.n_identification,
            self.n_identification_rows,
            sig(self.before.identification_rms_mm, 4),
            sig(self.after.identification_rms_mm, 4)
        )?;
        if let (Some(b), Some(a)) = (self.before.validation_rms_mm, self.after.validation_rms_mm) {
            writeln!(
                f,
                "{} held-out groups ({} rows): RMS {} -> {} mm",
                self.n_validation,
                self.n_validation_rows,
                sig(b, 4),
                sig(a, 4)
            )?;
        }
        if let Some(a) = &self.acceptance {
            if let Some(m) = &a.message {
                writeln!(f, "{m}")?;
            }
        }
        Ok(())
    }
}
