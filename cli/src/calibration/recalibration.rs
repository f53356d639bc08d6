//! Whether the robot changed since a model's calibration, judged on a new session alone
//! (`kinecal validate`). The session's poses are left out fold by fold
//! ([`super::thin_data::cross_validate`]) and predicted twice: by the model registered on the
//! other poses (the parameters `validate` registers) and by the robot calibrated again on them
//! (every geometric parameter, the base, the MDH rows and the tool, fitted from the registered
//! model; its effects kept as they are). A model of the same robot predicts left-out poses
//! about as well as a new calibration does; one of a robot that changed (a joint's zero
//! moved, a link bent) predicts them many times worse, although it may still beat the nominal
//! robot: an ER20 model with joint 2's zero moved 0.05° since predicts left-out poses to 1.02
//! mm, where the nominal robot leaves 1.81 mm and a new calibration 0.035 mm (`validate` called
//! that "still holds"; host-tests `validate_sessions`).
//! Both figures are on left-out poses, so a new calibration's own estimation error counts
//! against it as the model's counted against it at its calibration. When the robot did not
//! change, a third recalibration frees a scale on every joint's reading besides: what it
//! gains names a joint read on another scale since (`with_joint_scales_rms_mm`).

use super::fit_lm;
use super::thin_data::cross_validate;
use crate::HostRobot;
use kinecal::identify::lm::LmConfig;
use kinecal::{Measurement, Param};
use serde::{Deserialize, Serialize};

/// The model's left-out RMS above this many times a new calibration's: the robot changed. A
/// model of the same robot on another session stays well under it: a UR10 geometry from series
/// B on series D 1.24× (the workspace and the day differ), an ER20 model with the tracker and
/// the reflector moved since 1.02×; a link 0.5 mm longer or a joint's zero 0.05° off leave
/// 13–29× (host-tests `validate_sessions`).
pub const CHANGED_RATIO: f64 = 3.0;
/// ... and above it by at least this much (mm). A model carries the estimation error of its
/// own calibration, which a quieter session does not: a model from 50 poses at 0.05 mm noise
/// leaves 0.0295 mm on a session of 0.005 mm that a new calibration predicts to 0.0085 mm
/// (host-tests `validate_sessions::a_quieter_session_of_the_same_robot_holds`). A robot that
/// changed moves the tool by tenths of a millimetre and more (a joint's zero 0.05°: 1.02 mm).
pub const CHANGED_MIN_MM: f64 = 0.05;

/// The model against the robot calibrated again on the session, on left-out poses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Recalibration {
    /// Folds the poses were left out in.
    pub folds: usize,
    /// Position RMS of the left-out poses (mm): the model registered on the others.
    pub model_rms_mm: f64,
    /// The same for the robot calibrated again on the others.
    pub recalibrated_rms_mm: f64,
    /// The same for the robot calibrated again with a scale on every joint's reading that the
    /// model has none on; present when the geometry alone does not tell a change. A joint read
    /// 1 % off (a gear ratio or an encoder's resolution set anew, a bad export) is absorbed by
    /// no geometry: the model, the nominal robot and a geometric recalibration then miss the
    /// session alike (the real UR10 series C with q4 × 1.01: 3.68, 3.69 and 3.6 mm, "still
    /// holds"), while the scale leaves what the model left at calibration.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub with_joint_scales_rms_mm: Option<f64>,
}

impl Recalibration {
    /// Whether the model predicts the session so much worse than a new calibration
    /// ([`CHANGED_RATIO`], [`CHANGED_MIN_MM`]) that the robot changed since its calibration.
    pub fn changed(&self) -> bool {
        let r = self
            .recalibrated_rms_mm
            .min(self.with_joint_scales_rms_mm.unwrap_or(f64::INFINITY));
        worse(self.model_rms_mm, r)
    }

    /// Whether the geometry calibrated again alone tells the change (the joints' scales
    /// aside).
    pub fn geometry_changed(&self) -> bool {
        worse(self.model_rms_mm, self.recalibrated_rms_mm)
    }

    /// Whether only the recalibration with the joints' scales tells the change: a joint's
    /// readings changed their scale since calibration.
    pub fn joint_scale(&self) -> bool {
        self.changed() && !self.geometry_changed()
    }
}

/// Whether a left-out RMS `model` is so much worse than `recalibrated` ([`CHANGED_RATIO`],
/// [`CHANGED_MIN_MM`]) that the robot changed.
fn worse(model: f64, recalibrated: f64) -> bool {
    model > CHANGED_RATIO * recalibrated && model - recalibrated > CHANGED_MIN_MM
}

