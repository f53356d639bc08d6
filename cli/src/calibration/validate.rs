//! A calibrated model judged on another session's data (`kinecal validate`): only the
//! registration (where the robot stands in the tracker's frame, and where the probe sits on the
//! flange) is fitted to the session, the same way for the model and for the nominal robot, and
//! then both are compared on it. A model that predicts the session worse than the nominal robot
//! no longer describes the robot (or the set-up): recalibrate (docs/formats.md, "Validation on
//! another session").
//!
//! In memory only: robots in library units, observations already read (mm, degrees, weights);
//! the command (`crate::commands::validate`) loads the files and prints the report
//! (`crate::reports::validate`).

use super::stats::{quantile, SetFigures};
use super::{
    fit_lm, named_values, orientation_errors_deg, pose_error_vectors, weights, ErrorStats,
};
use crate::formats::observations::{ObservationArgs, Observed};
use crate::HostRobot;
use kinecal::identify::lm::LmConfig;
use kinecal::{Measurement, Param};
use std::collections::BTreeMap;

/// What the registration fits (`--register`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Register {
    /// Nothing: both robots as their files give them (the nominal file needs a `[base]`).
    None,
    /// The base pose (base.x … base.rz): the tracker moved.
    Base,
    /// The base pose and the tool point(s), and for 6-D data the tool orientation: the
    /// tracker and the probe moved.
    #[default]
    #[value(name = "base+tool")]
    BaseTool,
}

impl Register {
    /// The name on the command line and in the JSON report.
    pub fn id(self) -> &'static str {
        match self {
            Register::None => "none",
            Register::Base => "base",
            Register::BaseTool => "base+tool",
        }
    }

    /// The parameters fitted for a robot of `points` tool points, with 6-D data or not.
    pub fn params(self, points: usize, six_d: bool) -> Vec<Param> {
        let mut p = Vec::new();
        if self == Register::None {
            return p;
        }
        p.extend(Param::BASE);
        if self == Register::BaseTool {
            p.extend([Param::ToolX, Param::ToolY, Param::ToolZ]);
            if six_d {
                p.extend([Param::ToolRx, Param::ToolRy, Param::ToolRz]);
            }
            for k in 1..points {
                p.extend((0..3).map(|a| Param::ToolPoint(k as u8, a)));
            }
        }
        p
    }
}

/// Above this position RMS (mm) after registration, for the model and the nominal robot alike,
/// neither describes the session. A calibrated model leaves tenths of a millimetre, a nominal
/// robot a few millimetres (the UR10 5.5 mm), a robot re-mastered by 0.4° about 10 mm; swapped
/// or mirrored axes, joint columns in another order, a joint's sign or another unit leave 60
/// to 300 mm, where which of two wrong robots is the less wrong says nothing. With `--register
/// base`, a model above it also has the tool tried ([`Validation::tool_moved`]): a probe moved
/// 60 mm leaves both robots at tens of millimetres.
pub const MISMATCH_RMS_MM: f64 = 25.0;

/// The share of the model's RMS with the base alone registered under which registering the
/// tool too explains the session's errors (a reflector moved 10 mm: 9.9 mm → 0.032 mm).
pub const TOOL_EXPLAINS: f64 = 0.2;

/// The options of [`validate`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Options {
    pub register: Register,
    /// How orientation and σ columns weigh in the registration (as for `identify`).
    pub obs: ObservationArgs,
}

/// What [`validate`] compares: the nominal robot and the calibrated model (library units),
/// whether each file stated its `[base]`, the session's observations, and the names the
/// refusals use for the files.
#[derive(Clone, Copy)]
pub struct Inputs<'a, const N: usize> {
    pub nominal: &'a HostRobot<N>,
    pub nominal_base_known: bool,
    pub nominal_origin: &'a str,
    pub model: &'a HostRobot<N>,
    pub model_base_known: bool,
    /// The model file states a tool orientation (`rpy_deg`, even all zeros): 6-D data then
    /// judge it.
    pub model_orientation_stated: bool,
    pub model_origin: &'a str,
    pub observed: &'a Observed<N>,
    /// The check for a reflector or tracker that moved at one row (the diagnose layer's
    /// `row_step::warning`): run on the model registered onto the session.
    pub step_check: Option<StepCheck<N>>,
}

