//! Identification on data already loaded: the application function under `kinecal identify`
//! (which reads the files, calls [`identify`] and writes what it returns) and the Python
//! package's `identify` (which builds [`Inputs`] from arrays).

use crate::calibration::inputs::{joint_range, HoldoutArgs};
use crate::calibration::method::Method;
use crate::calibration::selection::hold_first_row;
use crate::calibration::selection::Selection;
use crate::calibration::{add_effect, named_values, weights, EffectRequest, Fit, Residuals};
use crate::formats::observations::{ObservationArgs, Observed, Pose};
use crate::formats::robot_file::RobotFile;
use crate::reports::identify::{Change, IdentifyReport, ObservationSummary, PointResiduals};
use crate::HostRobot;
use crate::HostValues;
use kinecal::model::param::ParamSet;
use kinecal::Measurement;
use kinecal::Param;
use std::time::Instant;

/// The seed of the stochastic methods unless one is given.
pub const DEFAULT_SEED: u64 = 1;
/// A length parameter that moves further than this (mm) from its file value is suspicious.
pub const DEFAULT_TOLERANCE_MM: f64 = 20.0;
/// The same for angle parameters, degrees.
pub const DEFAULT_TOLERANCE_DEG: f64 = 2.0;
/// A fold of a thin fit's cross-validation that stopped before converging counts when its
/// poses' RMS is within this factor of the whole fit's (`crate::calibration::thin_data`).
pub const FOLD_RMS_RATIO: f64 = 1.5;
/// A fit whose identification RMS stays above this (mm) has stalled.
pub const DEFAULT_STALL_RMS_MM: f64 = 5.0;

/// How to identify: `kinecal identify`'s options without its files (docs/formats.md).
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Identification method.
    pub method: Method,
    /// Which poses of the data are held out (unless [`Inputs::validate`] holds the held-out
    /// poses).
    pub holdout: HoldoutArgs,
    /// Effects added to the model with zero values.
    pub effects: Vec<EffectRequest>,
    /// Seed of the stochastic methods and of a random split.
    pub seed: u64,
    /// Parameters held at their file values, estimated too, or estimated alone: names or groups
    /// (`--fix`, `--free`, `--only`).
    pub fix: Vec<String>,
    pub free: Vec<String>,
    pub only: Vec<String>,
    /// The prior over the robot file's `[prior]`: `off` or KIND=SIGMA (`--prior`).
    pub prior: Vec<String>,
    /// Whether to tabulate each pose's residual ([`Identified::residuals`]).
    pub residuals: bool,
    /// Beyond these a change is suspicious.
    pub tolerance_mm: f64,
    pub tolerance_deg: f64,
    /// Above this identification RMS the fit has stalled (not converged).
    pub stall_rms_mm: f64,
    /// How orientations and σ columns are used.
    pub obs: ObservationArgs,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            method: Method::Lm,
            holdout: HoldoutArgs::default(),
            effects: Vec::new(),
            seed: DEFAULT_SEED,
            fix: Vec::new(),
            free: Vec::new(),
            only: Vec::new(),
            prior: Vec::new(),
            residuals: false,
            tolerance_mm: DEFAULT_TOLERANCE_MM,
            tolerance_deg: DEFAULT_TOLERANCE_DEG,
            stall_rms_mm: DEFAULT_STALL_RMS_MM,
            obs: ObservationArgs::default(),
        }
    }
}

/// What [`identify`] fits, in memory: the robot file and its model, the observations (already
/// in mm and degrees, through [`crate::formats::units`] and [`crate::formats::observations::observe`]) and, optionally, the
/// observations to validate on; each named as error messages name it (a path, or what the
/// caller calls it).
pub struct Inputs<const N: usize> {
    pub file: RobotFile,
    pub nominal: HostRobot<N>,
    pub observed: Observed<N>,
    pub robot_origin: String,
    pub data_origin: String,
    /// The `--validate` observations and their name.
    pub validate: Option<(Observed<N>, String)>,
}

/// The result of [`identify`]: the report (`out` unset) and the identified model, as a robot
/// file (what `--out` writes) and as the library's model.
pub struct Identified<const N: usize> {
    pub report: IdentifyReport,
    pub model: RobotFile,
    pub robot: HostRobot<N>,
    /// Each pose's residual (what `--residuals` writes; empty without `--residuals`).
    pub residuals: crate::calibration::residual_table::ResidualTable,
}

