//! Identification from constraint observations already read: the application function under
//! `kinecal identify` on a constraint file (which reads the files, calls [`identify`] and
//! writes what it returns). The model and the groups' shapes are fitted together
//! ([`crate::constraints::fit`]) and judged on held-out groups: `holdout` keeps whole groups out
//! by identify's rule and seed, or a second session holds them.

use super::identify::Options;
use crate::calibration::method::Method;
use crate::calibration::selection::Selection;
use crate::calibration::stats::rms;
use crate::calibration::{named_values, Residuals};
use crate::constraints::effects::{add_effects, measurements};
use crate::constraints::read::{self, Group, Session};
use crate::constraints::report::{
    ConstraintIdentifyReport, Constraints, FittedPlane, FittedSocket, KindSummary,
};
use crate::constraints::shapes::{errors, held_out_error, points, Shape};
use crate::formats::robot_file::RobotFile;
use crate::reports::identify::Change;
use crate::HostRobot;
use kinecal::Param;
use std::time::Instant;

/// What [`identify`] fits: the robot file and its model, the session (rows in radians and mm,
/// [`read::load`]) and, optionally, the groups of a second session to validate on.
pub struct Inputs<const N: usize> {
    pub file: RobotFile,
    pub nominal: HostRobot<N>,
    pub session: Session<N>,
    /// How error messages name the session (a path).
    pub data_origin: String,
    /// The held-out groups of `--validate` (then nothing of `session` is held out).
    pub validate: Option<Vec<Group<N>>>,
}

/// The result of [`identify`]: the report (`out` unset), the identified model as a robot file
/// (what `--out` writes unless `report.held_out_worse`), and the residual table when
/// [`Options::residuals`] asked for it.
pub struct Identified {
    pub report: ConstraintIdentifyReport,
    pub model: RobotFile,
    /// `--residuals`'s CSV (identification and held-out rows).
    pub residuals: Option<String>,
}

/// Why `fitted` (its constraints met to `rms_mm` RMS, its rows' `outliers`) is no calibration
/// of the robot file's model `nominal`, as the rest of a sentence that starts "the fit", or
/// `None`: the tracker path's guards ([`crate::calibration::arm_size`]): a few gross outliers
/// (a mistyped length), a fit that stretched the arm (a `length_mm` in another unit), turned a
/// joint or misplaced a stated tool point, that left the constraints above `stall_rms_mm` from
/// met (two sockets under one group name), or many gross outliers.
pub fn no_calibration<const N: usize>(
    (file, nominal): (&RobotFile, &HostRobot<N>),
    (fitted, outliers): (&HostRobot<N>, &crate::calibration::outliers::Outliers),
    rms_mm: f64,
    stall_rms_mm: f64,
) -> Option<String> {
    outliers
        .few()
        .or_else(|| {
            crate::calibration::arm_size::resized(nominal, fitted).map(|why| {
                format!(
                    "{why}; in a constraint file also each group's label and the unit of \
                     length_mm"
                )
            })
        })
        .or_else(|| crate::calibration::tool_check::stated_tool_slip(file, nominal, fitted))
        .or_else(|| {
            (rms_mm > stall_rms_mm || rms_mm.is_nan()).then(|| {
                format!(
                    "left the constraints {} mm RMS from met, above --stall-rms-mm {}: check \
                     each group's label (two sockets or planes under one name, a distance row \
                     in the wrong group), the length unit of length_mm, the tool and coupled \
                     joints",
                    crate::output::numfmt::sig(rms_mm, 4),
                    crate::output::numfmt::sig(stall_rms_mm, 3)
                )
            })
        })
        .or_else(|| outliers.reason())
}