/// A row-step check: the registered robot, the observations and their file lines, the number
/// of parameters fitted, and the floor (mm) with its name; `Some(warning)` for a step.
pub type StepCheck<const N: usize> =
    fn(&HostRobot<N>, (&[Measurement<f64, N>], &[u32]), f64, (f64, &str)) -> Option<String>;

/// One robot registered onto the session, and its errors there.
#[derive(Clone, Debug, PartialEq)]
pub struct Judged {
    /// Position errors, per axis and in total (mm).
    pub figures: SetFigures,
    /// Orientation errors of 6-D observations (degrees) and their 95th percentile.
    pub orientation: Option<(ErrorStats, f64)>,
    /// The median row's orientation error (degrees), with 6-D observations.
    pub orientation_median_deg: Option<f64>,
    /// Several reflectors: each one's position errors, by name.
    pub per_point: Vec<(String, SetFigures)>,
    /// The registration fitted, by name (mm, degrees).
    pub registration: BTreeMap<String, f64>,
    /// Registration parameters the session could not determine (held at their start).
    pub held: Vec<String>,
}

/// The result of [`validate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Validation {
    /// The session's residuals step at one row: the warning that names it.
    pub step: Option<String>,
    pub register: Register,
    /// Names of the parameters fitted (the same for both robots).
    pub registered: Vec<String>,
    pub poses: usize,
    pub observations: usize,
    /// Equations of the registration: three per position, three more per orientation.
    pub equations: usize,
    pub model: Judged,
    pub nominal: Judged,
    /// The model's position RMS is above the nominal robot's (strictly, no margin), or with
    /// 6-D data the tool orientation the model states is off ([`Validation::orientation_off`]).
    pub worse_than_nominal: bool,
    /// With 6-D data, the model states a tool orientation and its median row is further off
    /// than [`crate::calibration::orientation_slip::limit_deg`].
    pub orientation_off: bool,
    /// The model is worse than the nominal robot, but with some `joint-table` or
    /// `joint-cyclic` effects' values read as degrees it predicts the session many times
    /// better ([`super::effects_in_degrees`]).
    pub effects_in_degrees: Option<super::effects_in_degrees::InDegrees>,
    /// The model against the robot calibrated again on the session, on left-out poses
    /// ([`super::recalibration`]); `None` when the model is worse than the nominal robot, the
    /// session has gross outliers, or it cannot be cross-validated.
    pub recalibration: Option<super::recalibration::Recalibration>,
    /// The model predicts the session many times worse than a new calibration does
    /// ([`super::recalibration::Recalibration::changed`]): the robot changed since.
    pub changed: bool,
    /// A few rows far from both registered robots ([`super::outliers`]): wrong readings,
    /// which pull the registration; no verdict.
    pub gross_outliers: Vec<super::outliers::Outlier>,
    /// Why those rows leave no verdict, in words.
    pub outlier_reason: Option<String>,
    /// With `--register base` (or `none`) and a bad verdict: the model's RMS (mm) when the tool is
    /// registered too, when that is under [`TOOL_EXPLAINS`] of it with the base alone (the
    /// probe moved since calibration).
    pub tool_moved: Option<f64>,
    /// How far (mm) the registration put the model's tool point from where the model states
    /// it (0 without a tool registration): a new probe or reflector.
    pub tool_shift_mm: f64,
    /// A joint whose readings are a turn (360°) from those the model's scale or table was
    /// calibrated on, on many rows ([`super::wrapped_readings`]): no verdict.
    pub wrapped: Option<super::wrapped_readings::Wrapped>,
    /// With a bad verdict: a joint whose zero, registered free too, explains what the model
    /// leaves ([`super::zero_moved`]): it moved since the calibration.
    pub zero_moved: Option<super::zero_moved::ZeroMoved>,
}