/// `kinecal identify` in memory: fits the model of `inputs` with `opts`, exactly as the command
/// does. Refused input is a [`crate::Refused`] error; a fit that did not converge is
/// `report.converged == false`. Prints nothing (the command prints
/// [`IdentifyReport::warnings`]).
pub fn identify<const N: usize>(
    opts: &Options,
    inputs: Inputs<N>,
) -> anyhow::Result<Identified<N>> {
    let Inputs {
        file,
        mut nominal,
        observed,
        robot_origin,
        data_origin,
        validate,
    } = inputs;
    let validated = validate.is_some();
    let validate_name = validate.as_ref().map(|(_, name)| name.clone());
    let data_path = std::path::Path::new(&data_origin);
    let crate::calibration::inputs::Split {
        observed,
        ident,
        valid,
        ident_poses,
        valid_poses,
        pose_of,
        ident_set,
        valid_set,
    } = crate::calibration::inputs::split_observed(
        observed,
        validate,
        (&opts.holdout, opts.seed),
        &data_origin,
    )?;
    for (flag, v) in [
        ("--tolerance-mm", opts.tolerance_mm),
        ("--tolerance-deg", opts.tolerance_deg),
        ("--stall-rms-mm", opts.stall_rms_mm),
    ] {
        crate::check_positive(flag, v, 1e6)?;
    }
    // A thermal-expansion term of the file without `reference_c` and with a zero coefficient
    // is referred to the identification data's mean temperature (and written with it).
    let mut file = file;
    if file.with_thermal_reference(crate::calibration::thermal::mean_temperature(&ident)) {
        nominal = file
            .to_robot::<N>()
            .map_err(|e| anyhow::anyhow!("{robot_origin}: {e}"))?;
    }
    let base_unknown = !file.base_known();
    // 6-D data and no `[tool] rpy_deg`: the measured frame's orientation is unknown; started
    // from the data as the base is (and then compared with no tolerance).
    let tool_axes_unknown =
        crate::calibration::inputs::place_nominal(&mut nominal, &file, &ident, observed.six_d)?;
    // Effects requested on the command line join the model with zero values.
    let mut extra = Vec::new();
    for t in file.tilt_joints() {
        extra.push(kinecal::Param::Beta(t as u8));
    }
    for req in &opts.effects {
        if req.joint >= N {
            crate::refuse!(
                "--effect {}:{}: {robot_origin} has {N} joints (number them 1 to {N})",
                req.kind,
                req.joint + 1
            );
        }
        if req.kind == crate::formats::robot_file::THERMAL {
            extra.extend(crate::calibration::thermal::add(&mut nominal, req, &ident)?);
            continue;
        }
        if req.kind == crate::calibration::drift::DRIFT {
            extra.extend(crate::calibration::drift::add(&mut nominal, &ident)?);
            continue;
        }
        let range = joint_range(&ident, req.joint);
        extra.extend(add_effect(&mut nominal, req, range)?);
    }
    let mut params: Vec<kinecal::Param> = ParamSet::<64>::full(N, base_unknown)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    params.extend(existing_effect_params(&nominal, &params));
    // The requested effects are in the model already (and so among its effect values above):
    // a parameter listed twice would be held as confounded with itself.
    for p in &extra {
        if !params.contains(p) {
            params.push(*p);
        }
    }
    // What only 6-D observations see (the rotation about the tool axis, theta of the last
    // joint against the tool point) is in the full set or joins here; the identifiability
    // analysis holds what the data cannot determine.
    if observed.six_d {
        params.extend([
            kinecal::Param::ToolRx,
            kinecal::Param::ToolRy,
            kinecal::Param::ToolRz,
        ]);
    }
    for k in 1..nominal.tool_point_count() {
        params.extend((0..3).map(|a| kinecal::Param::ToolPoint(k as u8, a)));
    }
    if base_unknown {
        hold_first_row(&mut params);
    }
    crate::calibration::selection::apply(
        &mut params,
        &nominal,
        &Selection {
            only: &opts.only,
            free: &opts.free,
            fix: &opts.fix,
        },
    )?;
    // Effect values (table knots) that fewer than three poses move are held at their starting
    // values (the file's, 0 for a requested table): fitted, they would follow those poses'
    // noise.
    let effect_values = params
        .iter()
        .filter(|p| matches!(p, kinecal::Param::Effect(_)))
        .count();
    let thin_held = crate::calibration::thin_data::hold_thin_values(&nominal, &mut params, &ident);
    enough_poses(&ident, params.len(), base_unknown, data_path)?;
    let before = Residuals::of(&nominal, &ident, &valid);
    // The prior: the robot file's `[prior]` (or the defaults) with `--prior` over it; none on
    // what does not start from a file value.
    let prior = file.prior.unwrap_or_default().with_overrides(&opts.prior)?;
    let prior_sigma = crate::calibration::prior::sigmas(&prior, &params, |p| {
        (p.is_base() && base_unknown)
            || (p.is_tool_rotation() && tool_axes_unknown)
            || (is_tool_point(p) && file.tool_unknown())
            || extra.contains(&p) && matches!(p, kinecal::Param::Effect(_))
    });
    let t0 = Instant::now();
    let run_method = |data: &[Measurement<f64, N>]| match opts.method {
        Method::Lm => {
            crate::calibration::prior::fit_lm_with_prior(&nominal, &params, &prior_sigma, data)
        }
        m => crate::calibration::pso_search::identify(m, &nominal, &params, data, opts.seed),
    };
    let mut ident = ident;
    let stated = weights::stated(&ident, observed.sigma);
    // 6-D or σ-weighted data: error floors for what the model cannot explain, refitted until
    // they settle; not when the user set the weighting. 6-D with the weighting left to the
    // data: how much the orientations weigh against the positions is chosen by
    // cross-validating position prediction over the identification poses
    // (crate::calibration::weights::weighted_fit).
    let how = weights::Weighting::of(
        observed.six_d,
        observed.sigma,
        &opts.obs,
        ident_poses,
        params.len(),
    );
    let (fit, weighted) = weights::weighted_fit(&mut ident, &pose_of, &stated, how, run_method)?;
    let seconds = t0.elapsed().as_secs_f64();
    let after = Residuals::of(&fit.robot, &ident, &valid);
    if let Some(name) = &validate_name {
        crate::calibration::acceptance::refuse_foreign_held_out((&before, &after), name)?;
    }
    let per_point =
        PointResiduals::per_point(&observed.names, (&nominal, &fit.robot), (&ident, &valid));
    let estimated = params.len().saturating_sub(fit.unidentifiable.len());
    let chi2_per_dof = if observed.sigma {
        weights::chi2_per_dof(&fit.robot, &ident, &stated, estimated)
    } else {
        None
    };
    let tilts = crate::calibration::tilted_joints(&file.tilt_joints(), &params);
    let model = {
        let mut f = RobotFile::from_robot(
            &format!("{} (identified)", file.name),
            &fit.robot,
            true,
            &tilts,
        )
        .with_tool_names(&observed.names);
        // An identity `rpy_deg` written in the input stays written, and so does `[prior]`.
        if f.tool.rpy_deg.is_none() {
            f.tool.rpy_deg = file.tool.rpy_deg;
        }
        f.prior = file.prior;
        f
    };
    let mut changes = changes(&nominal, &fit, &params, base_unknown);
    for c in changes.iter_mut() {
        if tool_axes_unknown && c.name.starts_with("tool.r") {
            c.free_start = true;
        }
        // Started from the data: no tolerance says how far it may move from a guess.
        if file.tool_unknown() && ["tool.x", "tool.y", "tool.z"].contains(&c.name.as_str()) {
            c.free_start = true;
        }
    }
    let suspicious: Vec<String> = changes
        .iter()
        .filter(|c| c.beyond_tolerance(opts.tolerance_mm, opts.tolerance_deg))
        .map(|c| c.name.clone())
        .collect();
    let stalled = after.identification_rms_mm > opts.stall_rms_mm;
    // The file line of each identification observation (the row-step checks name them).
    let lines = crate::formats::observations::line_of(&ident_set);
    // A fit that a few gross outliers pulled is no calibration (what else it says follows from
    // them); nor is one that stretched or shrank the arm or turned a joint, however small its
    // error (a file the robot file does not describe: named so before its many outliers). The poses
    // held out of the same file are searched too; a `--validate` file's are of another session,
    // whose errors say whether the model holds there.
    let searched: &[(&[Pose], &[Measurement<f64, N>])] = if validated {
        &[(&ident_set, &ident)]
    } else {
        &[(&ident_set, &ident), (&valid_set, &valid)]
    };
    let outliers = crate::calibration::outliers::find(&fit.robot, searched);
    let held_lines: Vec<u32> = if validated {
        Vec::new()
    } else {
        valid_set.iter().map(|p| p.line).collect()
    };
    // One joint's readings on another scale (no geometry takes it up): checked only when no
    // earlier reason refuses the fit.
    let scaled_once = std::cell::OnceCell::new();
    let scaled = || {
        *scaled_once
            .get_or_init(|| crate::calibration::joint_scale::check(&fit.robot, &params, &ident))
    };
    let resized = outliers
        .few_given(&held_lines)
        .or_else(|| {
            crate::calibration::orientation_slip::astray(
                after.identification_rms_mm,
                opts.stall_rms_mm,
                &crate::calibration::orientation_errors_deg(&fit.robot, &ident),
                &stated
                    .iter()
                    .map(|s| s.orientation_rad.to_degrees())
                    .collect::<Vec<f64>>(),
            )
        })
        .or_else(|| crate::calibration::arm_size::resized(&nominal, &fit.robot))
        .or_else(|| crate::calibration::tool_check::stated_tool_slip(&file, &nominal, &fit.robot))
        .or_else(|| {
            crate::calibration::thermal::implausible(
                &fit.robot,
                fit.sigma.get("thermal-expansion1").copied(),
            )
        })
        .or_else(|| {
            crate::calibration::base_moved::reason(&fit.robot, &params, &ident, file.base_known())
        })
        .or_else(|| {
            // `--only` or `--fix` held a geometry the session no longer agrees with.
            (!opts.only.is_empty() || !opts.fix.is_empty())
                .then(|| crate::calibration::held_geometry::reason(&fit.robot, &params, &ident))
                .flatten()
        })
        .or_else(|| scaled().filter(|s| s.readings()).map(|s| s.reason()))
        .or_else(|| {
            // A reflector or a tracker that moved at one row: the fit took the mean.
            let floor = (after.identification_rms_mm, "the fit's RMS");
            crate::diagnose::row_step::refusal(
                &fit.robot,
                (&ident, &lines),
                estimated as f64,
                floor,
            )
        })
        .or_else(|| outliers.reason_given(&held_lines));
    let converged = fit.solver_converged()
        && !stalled
        && resized.is_none()
        && after.identification_rms_mm.is_finite();
    let verdict = Verdict {
        converged,
        stop: resized.unwrap_or_else(|| {
            stop_text(
                &fit,
                after.identification_rms_mm,
                stalled,
                opts.stall_rms_mm,
            )
        }),
        suspicious,
        out: None,
    };
    let mut report = report(
        opts.method,
        (&file, &tilts),
        &fit,
        (ident_poses, valid_poses),
        (before, after),
        seconds,
        changes,
        &verdict,
    );
    report.per_point = per_point;
    report.chi2_per_dof = chi2_per_dof;
    report.stray_points = outliers.strays().filter(|_| verdict.converged);
    report
        .notes
        .extend(crate::calibration::thin_data::held_note(
            &nominal,
            &thin_held,
            effect_values,
        ));
    report
        .notes
        .extend(crate::calibration::acceptance::narrow_joints(&ident));
    // A scale no more than a gearbox's that explains the fit: a missing effect of that joint.
    if verdict.converged {
        report
            .notes
            .extend(scaled().filter(|s| !s.readings()).map(|s| s.warning()));
    }
    // A creep of the measured point, or a joint's zero changing at one row (a step of the
    // residuals is a refusal above). A drift of the tracker is diagnose's to tell: the
    // residuals of a geometric fit hold the effects it misses, and in a session measured in
    // an order (series B: targets grid by grid) those trend along the rows as well.
    if verdict.converged {
        let floor = (report.after.identification_rms_mm, "the fit's RMS");
        let at = (ident.as_slice(), lines.as_slice());
        report.notes.extend(
            crate::diagnose::row_step::warning(&fit.robot, at, estimated as f64, floor).or_else(
                || crate::diagnose::zero_step::warning(&fit.robot, at, estimated as f64, floor),
            ),
        );
    }
    report.observations = Some(ObservationSummary::new(
        &observed,
        ident.len(),
        opts.obs.deg_weight_mm,
        &weighted,
    ));
    // Judged on the held-out poses against the model the fit started from.
    let weak: Vec<String> = report
        .changes
        .iter()
        .filter(|c| c.barely_determined(opts.tolerance_mm, opts.tolerance_deg))
        .map(|c| c.name.clone())
        .collect();
    // Nothing held out and thin data: judged by cross-validation instead. Each fold's fit is
    // the LM with the prior from the model placed on the fold's other poses, for every
    // method (a stochastic search would take each fold as long as the whole), with the
    // weights and error floors the whole fit settled on.
    let equations = crate::calibration::thin_data::equations(&ident);
    let cross = (valid.is_empty()
        && converged
        && crate::calibration::thin_data::thin(equations, estimated))
    .then(|| {
        crate::calibration::thin_data::cross_validate(
            &ident,
            (&fit.robot, &params),
            estimated,
            opts.seed,
            |train| {
                let mut start = nominal.clone();
                crate::calibration::inputs::place_nominal(&mut start, &file, train, observed.six_d)
                    .ok()
                    .map(|_| start)
            },
            |start, kept, train| {
                // The prior of each value the fold estimates (it holds those its poses do
                // not support).
                let sigma: Vec<Option<f64>> = kept
                    .iter()
                    .map(|p| {
                        params
                            .iter()
                            .position(|q| q == p)
                            .and_then(|i| prior_sigma[i])
                    })
                    .collect();
                crate::calibration::prior::fit_lm_with_prior(start, kept, &sigma, train)
                    .ok()
                    .filter(|f| {
                        // Settled where the whole fit did: converged, or stopped (at the
                        // iteration limit: a fold of hundreds of table knots) with the fold's
                        // poses fitted as well as the whole fit fits all of them.
                        f.solver_converged()
                            || Residuals::of(&f.robot, train, &[]).identification_rms_mm
                                <= FOLD_RMS_RATIO * after.identification_rms_mm + 1e-6
                    })
                    .map(|f| f.robot)
            },
        )
    })
    .flatten();
    report.acceptance = match &cross {
        Some(cv) => crate::calibration::acceptance::judge_cross_validated(
            cv,
            after.identification_rms_mm,
            ident_poses,
            weak,
        ),
        None => crate::calibration::acceptance::judge(
            (
                before.validation_rms_mm,
                after.validation_rms_mm,
                after.identification_rms_mm,
            ),
            &ident,
            &valid,
            weak,
        ),
    };
    // Poses that barely move some joints: is the model known across their ranges?
    let held_names: Vec<String> = fit.held.iter().map(|h| h.name.clone()).collect();
    let (estimated_params, estimated_prior): (Vec<kinecal::Param>, Vec<Option<f64>>) = params
        .iter()
        .zip(&prior_sigma)
        .filter(|(p, _)| !held_names.contains(&p.name(&fit.robot).to_string()))
        .unzip();
    if let Some(m) = crate::calibration::extrapolation::check(
        (&nominal, &fit.robot),
        (&estimated_params, &estimated_prior),
        (&ident, &valid),
        after.identification_rms_mm / 3f64.sqrt(),
    ) {
        report.acceptance = Some(crate::calibration::extrapolation::refuse(
            report.acceptance.take(),
            m,
        ));
    }
    report.cross_validated = cross;
    report.held_out_worse = report.acceptance.as_ref().map(|a| a.held_out_worse);
    // Only what `--residuals` writes: a row per observation (~90 MB for a million).
    let residuals = if opts.residuals {
        crate::calibration::residual_table::ResidualTable::of(
            (&nominal, &fit.robot),
            ((&ident_set, &ident), (&valid_set, &valid)),
            validated,
            &observed.names,
        )
    } else {
        Default::default()
    };
    Ok(Identified {
        report,
        model,
        robot: fit.robot,
        residuals,
    })
}