/// Fits the model and the shapes to the identification groups and judges the model on the
/// held-out ones. Refuses another method than LM, misstated lengths and empty identification
/// sets; prints nothing.
pub fn identify<const N: usize>(
    options: &Options,
    inputs: Inputs<N>,
) -> anyhow::Result<Identified> {
    let Inputs {
        file,
        mut nominal,
        session,
        data_origin,
        validate,
    } = inputs;
    if options.method != Method::Lm {
        crate::refuse!(
            "a constraint file (kind column) is fitted with --method lm only: leave --method out"
        );
    }
    crate::constraints::shapes::check_lengths(&nominal, &session.groups, &data_origin)?;
    let sigma_stated = session.sigma_stated;
    let validated = validate.is_some();
    let (ident, valid) = match validate {
        Some(v) => (session.groups, v),
        None => split_groups(session, &options.holdout, options.seed)?,
    };
    if ident.is_empty() {
        crate::refuse!("--holdout leaves no groups to identify from: hold out fewer");
    }
    // A thermal-expansion term of the file without `reference_c` and with a zero coefficient
    // is referred to the identification rows' mean temperature (and written with it), as on
    // tracker points.
    let mut file = file;
    if file.with_thermal_reference(crate::calibration::thermal::mean_temperature(
        &measurements(&ident),
    )) {
        nominal = file
            .to_robot::<N>()
            .map_err(|e| anyhow::anyhow!("{}: {e}", file.name))?;
    }
    let ident_session = Session {
        groups: ident.clone(),
        sigma_stated,
    };
    let base_unknown = !(file.base_known() && ident_session.has_points());
    let extra = add_effects(&mut nominal, &options.effects, &ident)?;
    let params = parameters(&nominal, &file, options, base_unknown, &extra)?;
    let t0 = Instant::now();
    let fitted = crate::constraints::fit::fit(&nominal, &ident, &params)?;
    let seconds = t0.elapsed().as_secs_f64();
    crate::constraints::fit::refuse_exact(&fitted, &ident, &data_origin)?;
    if let Some(w) = fitted
        .robot
        .effects()
        .thermal()
        .and_then(|(_, c, _)| crate::calibration::thermal::outside_materials(c))
    {
        crate::Tell::line(&mut crate::Stderr, &w);
    }
    let before_shapes = crate::constraints::fit::shapes_of(&nominal, &ident);
    let before = residuals(&nominal, &ident, &before_shapes, &valid);
    let after = residuals(&fitted.robot, &ident, &fitted.shapes, &valid);
    let name = |p: &Param| p.name(&fitted.robot).to_string();
    // The groups held out of the same file are searched too; a `--validate` file's are of
    // another session, whose errors say whether the model holds there.
    let outliers = crate::constraints::outliers::find(
        &fitted.robot,
        &ident,
        if validated { &[] } else { &valid },
    );
    let refused = no_calibration(
        (&file, &nominal),
        (&fitted.robot, &outliers),
        after.identification_rms_mm,
        options.stall_rms_mm,
    );
    // Rows far from their group's other rows at the robot file's model (a wrong group label)
    // pull any fit: a failed fit names them and their likely cause rather than what they made
    // it do (an arm 1.3 times as long, a bar offset, outliers of any kind).
    let far_rows = crate::constraints::far_rows::find(
        &nominal,
        &[&ident[..], if validated { &[] } else { &valid[..] }].concat(),
    );
    let far = crate::constraints::far_rows::warning(&far_rows);
    // Bar lengths off by one constant look like a few wrong bars to the outlier rule: the
    // refusal names the constant too.
    let offset = crate::constraints::bar_offset::warning(&fitted.robot, &fitted.estimated, &ident);
    let refused = match (refused, &far, &offset) {
        (Some(r), Some(f), _) => Some(format!(
            "was pulled by {}: {f}; else it {r}",
            if far_rows.len() == 1 {
                "a row far from its group"
            } else {
                "rows far from their groups"
            }
        )),
        (Some(r), _, Some(o)) => Some(format!("{r}; yet {o}")),
        (r, _, _) => r,
    };
    // A fit that scaled every link by one factor from bar lengths alone is the bar's
    // certificate, not the arm: such a model, which can be worse than the nominal robot, is not
    // reported as a calibration.
    let refused = refused.or_else(|| {
        let fit = (&fitted.robot, &fitted.estimated[..]);
        crate::constraints::bar_scale::refusal(&nominal, fit, &ident)
    });
    let changes = changes(&nominal, &fitted, &file, base_unknown);
    let suspicious: Vec<String> = changes
        .iter()
        .filter(|c| c.beyond_tolerance(options.tolerance_mm, options.tolerance_deg))
        .map(|c| c.name.clone())
        .collect();
    // The tool point and the last joint's d that moved beyond a tolerance: a probe other than
    // the robot file's tool.
    let last_d = Param::D(N as u8 - 1).name(&nominal).to_string();
    let tool_moved: Vec<String> = suspicious
        .iter()
        .filter(|n| n.starts_with("tool") || **n == last_d)
        .cloned()
        .collect();
    let weak: Vec<String> = changes
        .iter()
        .filter(|c| c.barely_determined(options.tolerance_mm, options.tolerance_deg))
        .map(|c| c.name.clone())
        .collect();
    let acceptance = judge_groups(&before, &after, &ident, &valid, weak);
    let stray_points = outliers.strays().filter(|_| refused.is_none());
    let chi2_per_dof = sigma_stated
        .then(|| {
            crate::constraints::outliers::chi2_per_dof(
                &fitted.robot,
                &ident,
                &fitted.shapes,
                &fitted.estimated,
            )
        })
        .flatten();
    let tilts = crate::calibration::tilted_joints(&file.tilt_joints(), &fitted.estimated);
    let all = crate::calibration::model_params(&fitted.robot, &tilts);
    let report = ConstraintIdentifyReport {
        method: "lm".into(),
        count_unit: "groups".into(),
        n_identification: ident.len(),
        n_validation: valid.len(),
        n_identification_rows: ident.iter().map(|g| g.rows.len()).sum(),
        n_validation_rows: valid.iter().map(|g| g.rows.len()).sum(),
        before,
        after,
        iterations: fitted.iterations,
        evaluations: fitted.evaluations,
        seconds,
        parameters: named_values(&fitted.robot, &all),
        estimated: fitted.estimated.iter().map(name).collect(),
        unidentifiable: fitted.unidentifiable.iter().map(name).collect(),
        suspicious: suspicious.clone(),
        converged: fitted.converged && after.identification_rms_mm.is_finite() && refused.is_none(),
        stray_points: stray_points.clone(),
        warnings: stray_points
            .iter()
            .map(|s| s.warning())
            .chain(
                crate::constraints::fit::thin_warning(&fitted, &ident)
                    .filter(|_| refused.is_none()),
            )
            .chain(offset.filter(|_| refused.is_none()))
            .chain(
                chi2_per_dof.filter(|_| refused.is_none()).and_then(|c| {
                    crate::constraints::outliers::chi2_warning(c, &ident, &tool_moved)
                }),
            )
            .chain(far.filter(|_| refused.is_none()))
            .chain(crate::calibration::acceptance::narrow_joints(
                &measurements(&ident),
            ))
            .chain(held_free(&nominal, options, &fitted.unidentifiable))
            .chain(
                crate::reports::identify::suspicious_warning(&suspicious)
                    .filter(|_| refused.is_none()),
            )
            .map(|w| format!("warning: {w}"))
            .collect(),
        chi2_per_dof,
        stop: refused.unwrap_or_else(|| fitted.stop.clone()),
        held_out_worse: acceptance.as_ref().map(|a| a.held_out_worse),
        acceptance,
        constraints: constraints(
            &ident,
            (&nominal, &before_shapes),
            (&fitted.robot, &fitted.shapes),
        ),
        out: None,
    };
    let residuals = options.residuals.then(|| {
        crate::constraints::residual_table::to_csv(
            (&nominal, &before_shapes),
            (&fitted.robot, &fitted.shapes),
            &ident,
            &valid,
        )
    });
    // A base the constraints could not see is written only as the robot file gave it: a model
    // without `[base]` takes targets in the robot base frame (`compensate` says so), where a
    // `[base]` of zeros would pass for a measured one.
    let base_seen = !fitted.unidentifiable.iter().any(|p| p.is_base());
    let mut model = RobotFile::from_robot(
        &format!("{} (identified)", file.name),
        &fitted.robot,
        file.base_known() || base_seen,
        &tilts,
    )
    .with_tool_names(&file.tool_names());
    if model.tool.rpy_deg.is_none() {
        model.tool.rpy_deg = file.tool.rpy_deg;
    }
    model.prior = file.prior;
    Ok(Identified {
        report,
        model,
        residuals,
    })
}

