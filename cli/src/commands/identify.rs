//! `kinecal identify`: fits the model to measurements and reports residuals before and after.

use super::inputs::InputArgs;
use crate::calibration::method::Method;
use crate::calibration::selection::Selection;
use crate::calibration::{add_effect, named_values, weights, EffectRequest, Fit, Residuals};
use crate::formats::observations::{observe, ObservationArgs, Observed};
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::reports::identify::{Change, IdentifyReport, ObservationSummary, PointResiduals};
use crate::{with_joints, VCAP};
use kinecal::model::param::ParamSet;
use kinecal::Param;
use kinecal::{Measurement, Robot};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kinecal identify` (docs/formats.md, docs/walkthrough.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot file, measurements (and the `--validate` file's) units.
    #[command(flatten)]
    pub input: InputArgs,
    /// Identification method.
    #[arg(long, value_enum, default_value = "lm")]
    pub method: Method,
    /// Held-out poses: `--holdout` a fraction (< 1) or a count (≥ 1), `--split` which ones
    /// (last, random, every:K).
    #[command(flatten)]
    pub holdout: super::inputs::HoldoutArgs,
    /// Validate on a separate measurement file.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Add a joint correction to the model: KIND:JOINT[:ARG] (ARG: cyclic order, or table knot
    /// spacing in degrees, default 3.6). Repeatable.
    #[arg(long = "effect")]
    pub effects: Vec<EffectRequest>,
    /// Seed of the stochastic methods.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the identified model (robot TOML; written atomically, never over an input).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Hold these parameters at their file values: names as printed (d6, theta1, tool.z,
    /// base.rz, joint-table1[0], …) or groups (base, tool, geometry, theta, effects,
    /// joint-table2, …). Repeatable, or comma-separated.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub fix: Vec<String>,
    /// Estimate these parameters too (for example base when `[base]` is given but not
    /// trusted, or beta3 for a tilt); names or groups as for --fix.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub free: Vec<String>,
    /// Estimate only these parameters (names or groups as for --fix) and hold everything
    /// else: a quick re-calibration (`--only base,theta2,theta3` after a re-mastering).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub only: Vec<String>,
    /// The prior on every parameter's change: `off`, or KIND=SIGMA over the robot file's
    /// `[prior]` and the defaults (length_mm 5, angle_deg 0.5, tool_mm 10, tool_deg 2,
    /// base_mm 10, base_deg 1, effect 0 = off). Comma-separated.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub prior: Vec<String>,
    /// Write each pose's residual (identification and held-out; per axis, with the pose index
    /// and its line in the file) to this CSV.
    #[arg(long)]
    pub residuals: Option<PathBuf>,
    /// A length parameter that moves further than this from its file value is reported as
    /// suspicious (a manufacturing tolerance; JSON `suspicious`).
    #[arg(long, default_value_t = 20.0)]
    pub tolerance_mm: f64,
    /// The same for angle parameters, degrees.
    #[arg(long, default_value_t = 2.0)]
    pub tolerance_deg: f64,
    /// A fit whose identification RMS stays above this has stalled far above any tracker's
    /// noise: reported as not converged (exit 3).
    #[arg(long, default_value_t = 5.0)]
    pub stall_rms_mm: f64,
    /// Orientation and σ columns: how they are used.
    #[command(flatten)]
    pub obs: ObservationArgs,
}

/// Refuses `--out` and `--residuals` over an input (tracker points and constraint files alike).
pub(super) fn refuse_outputs_over_inputs(args: &Args) -> anyhow::Result<()> {
    for out in [args.out.as_deref(), args.residuals.as_deref()] {
        crate::output::atomic::refuse_model_over_inputs(
            out,
            &args.input.robot,
            &args.input.data,
            args.validate.as_deref(),
        )?;
    }
    Ok(())
}

/// Runs the subcommand: fits the model (and writes it with `--out`); the report's
/// `converged` says whether the numbers are a calibration.
pub fn run(args: &Args) -> anyhow::Result<IdentifyReport> {
    refuse_outputs_over_inputs(args)?;
    let n = RobotFile::load(&args.input.robot)?.joint_count();
    with_joints!(n, N => run_with_joints::<N>(args))
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<IdentifyReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let load = |p: &std::path::Path| -> anyhow::Result<Observed<N>> {
        let ds = crate::formats::loading::load_measurements(
            p,
            &input.units,
            &nominal,
            file.base_known(),
        )?;
        observe(&ds, &file, &args.obs, &p.display().to_string())
    };
    let observed = load(&input.data)?;
    super::inputs::any_rows(&observed.poses, &input.data)?;
    let validate = match &args.validate {
        Some(v) => Some((load(v)?, v.display().to_string())),
        None => None,
    };
    let inputs = Inputs {
        file,
        nominal,
        observed,
        robot_origin: input.robot.display().to_string(),
        data_origin: input.data.display().to_string(),
        validate,
    };
    let mut done = identify(args, inputs)?;
    if let Some(path) = &args.residuals {
        crate::output::atomic::write_atomic(path, done.residuals.to_csv().as_bytes()).map_err(
            |e| crate::refused(format!("--residuals {}: cannot write: {e}", path.display())),
        )?;
    }
    if let Some(out) = &args.out {
        if done.report.held_out_worse == Some(true) {
            // Not a calibration: nothing a later step could mistake for one is written.
            eprintln!(
                "note: {} not written: the model predicts the held-out poses worse than the \
                 model it started from",
                out.display()
            );
        } else {
            done.model.save(out)?;
            done.report.out = Some(out.display().to_string());
        }
    }
    warn(&done.report);
    Ok(done.report)
}

/// What [`identify`] fits, in memory: the robot file and its model, the observations (already
/// in mm and degrees, through [`crate::formats::units`] and [`observe`]) and, optionally, the
/// observations to validate on; each named as error messages name it (a path, or what the
/// caller calls it).
pub struct Inputs<const N: usize> {
    pub file: RobotFile,
    pub nominal: Robot<f64, N, VCAP>,
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
    pub robot: Robot<f64, N, VCAP>,
    /// Each pose's residual (what `--residuals` writes; empty without `--residuals`).
    pub residuals: crate::calibration::residual_table::ResidualTable,
}

/// `kinecal identify` in memory: fits the model of `inputs` with the options of `args` (its
/// paths, `--validate` and `--out` are not read: the data are in `inputs`), exactly as the
/// command does. Refused input is a [`crate::Refused`] error; a fit that did not converge is
/// `report.converged == false`. Prints nothing (the command prints the warnings, [`warn`]).
pub fn identify<const N: usize>(args: &Args, inputs: Inputs<N>) -> anyhow::Result<Identified<N>> {
    let Inputs {
        file,
        mut nominal,
        observed,
        robot_origin,
        data_origin,
        validate,
    } = inputs;
    let data_path = std::path::Path::new(&data_origin);
    let super::inputs::Split {
        observed,
        ident,
        valid,
        ident_poses,
        valid_poses,
        pose_of,
        ident_set,
        valid_set,
    } = super::inputs::split_observed(
        observed,
        validate,
        (&args.holdout, args.seed),
        &data_origin,
    )?;
    for (flag, v) in [
        ("--tolerance-mm", args.tolerance_mm),
        ("--tolerance-deg", args.tolerance_deg),
        ("--stall-rms-mm", args.stall_rms_mm),
    ] {
        crate::check_positive(flag, v, 1e6)?;
    }
    // A thermal-expansion term of the file without `reference_c` is referred to the
    // identification data's mean temperature (and written with it).
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
        super::inputs::place_nominal(&mut nominal, &file, &ident, observed.six_d)?;
    // Effects requested on the command line join the model with zero values.
    let mut extra = Vec::new();
    for t in file.tilt_joints() {
        extra.push(kinecal::Param::Beta(t as u8));
    }
    for req in &args.effects {
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
        let range = joint_range(&ident, req.joint);
        extra.extend(add_effect(&mut nominal, req, range)?);
    }
    let mut params: Vec<kinecal::Param> = ParamSet::<64>::full(N, base_unknown)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    params.extend(existing_effect_params(&nominal, &params));
    params.extend(extra.iter().copied());
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
            only: &args.only,
            free: &args.free,
            fix: &args.fix,
        },
    )?;
    enough_poses(&ident, params.len(), base_unknown, data_path)?;
    let before = Residuals::of(&nominal, &ident, &valid);
    // The prior: the robot file's `[prior]` (or the defaults) with `--prior` over it; none on
    // what does not start from a file value.
    let prior = file.prior.unwrap_or_default().with_overrides(&args.prior)?;
    let prior_sigma = crate::calibration::prior::sigmas(&prior, &params, |p| {
        (p.is_base() && base_unknown)
            || (p.is_tool_rotation() && tool_axes_unknown)
            || (is_tool_point(p) && file.tool_unknown())
            || extra.contains(&p) && matches!(p, kinecal::Param::Effect(_))
    });
    let t0 = Instant::now();
    let run_method = |data: &[Measurement<f64, N>]| match args.method {
        Method::Lm => {
            crate::calibration::prior::fit_lm_with_prior(&nominal, &params, &prior_sigma, data)
        }
        m => crate::calibration::pso_search::identify(m, &nominal, &params, data, args.seed),
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
        &args.obs,
        ident_poses,
        params.len(),
    );
    let (fit, weighted) = weights::weighted_fit(&mut ident, &pose_of, &stated, how, run_method)?;
    let seconds = t0.elapsed().as_secs_f64();
    let after = Residuals::of(&fit.robot, &ident, &valid);
    let per_point =
        PointResiduals::per_point(&observed.names, (&nominal, &fit.robot), (&ident, &valid));
    let estimated = params.len().saturating_sub(fit.unidentifiable.len());
    let chi2_per_dof = if observed.sigma {
        weights::chi2_per_dof(&fit.robot, &ident, &stated, estimated)
    } else {
        None
    };
    let model = {
        let mut f = RobotFile::from_robot(
            &format!("{} (identified)", file.name),
            &fit.robot,
            true,
            &file.tilt_joints(),
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
        .filter(|c| c.beyond_tolerance(args.tolerance_mm, args.tolerance_deg))
        .map(|c| c.name.clone())
        .collect();
    let stalled = after.identification_rms_mm > args.stall_rms_mm;
    let converged = fit.solver_converged() && !stalled && after.identification_rms_mm.is_finite();
    let verdict = Verdict {
        converged,
        stop: stop_text(
            &fit,
            after.identification_rms_mm,
            stalled,
            args.stall_rms_mm,
        ),
        suspicious,
        out: None,
    };
    let mut report = report(
        args.method,
        &file,
        &fit,
        (ident_poses, valid_poses),
        (before, after),
        seconds,
        changes,
        &verdict,
    );
    report.per_point = per_point;
    report.chi2_per_dof = chi2_per_dof;
    report.observations = Some(ObservationSummary::new(
        &observed,
        ident.len(),
        args.obs.deg_weight_mm,
        &weighted,
    ));
    // Judged on the held-out poses against the model the fit started from.
    let weak: Vec<String> = report
        .changes
        .iter()
        .filter(|c| c.barely_determined(args.tolerance_mm, args.tolerance_deg))
        .map(|c| c.name.clone())
        .collect();
    report.acceptance = crate::calibration::acceptance::judge(
        (
            before.validation_rms_mm,
            after.validation_rms_mm,
            after.identification_rms_mm,
        ),
        &ident,
        &valid,
        weak,
    );
    report.held_out_worse = report.acceptance.as_ref().map(|a| a.held_out_worse);
    // Only what `--residuals` writes: a row per observation (~90 MB for a million).
    let residuals = if args.residuals.is_some() {
        crate::calibration::residual_table::ResidualTable::of(
            (&nominal, &fit.robot),
            ((&ident_set, &ident), (&valid_set, &valid)),
            args.validate.is_some(),
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

/// The warnings of a finished fit on stderr: χ²/dof far from 1, suspicious parameters, not
/// converged.
pub fn warn(report: &IdentifyReport) {
    if let Some(c) = report.chi2_per_dof {
        if !(0.25..=4.0).contains(&c) {
            eprintln!(
                "warning: χ²/dof = {} with the file's σ: the residuals are {}× what the stated \
                 uncertainties explain ({}); the fit added an error floor (JSON `observations`)",
                crate::output::numfmt::sig(c, 3),
                crate::output::numfmt::sig(c.sqrt(), 3),
                if c > 1.0 {
                    "the model misses an effect (kinecal diagnose) or the σ are too small"
                } else {
                    "the σ are too large"
                }
            );
        }
    }
    if !report.suspicious.is_empty() {
        eprintln!(
            "warning: {} moved further than a manufacturing tolerance explains: check the units, \
             the tool point and the robot file (--tolerance-mm/--tolerance-deg set the limit)",
            report.suspicious.join(", ")
        );
    }
    if let Some(m) = report.acceptance.as_ref().and_then(|a| a.message.as_ref()) {
        let level = if report.held_out_worse == Some(true) {
            "error"
        } else {
            "warning"
        };
        eprintln!("{level}: {m}");
    }
    if !report.converged {
        eprintln!(
            "error: the fit {}; these numbers are not a calibration (exit 3)",
            report.stop
        );
    }
}

/// The verdict on a run: whether its numbers can be taken as a calibration.
struct Verdict {
    converged: bool,
    stop: String,
    suspicious: Vec<String>,
    out: Option<String>,
}

fn stop_text<const N: usize>(
    fit: &Fit<N, VCAP>,
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
             model or the data are wrong (units, a coupled joint, the tool, the base)",
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
    let mut keys: Vec<([u64; N], u8)> = ident
        .iter()
        .map(|m| (m.q.map(f64::to_bits), m.tool))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let (poses, distinct) = (ident.len(), keys.len());
    let need = params.div_ceil(3).max(if base_unknown { 3 } else { 1 });
    if distinct < need {
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
    Ok(())
}

/// What every estimated parameter did, in the order of the parameter list.
fn changes<const N: usize>(
    start: &Robot<f64, N, VCAP>,
    fit: &Fit<N, VCAP>,
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
    robot: &Robot<f64, N, VCAP>,
    have: &[kinecal::Param],
) -> Vec<kinecal::Param> {
    (0..robot.effects().values().len())
        .map(|k| kinecal::Param::Effect(k as u16))
        .filter(|p| !have.contains(p))
        .collect()
}

/// (min, max) of joint `j` over the data, rad.
pub fn joint_range<const N: usize>(data: &[Measurement<f64, N>], j: usize) -> (f64, f64) {
    data.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
            (lo.min(m.q[j]), hi.max(m.q[j]))
        })
}

/// The report of a finished fit.
#[allow(clippy::too_many_arguments)]
fn report<const N: usize>(
    method: Method,
    file: &RobotFile,
    fit: &Fit<N, VCAP>,
    (ident, valid): (usize, usize),
    (before, after): (Residuals, Residuals),
    seconds: f64,
    changes: Vec<Change>,
    verdict: &Verdict,
) -> IdentifyReport {
    let params = crate::calibration::model_params(&fit.robot, &file.tilt_joints());
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
        observations: None,
        held_out_worse: None,
        acceptance: None,
    }
}

/// The first tool point's coordinates (`tool.x`, `tool.y`, `tool.z`).
fn is_tool_point(p: Param) -> bool {
    matches!(p, Param::ToolX | Param::ToolY | Param::ToolZ)
}

/// With the base estimated: the base is a rigid transform before row 1, which row 1's
/// constant part only repeats (T_1(q) = Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta)·Tz(d)·Rz(q)), so
/// alpha1, a1, beta1, theta1 and d1 are held at their file values and the base takes what they
/// would. Row 1 stays the robot's own (an import exports back into its URDF) and the
/// tracker's frame stays in the base. `--free` estimates them anyway.
pub fn hold_first_row(params: &mut Vec<Param>) {
    params.retain(|p| {
        !matches!(
            p,
            Param::Alpha(0) | Param::A(0) | Param::Beta(0) | Param::Theta(0) | Param::D(0)
        )
    });
}
