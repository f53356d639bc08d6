//! The calibration report of a constraint session (`kinecal report` on a constraint file):
//! the nominal robot and the calibrated model on the same groups, split as `identify` split
//! them (whole groups held out by its rule and seed), per kind, with the shapes the model fits,
//! the parameters it changed and what these constraints cannot determine; one self-contained
//! HTML page ([`crate::report_html::constraint_page`]) and its figures as a summary.

use super::constraints::{constraints, judge_groups, residuals, split_groups};
use crate::calibration::inputs::HoldoutArgs;
use crate::calibration::stats::rms;
use crate::constraints::fit::shapes_of;
use crate::constraints::read::{by_kind, Group, Session};
use crate::constraints::report::{Change, ConstraintReportSummary, HeldOutKind};
use crate::constraints::shapes::{errors, held_out_error, points};
use crate::formats::robot_file::RobotFile;
use crate::HostRobot;
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
    let acceptance = judge_groups(&before, &after, &ident, &valid, Vec::new());
    let held_out_worse = acceptance.as_ref().map(|a| a.held_out_worse);
    let checked = crate::constraints::check::check(
        &file,
        &nominal,
        &Session {
            groups: ident.clone(),
            ..Session::default()
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
    // The file's tilts and those the model carries (a tilt the fit estimated: `--effect
    // axis-tilt`).
    let tilted: Vec<kinecal::Param> = (0..N)
        .filter(|&j| model.joints()[j].beta != 0.0)
        .map(|j| kinecal::Param::Beta(j as u8))
        .collect();
    let tilts = crate::calibration::tilted_joints(&file.tilt_joints(), &tilted);
    crate::calibration::model_params(model, &tilts)
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