/// The groups `holdout` keeps out (whole groups, by identify's rule and `seed`): the
/// identification groups and the held-out ones.
pub(crate) fn split_groups<const N: usize>(
    session: Session<N>,
    holdout: &crate::calibration::inputs::HoldoutArgs,
    seed: u64,
) -> anyhow::Result<(Vec<Group<N>>, Vec<Group<N>>)> {
    let mask = crate::calibration::held_out_mask(
        session.groups.len(),
        holdout.holdout,
        holdout.split,
        seed,
    )?;
    let (mut ident, mut valid) = (Vec::new(), Vec::new());
    for (g, held) in session.groups.into_iter().zip(mask) {
        if held {
            valid.push(g);
        } else {
            ident.push(g);
        }
    }
    Ok((ident, valid))
}

/// The parameters the fit estimates: [`crate::constraints::fit::candidates`] narrowed by
/// `--fix/--free/--only`.
fn parameters<const N: usize>(
    nominal: &HostRobot<N>,
    file: &RobotFile,
    options: &Options,
    base_unknown: bool,
    extra: &[Param],
) -> anyhow::Result<Vec<Param>> {
    let mut params = crate::constraints::fit::candidates(nominal, file, base_unknown, extra)?;
    crate::calibration::selection::apply(
        &mut params,
        nominal,
        &Selection {
            only: &options.only,
            free: &options.free,
            fix: &options.fix,
        },
    )?;
    Ok(params)
}