/// The verdict on a run: whether its numbers can be taken as a calibration.
struct Verdict {
    converged: bool,
    stop: String,
    suspicious: Vec<String>,
    out: Option<String>,
}

fn stop_text<const N: usize>(
    fit: &Fit<N, HostValues>,
    rms_mm: f64,
    stalled: bool,
    stall_rms_mm: f64,
) -> String {
    use crate::output::numfmt::sig;
    use kinecal::identify::lm::LmStop;
    let how = match fit.stop {
        Some(LmStop::MaxIterations) => "stopped at its iteration limit before converging",
        Some(LmStop::NoProgress) => "stalled (no step lowered the error any more)",
        Some(_) => "converged",
        None => "finished its iterations",
    };
    if stalled {
        format!(
            "{how} at an RMS error of {} mm, above {} mm: far above any tracker's noise, so the \
             model or the data are wrong (units, the joint columns' order or signs, a coupled \
             joint, the tool, the base: `kinecal check` names the likely one)",
            sig(rms_mm, 4),
            sig(stall_rms_mm, 3)
        )
    } else {
        how.to_string()
    }
}

/// Refuses (exit 2), for every method, data that cannot determine the model: each distinct
/// observation (joint readings and tool point) gives three equations, so `n` of them
/// determine at most `3n` parameters (a pose repeated adds none); a base fitted by
/// registration needs at least 3 poses.
fn enough_poses<const N: usize>(
    ident: &[kinecal::Measurement<f64, N>],
    params: usize,
    base_unknown: bool,
    data: &std::path::Path,
) -> anyhow::Result<()> {
    let need = params.div_ceil(3).max(if base_unknown { 3 } else { 1 });
    // Distinct poses counted until there are enough (a million poses: the first few hundred
    // settle it, where sorting all of them took a fifth of a second); all of them when there
    // are too few, so that the refusal says how many there are.
    let mut seen = std::collections::HashSet::with_capacity(need.min(ident.len()));
    for m in ident {
        seen.insert((m.q.map(f64::to_bits), m.tool));
        if seen.len() >= need {
            return Ok(());
        }
    }
    let (poses, distinct) = (ident.len(), seen.len());
    let repeated = if distinct < poses {
        format!(" ({distinct} distinct: the others repeat them)")
    } else {
        String::new()
    };
    crate::refuse!(
        "{}: {poses} poses{repeated} to identify {params} parameters from; at least {need} \
         distinct ones are needed (3 equations per pose{}): measure more poses, or hold \
         parameters with --fix",
        data.display(),
        if base_unknown {
            ", and 3 poses for the base estimate"
        } else {
            ""
        }
    );
}

