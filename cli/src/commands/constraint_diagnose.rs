//! `kinecal diagnose` on a constraint file: reads the robot file and the session, splits off
//! the held-out groups as `identify` does, runs the search ([`crate::constraints::diagnose`]),
//! fits the model with what it found, writes it (`--out`) and reports the rounds and the
//! held-out groups' error before and after (exit 3 when the extended model predicts them
//! worse than the geometric one).

use super::diagnose::Args;
use crate::calibration::acceptance::NO_DIFFERENCE_MM;
use crate::calibration::stats::rms;
use crate::constraints::diagnose::{fit_with, request_text, search, Round, SearchOptions};
use crate::constraints::read;
use crate::constraints::shapes::held_out_error;
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::output::numfmt::sig;
use crate::reports::path_text;
use crate::with_joints;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

/// The held-out groups' RMS (mm): the nominal robot, the geometric fit, the extended model.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct HeldOut {
    pub groups: usize,
    pub nominal_mm: f64,
    pub geometric_mm: f64,
    pub extended_mm: f64,
}

/// An effect found, in the order added.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FoundEffect {
    /// An id of docs/formats.md "Effects".
    pub effect: String,
    /// 1-based (thermal expansion, which acts on no joint, is listed on joint 1).
    pub joint: usize,
    /// The `--effect` request that adds it.
    pub request: String,
    /// Its values in the extended model (name → value).
    pub values: BTreeMap<String, f64>,
    /// The cross-validated RMS (mm) once it was added.
    pub validation_rms_mm: f64,
}

/// `diagnose` on a constraint file.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintDiagnoseReport {
    pub count_unit: String,
    pub n_identification: usize,
    pub n_validation: usize,
    pub folds: usize,
    /// What `baseline_validation_rms_mm` and `final_validation_rms_mm` are over: `held-out
    /// groups` when groups were held out, else `cross-validated groups`.
    pub validation: String,
    /// The geometric fit's and the extended model's RMS (mm) on those groups.
    pub baseline_validation_rms_mm: f64,
    pub final_validation_rms_mm: f64,
    /// What the rows' stated σ alone would leave in the same RMS sense (mm): a socket group
    /// `σ√(3(K−1)/K)`, a plane `σ√((K−3)/K)`, a distance `σ`, a point `σ√3`.
    pub noise_floor_mm: f64,
    /// Whether the file states σ (`sigma_mm`); else the floor is of the default σ.
    pub sigma_stated: bool,
    /// With stated σ: χ²/dof of the extended model fitted to every identification group
    /// (absent with fewer than 10 degrees of freedom).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2_per_dof: Option<f64>,
    /// What a wrong row may be in this session (the text's advice).
    #[serde(skip)]
    pub causes: String,
    /// Cross-validated RMS over the identification groups (mm), geometry alone and with what
    /// was found: each group against its own shape refitted to the model fitted without it.
    pub cv_rms_geometric_mm: f64,
    pub cv_rms_final_mm: f64,
    pub rounds: Vec<Round>,
    pub found: Vec<FoundEffect>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOut>,
    /// The extended model predicts the held-out groups worse than the geometric fit.
    pub held_out_worse: bool,
    /// Why the geometric fit is no calibration of these data (the arm stretched, a joint
    /// turned, a tool point misplaced, the constraints far from met), or absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resized: Option<String>,
    pub out: Option<String>,
}

impl ConstraintDiagnoseReport {
    /// χ²/dof of the extended model when the rows stay far from their constraints
    /// ([`crate::constraints::outliers::chi2_far`], above 1).
    fn unexplained_chi2(&self) -> Option<f64> {
        self.chi2_per_dof
            .filter(|c| *c > 1.0 && crate::constraints::outliers::chi2_far(*c))
    }
}

crate::reports::judged_report!(ConstraintDiagnoseReport, |r| !r.held_out_worse
    && r.resized.is_none());

impl fmt::Display for ConstraintDiagnoseReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} identification groups, {}-fold cross-validation: RMS {} mm with the geometry alone",
            self.n_identification,
            self.folds,
            sig(self.cv_rms_geometric_mm, 4)
        )?;
        for r in &self.rounds {
            writeln!(
                f,
                "  {} {} ({}): cross-validated RMS {} -> {} mm, p = {} (needs < {})",
                if r.accepted {
                    "found"
                } else {
                    "best, not taken:"
                },
                r.effect,
                r.label,
                sig(r.cv_rms_before_mm, 4),
                sig(r.cv_rms_after_mm, 4),
                sig(r.p, 2),
                sig(r.threshold, 2)
            )?;
            if let Some(why) = &r.implausible {
                writeln!(f, "    refused: {why}")?;
            }
        }
        writeln!(
            f,
            "noise floor of the {} σ: {} mm",
            if self.sigma_stated {
                "stated"
            } else {
                "default (no sigma_mm given)"
            },
            sig(self.noise_floor_mm, 4)
        )?;
        if self.rounds.iter().any(|r| r.implausible.is_some()) {
            writeln!(
                f,
                "an effect would fit, but its size is no arm's (refused above): check the column \
                 it reads before calibrating with it"
            )?;
        } else if let Some(c) = self.unexplained_chi2() {
            writeln!(
                f,
                "the rows are {}× farther from their constraints than the stated σ explain \
                 (χ²/dof {}{}), and no effect of the catalogue explains {}: check the rows \
                 ({}), then sigma_mm",
                sig(c.sqrt(), 3),
                sig(c, 3),
                if self.found.is_empty() {
                    ""
                } else {
                    " with what was found"
                },
                if self.found.is_empty() {
                    "it"
                } else {
                    "the rest"
                },
                self.causes
            )?;
        } else if self.found.is_empty() {
            writeln!(f, "nothing significant is missing from the geometry")?;
        }
        if let Some(h) = &self.held_out {
            writeln!(
                f,
                "{} held-out groups: RMS {} mm nominal, {} mm geometric, {} mm with what was found",
                h.groups,
                sig(h.nominal_mm, 4),
                sig(h.geometric_mm, 4),
                sig(h.extended_mm, 4)
            )?;
        }
        if let Some(o) = &self.out {
            writeln!(f, "model written to {o}")?;
        }
        Ok(())
    }
}