/// The acceptance of a model on held-out groups (`before`, `after`: the starting model's and
/// the model's figures), with the joint ranges of the identification and held-out rows and the
/// parameters the data barely determine (`weak`).
pub(crate) fn judge_groups<const N: usize>(
    before: &Residuals,
    after: &Residuals,
    ident: &[Group<N>],
    valid: &[Group<N>],
    weak: Vec<String>,
) -> Option<crate::calibration::acceptance::Acceptance> {
    crate::calibration::acceptance::judge(
        (
            before.validation_rms_mm,
            after.validation_rms_mm,
            after.identification_rms_mm,
        ),
        &measurements(ident),
        &measurements(valid),
        weak,
    )
}

/// What each estimated parameter of `fitted` did from `nominal`, with its 1-σ from the data
/// (file units), as the tracker report's [`Change`] (whose tolerance tests name the suspicious
/// and the barely determined parameters): a base estimated from tracker points of an unknown
/// base, a tool point the file leaves unknown and effect values are not held to a tolerance.
fn changes<const N: usize>(
    nominal: &HostRobot<N>,
    fitted: &crate::constraints::fit::Fitted<N>,
    file: &RobotFile,
    base_unknown: bool,
) -> Vec<Change> {
    fitted
        .estimated
        .iter()
        .zip(&fitted.data_sigma)
        .filter_map(|(p, sigma)| {
            let value = |r: &HostRobot<N>| kinecal::model::param::value(r, *p);
            let unit = |v: f64| match p {
                Param::Effect(_) => v,
                _ if p.is_length() => v,
                _ => v.to_degrees(),
            };
            let (a, b) = (unit(value(nominal)?), unit(value(&fitted.robot)?));
            let tool_point = matches!(p, Param::ToolX | Param::ToolY | Param::ToolZ);
            Some(Change {
                name: p.name(&fitted.robot).to_string(),
                length: p.is_length(),
                free_start: matches!(p, Param::Effect(_))
                    || (p.is_base() && base_unknown)
                    || (tool_point && file.tool_unknown()),
                nominal: a,
                calibrated: b,
                change: b - a,
                sigma: sigma.map(unit),
                data_sigma: sigma.map(unit),
                prior_sigma: None,
                data_share: None,
            })
        })
        .collect()
}