/// What every estimated parameter did, in the order of the parameter list.
fn changes<const N: usize>(
    start: &HostRobot<N>,
    fit: &Fit<N, HostValues>,
    params: &[kinecal::Param],
    base_unknown: bool,
) -> Vec<Change> {
    let from = named_values(start, params);
    let to = named_values(&fit.robot, params);
    params
        .iter()
        .filter_map(|p| {
            let name = p.name(&fit.robot).to_string();
            let (a, b) = (*from.get(&name)?, *to.get(&name)?);
            let share = fit.prior.get(&name);
            Some(Change {
                sigma: fit.sigma.get(&name).copied(),
                data_sigma: share.map_or(fit.sigma.get(&name).copied(), |s| s.data_sigma),
                prior_sigma: share.map(|s| s.prior_sigma),
                data_share: share.map(|s| s.data_share),
                length: p.is_length(),
                free_start: matches!(p, kinecal::Param::Effect(_)) || (p.is_base() && base_unknown),
                nominal: a,
                calibrated: b,
                change: b - a,
                name,
            })
        })
        .collect()
}

/// Parameters of effects the model file already carries (identified along with the geometry).
fn existing_effect_params<const N: usize>(
    robot: &HostRobot<N>,
    have: &[kinecal::Param],
) -> Vec<kinecal::Param> {
    (0..robot.effects().values().len())
        .map(|k| kinecal::Param::Effect(k as u16))
        .filter(|p| !have.contains(p))
        .collect()
}