/// Registers the model and the nominal robot onto the session the same way (the parameters of
/// `opts.register`, fitted by the Levenberg–Marquardt of `identify` over every observation,
/// weighted as `identify` weighs 6-D and σ data: [`weights::weighted_fit`]) and compares them.
/// The base of each starts from point-set registration, for 6-D data with `base+tool` the tool
/// orientation from the data too. Refused (exit 2): `none` with a file that has no `[base]`, a
/// model with other tool points than the nominal robot, a session with no observations.
pub fn validate<const N: usize>(inp: Inputs<'_, N>, opts: &Options) -> anyhow::Result<Validation> {
    let observed = inp.observed;
    let data = observed.all();
    if data.is_empty() {
        crate::refuse!("the session has no observations: give a file with measured poses");
    }
    if inp.model.tool_point_count() != inp.nominal.tool_point_count() {
        crate::refuse!(
            "{}: {} tool points, but {} has {}: give the model that `kinecal identify --robot {} \
             --out M.toml` wrote",
            inp.model_origin,
            inp.model.tool_point_count(),
            inp.nominal_origin,
            inp.nominal.tool_point_count(),
            inp.nominal_origin
        );
    }
    if opts.register == Register::None {
        for (known, origin) in [
            (inp.nominal_base_known, inp.nominal_origin),
            (inp.model_base_known, inp.model_origin),
        ] {
            if !known {
                crate::refuse!(
                    "{origin} has no [base]: --register none compares the files as written and \
                     needs the base pose: add a [base] (the one `kinecal check` prints), or \
                     register it with --register base"
                );
            }
        }
    }
    let params = opts
        .register
        .params(inp.nominal.tool_point_count(), observed.six_d);
    let pose_of = crate::formats::observations::pose_of(&observed.poses);
    let placed = |robot: &HostRobot<N>| -> anyhow::Result<(HostRobot<N>, Judged, Vec<_>)> {
        let (placed, held, weighted) = register(robot, &params, &data, &pose_of, observed, opts)?;
        let j = judged(&placed, &data, &observed.names, &params, held)?;
        Ok((placed, j, weighted))
    };
    let judge = |robot: &HostRobot<N>| Ok::<_, anyhow::Error>(placed(robot)?.1);
    let (model_placed, model, weighted) = placed(inp.model)?;
    let (nominal_placed, nominal, nominal_weighted) = placed(inp.nominal)?;
    // Wrong readings: rows far from both registered robots by identify's rule (each observation
    // weighed as its registration weighed it). A verdict on a registration they pull says
    // nothing (two rows 200 mm off among 150 swung it either way). A row far from the model
    // alone is the model's fault there (a table knot its calibration did not support), not
    // the data's.
    let far = |robot: &HostRobot<N>, data: &[Measurement<f64, N>]| {
        super::outliers::find(robot, &[(&observed.poses, data)])
    };
    let mut outliers = far(&model_placed, &weighted);
    let by_nominal = far(&nominal_placed, &nominal_weighted);
    outliers
        .far
        .retain(|o| by_nominal.far.iter().any(|n| n.line == o.line));
    let few = outliers.few().is_some();
    let gross_outliers = if few {
        outliers.far.clone()
    } else {
        Vec::new()
    };
    let outlier_reason = few.then(|| {
        let what = if params.is_empty() {
            "decide which of the two robots looks better"
        } else {
            "pull the registration of both robots"
        };
        format!(
            "{} row(s) lie far from both robots ({}): wrong readings ({}) {what}; delete those \
             rows or measure them again",
            outliers.far.len(),
            outliers.far_named(),
            outliers.causes
        )
    });
    // 6-D data judge the orientations too, of a model that states a tool orientation: one
    // fitted to angles in radians "held" at 115° on its positions alone. A calibration of the
    // tool frame leaves its median row within a degree (the real UR10 rows: 0.057°); a model
    // without a tool orientation, or a positions calibration that moved the orientations by
    // hundredths of a degree, is judged on its positions.
    let stated: Vec<f64> = weights::stated(&data, observed.sigma)
        .iter()
        .map(|s| s.orientation_rad.to_degrees())
        .collect();
    let worse_orientation = inp.model_orientation_stated
        && model
            .orientation_median_deg
            .is_some_and(|d| d > crate::calibration::orientation_slip::limit_deg(&stated));
    let worse_than_nominal =
        model.figures.total.rms > nominal.figures.total.rms || worse_orientation;
    // A model worse than the nominal robot whose angle-valued effects, read as degrees, predict
    // the session many times better (and, with a stated tool orientation, hold it): values
    // written in degrees where the file holds radians.
    let limit_deg = crate::calibration::orientation_slip::limit_deg(&stated);
    let effects_in_degrees = if worse_than_nominal {
        super::effects_in_degrees::best(inp.model, model.figures.total.rms, |m| {
            let j = judge(m).ok()?;
            let off = inp.model_orientation_stated
                && j.orientation_median_deg.is_some_and(|d| d > limit_deg);
            (!off).then_some(j.figures.total.rms)
        })
    } else {
        None
    };
    // Readings a turn from those the model's scale or table was calibrated on: judged on the
    // wrong turn, the model says nothing of the robot.
    let wrapped = outlier_reason
        .is_none()
        .then(|| super::wrapped_readings::find(&model_placed, &data))
        .flatten();
    // A model no worse than the nominal robot may still be far worse than the robot calibrated
    // again on the session: it changed since.
    let recalibration = (!worse_than_nominal && outlier_reason.is_none() && wrapped.is_none())
        .then(|| super::recalibration::recalibrate(inp.model, &params, &weighted))
        .flatten();
    let changed = recalibration.as_ref().is_some_and(|r| r.changed());
    // A bad verdict with the base alone registered that registering the tool too mostly
    // explains: the probe moved (the robot may have too: the verdict with both says).
    let bad = worse_than_nominal || changed || model.figures.total.rms > MISMATCH_RMS_MM;
    // With `--register none` the base too is registered for the test, and the tool must be
    // what explains it: registering the base alone must leave far more (a tracker moved is
    // not a probe moved).
    let held_tool = matches!(opts.register, Register::Base | Register::None);
    let tool_moved = (held_tool && bad && outlier_reason.is_none())
        .then(|| {
            let rms_with = |register| {
                let o = Options {
                    register,
                    ..opts.clone()
                };
                validate(inp, &o).ok().map(|v| v.model.figures.total.rms)
            };
            let rms = rms_with(Register::BaseTool)?;
            let base_alone = match opts.register {
                Register::None => rms_with(Register::Base)?,
                _ => model.figures.total.rms,
            };
            (rms < TOOL_EXPLAINS * model.figures.total.rms && rms < TOOL_EXPLAINS * base_alone)
                .then_some(rms)
        })
        .flatten();
    let tool_shift_mm = (model_placed.tool() - inp.model.tool()).norm();
    // A reflector re-seated or a tracker bumped halfway: neither registration describes the
    // session (a 3 mm step "held" at 1.5 mm with exit 0). Not when a joint's scale explains the
    // session: its residuals jump between rows far apart in that joint, and are no step.
    let scaled = recalibration.as_ref().is_some_and(|r| r.joint_scale());
    let step = inp.step_check.filter(|_| !scaled).and_then(|check| {
        let lines = crate::formats::observations::line_of(&observed.poses);
        let floor = (model.figures.total.rms, "the model's RMS");
        check(&model_placed, (&data, &lines), params.len() as f64, floor)
    });
    // A bad verdict one joint's zero explains: that zero moved since (a 5° shift read as "the
    // data do not fit the robot file: check the units"). Not beside another named cause: wrong,
    // wrapped or stepping readings, a joint's scale, effect values in degrees, a tool
    // orientation off, a probe moved.
    let named = outlier_reason.is_some()
        || wrapped.is_some()
        || step.is_some()
        || scaled
        || effects_in_degrees.is_some()
        || worse_orientation
        || tool_moved.is_some();
    let zero_moved = (bad && !named)
        .then(|| super::zero_moved::find(&model_placed, &params, &weighted))
        .flatten();
    Ok(Validation {
        zero_moved,
        step,
        wrapped,
        tool_shift_mm,
        tool_moved,
        changed,
        recalibration,
        gross_outliers,
        outlier_reason,
        register: opts.register,
        registered: params
            .iter()
            .map(|p| p.name(inp.model).to_string())
            .collect(),
        poses: observed.poses.len(),
        observations: data.len(),
        equations: crate::calibration::thin_data::equations(&data),
        model,
        nominal,
        worse_than_nominal,
        orientation_off: worse_orientation,
        effects_in_degrees,
    })
}