/// The one-line warning when parameters `--free` names are held all the same (`held`: what the
/// constraints cannot determine at the robot file's model), or `None`.
fn held_free<const N: usize>(
    nominal: &HostRobot<N>,
    options: &Options,
    held: &[Param],
) -> Option<String> {
    let freed =
        crate::calibration::selection::named("--free", &options.free, nominal).unwrap_or_default();
    let names: Vec<String> = held
        .iter()
        .filter(|p| freed.contains(p))
        .map(|p| p.name(nominal).to_string())
        .collect();
    if names.is_empty() {
        return None;
    }
    // A tool point on the last joint's axis: that joint's alpha and a move no point there, and
    // a probe off the axis would (the robot file's tool decides what can be estimated).
    let tool = nominal.tool();
    let last = |p: &Param| matches!(p, Param::Alpha(j) | Param::A(j) if *j as usize + 1 == N);
    let on_axis = tool.x.hypot(tool.y) < 1e-6 && held.iter().any(|p| freed.contains(p) && last(p));
    Some(format!(
        "--free {}: held all the same: these constraints cannot determine {} at the robot \
         file's model, where what a fit can estimate is decided{}",
        names.join(", "),
        if names.len() == 1 { "it" } else { "them" },
        if on_axis {
            " (its tool point lies on the last joint's axis, where that joint's alpha and a \
             move no tool point): if the probe measured is not the robot file's tool, give its \
             nominal offset in [tool] and run again"
        } else {
            ": measure what moves them (another kind of constraint, tracker points) or leave \
             them out of --free"
        }
    ))
}

/// Before/after figures: the RMS of the identification rows against the fit's shapes, and per
/// held-out group its residual against its own refitted shape (mm).
pub(crate) fn residuals<const N: usize>(
    robot: &HostRobot<N>,
    ident: &[Group<N>],
    shapes: &[Shape],
    valid: &[Group<N>],
) -> Residuals {
    let e: Vec<f64> = ident
        .iter()
        .zip(shapes)
        .flat_map(|(g, s)| errors(g, &points(robot, g), s))
        .collect();
    let v: Vec<f64> = valid.iter().map(|g| held_out_error(robot, g)).collect();
    let held = !v.is_empty();
    Residuals {
        identification_rms_mm: rms(&e),
        validation_rms_mm: held.then(|| rms(&v)),
        validation_mean_mm: held.then(|| v.iter().map(|x| x.abs()).sum::<f64>() / v.len() as f64),
        validation_max_mm: held.then(|| v.iter().fold(0.0, |m: f64, x| m.max(x.abs()))),
        identification_rms_deg: None,
        validation_rms_deg: None,
    }
}

/// Per kind: counts and RMS before and after; the fitted socket centres and planes.
pub(crate) fn constraints<const N: usize>(
    groups: &[Group<N>],
    (nominal, before): (&HostRobot<N>, &[Shape]),
    (robot, after): (&HostRobot<N>, &[Shape]),
) -> Constraints {
    let mut out = Constraints::default();
    for (kind, of) in read::by_kind(groups) {
        let err = |r: &HostRobot<N>, s: &[Shape]| {
            let e: Vec<f64> = of
                .iter()
                .flat_map(|&k| errors(&groups[k], &points(r, &groups[k]), &s[k]))
                .collect();
            rms(&e)
        };
        out.kinds.push(KindSummary {
            kind: kind.id().into(),
            groups: of.len(),
            rows: of.iter().map(|&k| groups[k].rows.len()).sum(),
            before_rms_mm: err(nominal, before),
            after_rms_mm: err(robot, after),
        });
    }
    for (g, s) in groups.iter().zip(after) {
        match s {
            Shape::Centre(c) => out.sockets.push(FittedSocket {
                group: g.name.clone(),
                centre_mm: [c.x, c.y, c.z],
            }),
            Shape::Plane(n, d) => out.planes.push(FittedPlane {
                group: g.name.clone(),
                normal: [n.x, n.y, n.z],
                offset_mm: *d,
            }),
            Shape::None => {}
        }
    }
    out
}