/// The report of a finished fit.
#[allow(clippy::too_many_arguments)]
fn report<const N: usize>(
    method: Method,
    (file, tilts): (&RobotFile, &[usize]),
    fit: &Fit<N, HostValues>,
    (ident, valid): (usize, usize),
    (before, after): (Residuals, Residuals),
    seconds: f64,
    changes: Vec<Change>,
    verdict: &Verdict,
) -> IdentifyReport {
    let params = crate::calibration::model_params(&fit.robot, tilts);
    IdentifyReport {
        method: method.id().to_string(),
        n_identification: ident,
        n_validation: valid,
        tool_unknown: file.tool_unknown(),
        before,
        after,
        iterations: fit.iterations,
        evaluations: fit.evaluations,
        seconds,
        parameters: named_values(&fit.robot, &params),
        unidentifiable: fit.unidentifiable.clone(),
        held: fit.held.clone(),
        changes,
        converged: verdict.converged,
        stop: verdict.stop.clone(),
        suspicious: verdict.suspicious.clone(),
        out: verdict.out.clone(),
        fitness_history: fit.history.clone(),
        per_point: None,
        chi2_per_dof: None,
        stray_points: None,
        notes: Vec::new(),
        observations: None,
        held_out_worse: None,
        acceptance: None,
        cross_validated: None,
    }
}

/// The first tool point's coordinates (`tool.x`, `tool.y`, `tool.z`).
fn is_tool_point(p: Param) -> bool {
    matches!(p, Param::ToolX | Param::ToolY | Param::ToolZ)
}
