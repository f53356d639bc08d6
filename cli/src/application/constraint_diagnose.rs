//! The discrepancy search on constraint observations already read: the application function
//! under `kinecal diagnose` on a constraint file (the command reads the files, calls
//! [`diagnose`], prints its warnings and writes the model it returns). The held-out groups are
//! split off as `identify` splits them, the search runs on the rest
//! ([`crate::constraints::diagnose`]), and the model with what it found is judged on them.

use crate::calibration::acceptance::NO_DIFFERENCE_MM;
use crate::calibration::stats::rms;
use crate::constraints::diagnose::{fit_with, request_text, search, Round, SearchOptions};
use crate::constraints::diagnose_report::{ConstraintDiagnoseReport, FoundEffect, HeldOut};
use crate::constraints::read::{self, Session};
use crate::constraints::shapes::held_out_error;
use crate::formats::robot_file::RobotFile;
use crate::HostRobot;

/// How the search runs and which groups are held out (`diagnose`'s flags).
pub struct Options {
    pub search: SearchOptions,
    /// `--holdout`, `--split` (identify's rule, whole groups, drawn by `search.seed`).
    pub holdout: crate::calibration::inputs::HoldoutArgs,
    /// `--stall-rms-mm`: a geometric fit that leaves the constraints farther from met is no
    /// calibration.
    pub stall_rms_mm: f64,
}

/// What [`diagnose`] searches: the robot file and its model, the session (rows in radians and
/// mm, [`read::load`]) and how messages name the session.
pub struct Inputs<const N: usize> {
    pub file: RobotFile,
    pub nominal: HostRobot<N>,
    pub session: Session<N>,
    pub data_origin: String,
}

/// The result of [`diagnose`]: the report (`out` unset), the extended model as a robot file
/// when it is a calibration (none when the geometric fit is none or the model predicts the
/// held-out groups worse), and the warnings about the rows to print.
pub struct Diagnosed {
    pub report: ConstraintDiagnoseReport,
    pub model: Option<RobotFile>,
    pub warnings: Vec<String>,
}