/// Runs `diagnose` on the constraint file `args.input.data`.
pub fn run(args: &Args) -> anyhow::Result<ConstraintDiagnoseReport> {
    for (flag, given) in [
        ("--validate", args.validate.is_some()),
        ("--plots", args.plots.is_some()),
    ] {
        if given {
            crate::refuse!(
                "{flag}: diagnose on a constraint file holds out groups of the session \
                 (--holdout, --split, --seed); leave {flag} out"
            );
        }
    }
    if let Some(out) = &args.out {
        crate::output::atomic::refuse_overwriting_inputs(
            "--out",
            out,
            &[
                ("robot", args.input.robot.as_path()),
                ("data", args.input.data.as_path()),
            ],
        )?;
    }
    if !(2..=20).contains(&args.folds) {
        crate::refuse!("--folds {}: give 2 to 20", args.folds);
    }
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        crate::refuse!("--alpha {}: give a probability between 0 and 1", args.alpha);
    }
    let file = RobotFile::load(&args.input.robot)?;
    let report = with_joints!(file.joint_count(), N => run_with_joints::<N>(args))?;
    if let Some(why) = &report.resized {
        eprintln!("error: the geometric fit {why}; nothing is diagnosed (exit 3)");
    } else if report.held_out_worse {
        eprintln!(
            "error: the extended model predicts the held-out groups worse than the geometric \
             fit: not an improvement (exit 3)"
        );
    }
    Ok(report)
}

fn run_with_joints<const N: usize>(args: &Args) -> anyhow::Result<ConstraintDiagnoseReport> {
    let input = &args.input;
    let (file, nominal) = load_robot::<N>(&input.robot)?;
    let session = read::load::<N>(&input.data, &input.units, &file.tool_names())?;
    super::inputs::warn_outside_limits(
        crate::calibration::check::OutsideLimits::of_rows(&file, session.joint_rows()),
        session.rows(),
        &input.data,
        &input.robot,
    );
    let origin = path_text(&input.data);
    crate::constraints::shapes::check_lengths(&nominal, &session.groups, &origin)?;
    let sigma_stated = session.sigma_stated;
    let (ident, valid) =
        crate::application::constraints::split_groups(session, &args.holdout, args.seed)?;
    let opts = SearchOptions {
        folds: args.folds,
        alpha: args.alpha,
        max_order: args.max_order.clamp(1, crate::MAX_CYCLIC_ORDER),
        max_effects: args.max_effects,
        seed: args.seed,
    };
    let s = search(&file, &nominal, &ident, &opts)?;
    let extended = fit_with(&file, &nominal, &s.found, &ident)?;
    let geometric = fit_with(&file, &nominal, &[], &ident)?;
    // The search's groups only, as on tracker points: the held-out groups' errors under the
    // geometry hold what the search is to find.
    let outliers = crate::constraints::outliers::find(&geometric.robot, &ident, &[]);
    let resized = crate::application::constraints::no_calibration(
        (&file, &nominal),
        (&geometric.robot, &outliers),
        rms(&ident
            .iter()
            .map(|g| held_out_error(&geometric.robot, g))
            .collect::<Vec<f64>>()),
        args.stall_rms_mm,
    );
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
    if resized.is_none() {
        let strays = crate::constraints::outliers::find(&extended.robot, &ident, &[]).strays();
        if let Some(s) = strays {
            eprintln!("warning: {origin}: {}", s.warning());
        }
        if let Some(w) = crate::constraints::bar_scale::warning(
            &nominal,
            (&extended.robot, &extended.estimated),
            &ident,
        ) {
            eprintln!("warning: {origin}: {w}");
        }
    }
    if let Some(path) = args
        .out
        .as_ref()
        .filter(|_| resized.is_some() || held_out_worse)
    {
        eprintln!(
            "note: {} not written: these numbers are not a calibration",
            path.display()
        );
    }
    let out = match args
        .out
        .as_ref()
        .filter(|_| resized.is_none() && !held_out_worse)
    {
        Some(path) => {
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
            model.save(path)?;
            Some(path.display().to_string())
        }
        None => None,
    };
    Ok(ConstraintDiagnoseReport {
        count_unit: "groups".into(),
        n_identification: ident.len(),
        n_validation: valid.len(),
        folds: args.folds,
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
        out,
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
