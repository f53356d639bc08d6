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
    pub split: Split<N>,
    pub sources: Sources,
    pub diagnose: Option<(DiagnoseJson, String)>,
    pub validation: Option<(ValidateReport, String)>,
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
        split,
        sources,
        diagnose,
        validation,
    } = inputs;
    let observed = &split.observed;
    // "Before" is the nominal robot placed as identify and check place it.
    let base_unknown = !file.base_known();
    place_nominal(&mut nominal, &file, &split.ident, observed.six_d)?;
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
        diagnose,
        validation,
        ident: split.ident,
        valid: split.valid,
        pose_of: split.pose_of,
        ident_poses: split.ident_poses,
        valid_poses: split.valid_poses,
    })
}
