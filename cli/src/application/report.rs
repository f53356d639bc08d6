//! `kinecal report` on what was read: the application function under the command (which
//! reads the robot file, the model, the data and the JSON files, calls [`report`] and writes
//! the page). Identify's fit of the model is rebuilt ([`crate::calibration::replay`]) so that
//! the page's 1-σ, tables and figures are the ones identify reported.

use crate::calibration::inputs::{place_nominal, Split};
use crate::calibration::replay;
use crate::calibration::selection::ParameterArgs;
use crate::calibration::{model_params, weights};
use crate::formats::observations::ObservationArgs;
use crate::formats::robot_file::RobotFile;
use crate::report_html::findings::DiagnoseJson;
use crate::report_html::{build, Built, Sources};
use crate::reports::validate::ValidateReport;
use crate::HostRobot;

/// How identify was run (as given to it) and when a fit has stalled.
pub struct Options<'a> {
    pub parameters: &'a ParameterArgs,
    pub obs: &'a ObservationArgs,
    /// Above this identification RMS (mm) the model is not a calibration of the data.
    pub stall_rms_mm: f64,
}

/// What the page is made of: the robot file and its model (not yet placed), the identified
/// model (file and model, named `model_origin`), the data split as identify split it, where
/// they came from, and optionally diagnose's findings and another session's validation.
pub struct Inputs<const N: usize> {
    pub file: RobotFile,
    pub nominal: HostRobot<N>,
    pub model_file: RobotFile,
    pub model: HostRobot<N>,
    pub model_origin: String,
    /// The robot file's path as given (compared with a validate JSON's).
    pub robot_origin: String,
    /// The `--validate` file's name when the held-out poses are another file's, not a part of
    /// the data file.
    pub validated: Option<String>,
    pub split: Split<N>,
    pub sources: Sources,
    pub diagnose: Option<(DiagnoseJson, String)>,
    pub validation: Option<(ValidateReport, String)>,
}

/// Refuses (exit 2) a validate JSON (`origin`) of another robot file or model than the page's
/// (`robot`, `model`: paths as given, compared by file name): its verdict would be shown as
/// this model's.
fn same_files(
    v: &ValidateReport,
    origin: &str,
    (robot, model): (&str, &str),
) -> anyhow::Result<()> {
    let name = |p: &str| {
        std::path::Path::new(p)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
    };
    for (what, theirs, ours) in [
        ("robot file", &v.robot_file, robot),
        ("model", &v.model_file, model),
    ] {
        if name(theirs) != name(ours) {
            crate::refuse!(
                "{origin}: a validation of the {what} {theirs}, not {ours}: give the JSON of \
                 `kinecal validate --robot {robot} --model {model} …`"
            );
        }
    }
    Ok(())
}

/// The calibration report of `inputs.model`: the page and its summary. Refuses what identify
/// would have refused (a base that cannot be placed, unknown parameter names).
pub fn report<const N: usize>(options: &Options<'_>, inputs: Inputs<N>) -> anyhow::Result<Built> {
    let Inputs {
        file,
        mut nominal,
        model_file,
        model,
        model_origin,
        robot_origin,
        validated,
        split,
        sources,
        diagnose,
        validation,
    } = inputs;
    if let Some((v, origin)) = &validation {
        same_files(v, origin, (&robot_origin, &model_origin))?;
    }
    if let Some((d, origin)) = &diagnose {
        let poses = split.ident_poses + split.valid_poses;
        if let Some(searched) = d.poses.filter(|&p| p > poses) {
            crate::refuse!(
                "{origin}: diagnose searched {searched} poses, more than these data hold \
                 ({poses}): it is of another data file; give the JSON of `kinecal diagnose` on \
                 these data"
            );
        }
    }
    // Gross outliers refuse the model as identify refuses its fit (held-out rows of the data
    // file searched too, named as held out).
    let held_lines: Vec<u32> = split.valid_set.iter().map(|p| p.line).collect();
    let outliers = if validated.is_some() {
        crate::calibration::outliers::find(&model, &[(&split.ident_set, &split.ident)])
    } else {
        crate::calibration::outliers::find(
            &model,
            &[
                (&split.ident_set, &split.ident),
                (&split.valid_set, &split.valid),
            ],
        )
    };
    let outliers = outliers.reason_given(if validated.is_some() {
        &[]
    } else {
        &held_lines
    });
    let observed = &split.observed;
    // "Before" is the nominal robot placed as identify and check place it.
    let base_unknown = !file.base_known();
    place_nominal(&mut nominal, &file, &split.ident, observed.six_d)?;
    // A --validate file in another unit or layout is refused as identify refuses it.
    if let Some(name) = &validated {
        let (ident, valid) = (&split.ident, &split.valid);
        let before = crate::calibration::Residuals::of(&nominal, ident, valid);
        let after = crate::calibration::Residuals::of(&model, ident, valid);
        crate::calibration::acceptance::refuse_foreign_held_out((&before, &after), name)?;
    }
    let how = (observed.six_d, base_unknown);
    let selected = options.parameters.selection();
    let (tilts, estimated) = replay::estimated(&file, (&model_file, &model), how, &selected)?;
    let weighting = weights::Weighting::of(
        observed.six_d,
        observed.sigma,
        options.obs,
        split.ident_poses,
        estimated.len(),
    );
    let (start, prior) = replay::start_and_prior(
        (&file, &nominal),
        (&model, &model_origin),
        how,
        &estimated,
        &options.parameters.prior,
    )?;
    build(crate::report_html::Inputs {
        robot_name: file.name.clone(),
        model_name: model_file.name.clone(),
        sources,
        nominal: &nominal,
        base_fitted: base_unknown,
        tool_unknown: file.tool_unknown(),
        model: &model,
        start: &start,
        all_params: model_params(&model, &tilts),
        estimated,
        prior,
        names: observed.names.clone(),
        six_d: observed.six_d,
        sigma: observed.sigma,
        weighting,
        limits_deg: file.joints.iter().map(|j| j.limits_deg).collect(),
        stall_rms_mm: options.stall_rms_mm,
        outliers,
        diagnose,
        validation,
        ident: split.ident,
        valid: split.valid,
        pose_of: split.pose_of,
        ident_poses: split.ident_poses,
        valid_poses: split.valid_poses,
    })
}