/// [`Recalibration`] of `model` on `data` (weighted as `validate` registered it), registering
/// `register` on each fold's training poses. `None` when the session cannot be cross-validated
/// (fewer than two distinct poses, a fold that could not be fitted).
pub fn recalibrate<const N: usize>(
    model: &HostRobot<N>,
    register: &[Param],
    data: &[Measurement<f64, N>],
) -> Option<Recalibration> {
    let mut r = recalibrate_geometry(model, register, data)?;
    if !r.changed() {
        r.with_joint_scales_rms_mm = with_joint_scales(model, &geometry_params(model))
            .and_then(|(scaled, with)| left_out(&scaled, &with, register, data))
            .map(|(_, _, rms)| rms)
            .filter(|rms| rms.is_finite());
    }
    Some(r)
}

/// [`recalibrate`] without the recalibration with the joints' scales: the model against its
/// geometry (base, MDH rows, tool) calibrated again on the session, on left-out poses.
pub fn recalibrate_geometry<const N: usize>(
    model: &HostRobot<N>,
    register: &[Param],
    data: &[Measurement<f64, N>],
) -> Option<Recalibration> {
    let (folds, model_rms_mm, recalibrated_rms_mm) =
        left_out(model, &geometry_params(model), register, data)?;
    Some(Recalibration {
        folds,
        model_rms_mm,
        recalibrated_rms_mm,
        with_joint_scales_rms_mm: None,
    })
}

/// Every parameter of `model` but its effects' values.
fn geometry_params<const N: usize>(model: &HostRobot<N>) -> Vec<Param> {
    let mut params = super::model_params(model, &[]);
    params.retain(|p| !matches!(p, Param::Effect(_)));
    params
}

/// `model` with a scale on every joint's reading it has none on, and `params` with theirs;
/// `None` when one cannot be added (the effects store is full): no such recalibration then.
fn with_joint_scales<const N: usize>(
    model: &HostRobot<N>,
    params: &[Param],
) -> Option<(HostRobot<N>, Vec<Param>)> {
    let mut scaled = model.clone();
    let mut with = params.to_vec();
    let has_scale: Vec<usize> = model
        .effects()
        .iter()
        .filter(|e| e.kind == kinecal::EffectKind::Scale)
        .map(|e| e.joint as usize)
        .collect();
    for joint in (0..N).filter(|j| !has_scale.contains(j)) {
        let req = super::EffectRequest {
            kind: "joint-scale".into(),
            joint,
            arg: None,
        };
        with.extend(super::add_effect(&mut scaled, &req, (0.0, 0.0)).ok()?);
    }
    Some((scaled, with))
}

/// Folds, and the left-out RMS of `model` registered (`register`) and of `model` calibrated
/// again (`params` and `register`) on each fold's other poses.
fn left_out<const N: usize>(
    model: &HostRobot<N>,
    params: &[Param],
    register: &[Param],
    data: &[Measurement<f64, N>],
) -> Option<(usize, f64, f64)> {
    let mut params = params.to_vec();
    for p in register {
        if !params.contains(p) {
            params.push(*p);
        }
    }
    let place = |train: &[Measurement<f64, N>]| -> Option<HostRobot<N>> {
        let mut start = model.clone();
        if register.is_empty() {
            return Some(start);
        }
        crate::compute::registration::place_base(&mut start, train).ok()?;
        if register.contains(&Param::ToolRx) {
            if let Some(axes) = crate::compute::registration::fit_tool_axes(&start, train) {
                start.set_tool_axes(axes).ok()?;
            }
        }
        Some(
            fit_lm(&start, register, train, LmConfig::default())
                .ok()?
                .robot,
        )
    };
    // A fit stopped at the iteration limit is still a fit (its cost never rose from the
    // registered model's): the figure it gives is no lower than a converged fit's.
    let fit = |start: &HostRobot<N>, params: &[Param], train: &[Measurement<f64, N>]| {
        Some(
            fit_lm(start, params, train, LmConfig::default())
                .ok()?
                .robot,
        )
    };
    let cv = cross_validate(data, (model, &params), params.len(), 1, place, fit)?;
    let (model_rms_mm, recalibrated_rms_mm) = cv.figures()?;
    Some((cv.folds, model_rms_mm, recalibrated_rms_mm))
}