/// A robot registered onto a session: the robot, the names of the registration parameters the
/// data could not determine, and the data weighted as the registration weighed them.
type Registered<const N: usize> = (HostRobot<N>, Vec<String>, Vec<Measurement<f64, N>>);

/// `robot` with the registration parameters fitted to `data` (unchanged for no parameters),
/// the names of those the data could not determine, and the data as weighted.
fn register<const N: usize>(
    robot: &HostRobot<N>,
    params: &[Param],
    data: &[Measurement<f64, N>],
    pose_of: &[usize],
    observed: &Observed<N>,
    opts: &Options,
) -> anyhow::Result<Registered<N>> {
    use anyhow::Context;
    if params.is_empty() {
        return Ok((robot.clone(), Vec::new(), data.to_vec()));
    }
    let mut start = robot.clone();
    crate::compute::registration::place_base(&mut start, data)
        .context("registering the base pose")?;
    if params.contains(&Param::ToolRx) {
        if let Some(axes) = crate::compute::registration::fit_tool_axes(&start, data) {
            start
                .set_tool_axes(axes)
                .map_err(|e| anyhow::anyhow!("registered tool orientation is invalid: {e:?}"))?;
        }
    }
    let mut weighted = data.to_vec();
    let stated = weights::stated(&weighted, observed.sigma);
    let how = weights::Weighting::of(
        observed.six_d,
        observed.sigma,
        &opts.obs,
        observed.poses.len(),
        params.len(),
    );
    let (fit, _) = weights::weighted_fit(&mut weighted, pose_of, &stated, how, |d| {
        fit_lm(&start, params, d, LmConfig::default())
    })?;
    Ok((fit.robot, fit.unidentifiable, weighted))
}

/// The errors of the registered `robot` on `data`.
fn judged<const N: usize>(
    robot: &HostRobot<N>,
    data: &[Measurement<f64, N>],
    names: &[String],
    params: &[Param],
    held: Vec<String>,
) -> anyhow::Result<Judged> {
    let e = pose_error_vectors(robot, data);
    let figures =
        SetFigures::of_vectors(&e).ok_or_else(|| anyhow::anyhow!("no observations to judge"))?;
    let o = orientation_errors_deg(robot, data);
    let orientation = ErrorStats::of(&o).map(|s| (s, quantile(&o, 0.95)));
    let per_point = if names.len() < 2 {
        Vec::new()
    } else {
        names
            .iter()
            .enumerate()
            .filter_map(|(k, name)| {
                let ek: Vec<_> = e
                    .iter()
                    .zip(data)
                    .filter(|(_, m)| m.tool as usize == k)
                    .map(|(v, _)| *v)
                    .collect();
                Some((name.clone(), SetFigures::of_vectors(&ek)?))
            })
            .collect()
    };
    Ok(Judged {
        figures,
        orientation,
        orientation_median_deg: crate::calibration::orientation_slip::median(&o),
        per_point,
        registration: named_values(robot, params),
        held,
    })
}
