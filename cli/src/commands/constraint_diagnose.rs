//! `kinecal diagnose` on a constraint file: reads the robot file and the session, splits off
//! the held-out groups as `identify` does, runs the search ([`crate::constraints::diagnose`]),
//! fits the model with what it found, writes it (`--out`) and reports the rounds and the
//! held-out groups' error before and after (exit 3 when the extended model predicts them
//! worse than the geometric one).

use super::diagnose::Args;
use crate::calibration::acceptance::NO_DIFFERENCE_MM;
use crate::constraints::diagnose::{fit_with, request_text, search, Round, SearchOptions};
use crate::constraints::read;
use crate::constraints::shapes::{held_out_error, rms};
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

/// `diagnose` on a constraint file.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintDiagnoseReport {
    pub count_unit: String,
    pub n_identification: usize,
    pub n_validation: usize,
    pub folds: usize,
    /// Cross-validated RMS over the identification groups (mm), geometry alone and with what
    /// was found: each group against its own shape refitted to the model fitted without it.
    pub cv_rms_geometric_mm: f64,
    pub cv_rms_final_mm: f64,
    pub rounds: Vec<Round>,
    /// The effects found, as `--effect` requests, and their values in the extended model.
    pub found: Vec<String>,
    pub values: BTreeMap<String, f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOut>,
    /// The extended model predicts the held-out groups worse than the geometric fit.
    pub held_out_worse: bool,
    pub out: Option<String>,
}

crate::reports::judged_report!(ConstraintDiagnoseReport, |r| !r.held_out_worse);

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
        }
        if self.found.is_empty() {
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
    if report.held_out_worse {
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
    let origin = path_text(&input.data);
    crate::constraints::shapes::check_lengths(&nominal, &session.groups, &origin)?;
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
    let held_out = if valid.is_empty() {
        None
    } else {
        let geometric = fit_with(&file, &nominal, &[], &ident)?;
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
    let out = match &args.out {
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
            let mut model = RobotFile::from_robot(
                &format!("{} (diagnosed)", file.name),
                &extended.robot,
                true,
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
        cv_rms_geometric_mm: s.cv_rms_geometric_mm,
        cv_rms_final_mm: s.cv_rms_final_mm,
        rounds: s.rounds,
        found: s.found.iter().map(request_text).collect(),
        values,
        held_out,
        held_out_worse,
        out,
    })
}