/// Searches the identification groups for what the geometry misses, fits the model with what
/// was found and judges it on the held-out groups; refuses misstated lengths. Prints nothing.
pub fn diagnose<const N: usize>(options: &Options, inputs: Inputs<N>) -> anyhow::Result<Diagnosed> {
    let Inputs {
        file,
        nominal,
        session,
        data_origin: origin,
    } = inputs;
    crate::constraints::shapes::check_lengths(&nominal, &session.groups, &origin)?;
    let sigma_stated = session.sigma_stated;
    let (ident, valid) =
        super::constraints::split_groups(session, &options.holdout, options.search.seed)?;
    let opts = options.search;
    let geometric = fit_with(&file, &nominal, &[], &ident)?;
    crate::constraints::fit::refuse_exact(&geometric, &ident, &origin)?;
    let s = search(&file, &nominal, &ident, &opts)?;
    let extended = fit_with(&file, &nominal, &s.found, &ident)?;
    // The search's groups only, as on tracker points: the held-out groups' errors under the
    // geometry hold what the search is to find.
    let outliers = crate::constraints::outliers::find(&geometric.robot, &ident, &[]);
    let resized = super::constraints::no_calibration(
        (&file, &nominal),
        (&geometric.robot, &outliers),
        rms(&ident
            .iter()
            .map(|g| held_out_error(&geometric.robot, g))
            .collect::<Vec<f64>>()),
        options.stall_rms_mm,
    )
    .or_else(|| {
        let fit = (&geometric.robot, &geometric.estimated[..]);
        crate::constraints::bar_scale::refusal(&nominal, fit, &ident)
    });
    let held_out = if valid.is_empty() {
        None
    } else {
        let e = |r: &crate::HostRobot<N>| {
            rms(&valid
                .iter()
                .map(|g| held_out_error(r, g))
                .collect::<Vec<f64>>())
        };
        Some(HeldOut {
            groups: valid.len(),
            nominal_mm: e(&nominal),
            geometric_mm: e(&geometric.robot),
            extended_mm: e(&extended.robot),
        })
    };
    let held_out_worse = held_out.as_ref().is_some_and(|h| {
        h.extended_mm.is_nan() || h.extended_mm > h.geometric_mm + NO_DIFFERENCE_MM
    });
    let effect_params: Vec<kinecal::Param> = extended
        .estimated
        .iter()
        .copied()
        .filter(|p| matches!(p, kinecal::Param::Effect(_) | kinecal::Param::Beta(_)))
        .collect();
    let values = crate::calibration::named_values(&extended.robot, &effect_params);
    let accepted: Vec<&Round> = s.rounds.iter().filter(|r| r.accepted).collect();
    let found = s
        .found
        .iter()
        .zip(&accepted)
        .map(|(req, round)| {
            let joint = req.joint + 1;
            let prefix = match req.kind.as_str() {
                "axis-tilt" => format!("beta{joint}"),
                "joint-cyclic" => format!("joint-cyclic{joint}.n{}.", req.arg.unwrap_or(1.0)),
                k if k == crate::formats::robot_file::THERMAL => k.to_string(),
                k => format!("{k}{joint}"),
            };
            FoundEffect {
                effect: req.kind.clone(),
                joint,
                request: request_text(req),
                values: values
                    .iter()
                    .filter(|(n, _)| n.starts_with(&prefix))
                    .map(|(n, v)| (n.clone(), *v))
                    .collect(),
                validation_rms_mm: round.cv_rms_after_mm,
            }
        })
        .collect();
    let (validation, baseline, final_rms) = match &held_out {
        Some(h) => ("held-out groups", h.geometric_mm, h.extended_mm),
        None => (
            "cross-validated groups",
            s.cv_rms_geometric_mm,
            s.cv_rms_final_mm,
        ),
    };
    let noise_floor_mm = noise_floor(&ident);
    let mut warnings: Vec<String> = crate::constraints::fit::thin_warning(&geometric, &ident)
        .map(|w| format!("{origin}: {w}"))
        .into_iter()
        .collect();
    if resized.is_none() {
        let strays = crate::constraints::outliers::find(&extended.robot, &ident, &[]).strays();
        if let Some(s) = strays {
            warnings.push(format!("{origin}: {}", s.warning()));
        }
        let (robot, estimated) = (&extended.robot, &extended.estimated);
        let offset = crate::constraints::bar_offset::warning(robot, estimated, &ident);
        if let Some(w) = offset {
            warnings.push(format!("{origin}: {w}"));
        }
    }
    let model = (resized.is_none() && !held_out_worse).then(|| {
        let tilts: Vec<usize> = extended
            .estimated
            .iter()
            .filter_map(|p| match p {
                kinecal::Param::Beta(j) => Some(*j as usize),
                _ => None,
            })
            .chain(file.tilt_joints())
            .collect();
        // A base the constraints could not see only as the robot file gave it (see
        // `application::constraints::identify`).
        let base_seen = !extended.unidentifiable.iter().any(|p| p.is_base());
        let mut model = RobotFile::from_robot(
            &format!("{} (diagnosed)", file.name),
            &extended.robot,
            file.base_known() || base_seen,
            &tilts,
        )
        .with_tool_names(&file.tool_names());
        if model.tool.rpy_deg.is_none() {
            model.tool.rpy_deg = file.tool.rpy_deg;
        }
        model
    });
    let report = ConstraintDiagnoseReport {
        count_unit: "groups".into(),
        n_identification: ident.len(),
        n_validation: valid.len(),
        folds: opts.folds,
        validation: validation.into(),
        baseline_validation_rms_mm: baseline,
        final_validation_rms_mm: final_rms,
        noise_floor_mm,
        sigma_stated,
        chi2_per_dof: sigma_stated
            .then(|| {
                crate::constraints::outliers::chi2_per_dof(
                    &extended.robot,
                    &ident,
                    &extended.shapes,
                    &extended.estimated,
                )
            })
            .flatten(),
        causes: crate::constraints::outliers::causes(&ident),
        cv_rms_geometric_mm: s.cv_rms_geometric_mm,
        cv_rms_final_mm: s.cv_rms_final_mm,
        rounds: s.rounds,
        found,
        held_out,
        held_out_worse,
        resized,
        out: None,
    };
    Ok(Diagnosed {
        report,
        model,
        warnings,
    })
}

/// What the rows' stated σ alone leaves in each group's error, as RMS over the groups (mm; see
/// [`ConstraintDiagnoseReport::noise_floor_mm`]).
fn noise_floor<const N: usize>(groups: &[read::Group<N>]) -> f64 {
    let e: Vec<f64> = groups
        .iter()
        .map(|g| {
            let k = g.rows.len() as f64;
            let sigma = rms(&g.rows.iter().map(|r| r.sigma_mm).collect::<Vec<f64>>());
            let share = match g.kind {
                read::Kind::Socket => 3.0 * (k - 1.0) / k,
                read::Kind::Plane => ((k - 3.0) / k).max(0.0),
                read::Kind::Distance => 1.0,
                read::Kind::Point => 3.0,
            };
            sigma * share.sqrt()
        })
        .collect();
    rms(&e)
}
