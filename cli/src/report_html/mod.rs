//! The calibration report: one self-contained HTML page (inline CSS and SVG, no script, no
//! URL) of how accurate the robot was before and after, what was changed, how sure the numbers
//! are and what is still unexplained (`kinecal report`, `demo`).
//!
//! - [`stats`]: per-axis and total error statistics (the totals from identify's functions;
//!   the module lives in [`crate::calibration::stats`], which `validate` uses too);
//! - [`iso9283`]: positional accuracy and repeatability in the ISO 9283 sense;
//! - [`params`]: the parameter table, what was held and why, the correlations;
//! - [`findings`]: a diagnose JSON read back, with its figures;
//! - [`validation`]: a validate JSON read back (the model on another session);
//! - [`plots`]: the figures (plotters, SVG);
//! - [`page`]: the page model (formatted text), [`template`]: the page from its template;
//! - [`summary`]: the command's JSON and text (the page's figures).
//!
//! [`build`] computes everything from in-memory robots and observations; the command
//! (`crate::commands::report`) loads the files, `demo` passes its own.

pub mod constraint_page;
pub mod findings;
pub mod iso9283;
pub mod page;
pub mod params;
pub mod plots;
pub mod summary;
pub mod template;
pub mod validation;

pub use crate::calibration::stats;
/// The statistics of one model on one set (per axis, total, 95 %), shared with `validate`.
use crate::HostRobot;

use crate::calibration::weights::{self, Weighting};
use crate::calibration::{orientation_errors_deg, pose_errors, ErrorStats, Residuals};
use crate::output::numfmt::sig;
use crate::reports::identify::PointResiduals;
use kinecal::model::param::Param;
use kinecal::Measurement;
use nalgebra::Vector3;
use page::{
    Cell, DataSet, Figure, IsoRepeat, IsoRow, JointRange, Page, ParamLine, PointLine, SetTable,
    StatRow,
};
use stats::SetFigures;
use std::path::Path;
use summary::{ReportSummary, SetSummary};

/// Where the inputs came from, as the page lists them.
#[derive(Clone, Debug, Default)]
pub struct Sources {
    /// `(label, value)`: robot file, model, data, held-out data, diagnose JSON.
    pub files: Vec<(String, String)>,
    /// The units the data were read in, in words.
    pub units: String,
    /// What reading the files told (stderr's warnings and notes: joint tables whose knots miss
    /// the readings, readings beyond the joint limits, suspicious units …), shown on the page.
    pub told: Vec<String>,
}

impl Sources {
    /// The files of a report, labelled: the robot file, the identified model, the
    /// identification data, the held-out data (a file, or which poses of the data), the
    /// diagnose findings and another session's validate JSON.
    pub fn files(
        (robot, model, data): (&Path, &Path, &Path),
        held_out: Option<String>,
        (diagnose, validate_json): (Option<&Path>, Option<&Path>),
    ) -> Vec<(String, String)> {
        let t = |p: &Path| p.display().to_string();
        let mut files = vec![
            ("robot file".to_string(), t(robot)),
            ("identified model".to_string(), t(model)),
            ("identification data".to_string(), t(data)),
        ];
        files.extend(held_out.map(|h| ("held-out data".to_string(), h)));
        files.extend(diagnose.map(|d| ("diagnose findings".to_string(), t(d))));
        files.extend(validate_json.map(|v| ("another session (validate)".to_string(), t(v))));
        files
    }
}

/// What the report is made of (robots in library units, observations flattened).
pub struct Inputs<'a, const N: usize> {
    pub robot_name: String,
    pub model_name: String,
    pub sources: Sources,
    /// The nominal robot, its base fitted when the robot file has none (`base_fitted`).
    pub nominal: &'a HostRobot<N>,
    pub base_fitted: bool,
    /// The robot file gave the tool point as unknown (started from the data in `nominal`).
    pub tool_unknown: bool,
    /// The identified model.
    pub model: &'a HostRobot<N>,
    /// Where `identify` started its fit: the nominal robot placed as above, with the model's
    /// effects at zero (the 1-σ, held parameters and correlations are those of identify's fit
    /// from it over the identification data).
    pub start: &'a HostRobot<N>,
    /// Every parameter of the model (the table's rows) and those the fit estimates.
    pub all_params: Vec<Param>,
    pub estimated: Vec<Param>,
    /// The prior 1-σ of each of `estimated` as identify set it
    /// ([`crate::calibration::prior::sigmas`]).
    pub prior: Vec<Option<f64>>,
    pub ident: Vec<Measurement<f64, N>>,
    pub valid: Vec<Measurement<f64, N>>,
    /// The pose of each identification observation (several reflectors), for the
    /// cross-validation of the orientation weight.
    pub pose_of: Vec<usize>,
    pub ident_poses: usize,
    pub valid_poses: usize,
    /// Reflector names (empty for one tool point), 6-D rows, σ-weighted rows.
    pub names: Vec<String>,
    pub six_d: bool,
    pub sigma: bool,
    /// How `identify` weighed the identification data (see [`weights::weighted_fit`]).
    pub weighting: Weighting,
    /// Joint limits of the robot file (degrees), where stated.
    pub limits_deg: Vec<Option<[f64; 2]>>,
    /// Above this identification RMS (mm) the model is not a calibration of these data.
    pub stall_rms_mm: f64,
    /// Why a few gross outliers make the model no calibration of these data (the rest of a
    /// sentence that starts "the model"), as identify refuses its fit.
    pub outliers: Option<String>,
    pub diagnose: Option<(findings::DiagnoseJson, String)>,
    /// `kinecal validate --json` on another session, and where it was read from.
    pub validation: Option<(crate::reports::validate::ValidateReport, String)>,
}

/// The page and its summary.
pub struct Built {
    pub html: String,
    pub summary: ReportSummary,
}

const STATS: [&str; 4] = ["rms", "mean", "max", "p95"];

fn stat_rows(model: &str, set: &str, f: &SetFigures, orient_deg: &[f64]) -> Vec<StatRow> {
    let mut rows: Vec<StatRow> = [("x", &f.x), ("y", &f.y), ("z", &f.z), ("total", &f.total)]
        .into_iter()
        .map(|(axis, s)| StatRow {
            model: model.into(),
            axis: axis.into(),
            unit: "mm".into(),
            cells: STATS
                .iter()
                .zip([s.rms, s.mean, s.max, s.p95])
                .map(|(k, v)| Cell {
                    key: format!("{model}.{set}.{axis}.{k}"),
                    text: if *k == "mean" && axis != "total" {
                        beside(v, s.rms)
                    } else {
                        sig(v, 4)
                    },
                })
                .collect(),
        })
        .collect();
    if let Some(o) = ErrorStats::of(orient_deg) {
        let p95 = stats::quantile(orient_deg, 0.95);
        rows.push(StatRow {
            model: model.into(),
            axis: "orientation".into(),
            unit: "°".into(),
            cells: STATS
                .iter()
                .zip([o.rms_mm, o.mean_mm, o.max_mm, p95])
                .map(|(k, v)| Cell {
                    key: format!("{model}.{set}.orientation.{k}"),
                    text: sig(v, 4),
                })
                .collect(),
        });
    }
    rows
}

/// A signed mean printed with the decimals of the RMS beside it (4 significant digits): a
/// mean of 1e-13 mm beside an RMS of 4.605 mm is 0.000.
fn beside(mean: f64, rms: f64) -> String {
    let r = sig(rms, 4);
    let decimals = r.split_once('.').map_or(0, |(_, d)| d.len());
    if r.contains('e') || !mean.is_finite() {
        return sig(mean, 4);
    }
    let t = format!("{mean:.decimals$}");
    if t.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        t.trim_start_matches('-').to_string()
    } else {
        t
    }
}

fn range_text(lo: f64, hi: f64) -> String {
    if lo.is_finite() {
        format!("{} … {}", sig(lo, 4), sig(hi, 4))
    } else {
        "-".into()
    }
}

fn joint_ranges_deg<const N: usize>(data: &[Measurement<f64, N>]) -> [(f64, f64); N] {
    let mut r = [(f64::INFINITY, f64::NEG_INFINITY); N];
    for m in data {
        for (j, q) in m.q.iter().enumerate() {
            let d = q.to_degrees();
            r[j] = (r[j].0.min(d), r[j].1.max(d));
        }
    }
    r
}

/// Computes the report: statistics, figures, the parameter table (a fit from the model over
/// the identification data for its covariance), the findings; renders the page.
pub fn build<const N: usize>(inp: Inputs<'_, N>) -> anyhow::Result<Built> {
    let t0 = std::time::Instant::now();
    let (ident, valid) = (&inp.ident, &inp.valid);
    // The figures identify reports, by its functions.
    let before = Residuals::of(inp.nominal, ident, valid);
    let after = Residuals::of(inp.model, ident, valid);
    let per_point = PointResiduals::per_point(&inp.names, (inp.nominal, inp.model), (ident, valid));

    let mut sets = Vec::new();
    let mut summaries = Vec::new();
    for (key, title, data) in [
        ("identification", "Identification poses", ident),
        ("validation", "Held-out poses", valid),
    ] {
        if data.is_empty() {
            continue;
        }
        let mut rows = Vec::new();
        let mut pair = Vec::new();
        for (model, robot) in [("before", inp.nominal), ("after", inp.model)] {
            let (f, _) = SetFigures::of(robot, data);
            let f = f.ok_or_else(|| anyhow::anyhow!("no {key} observations"))?;
            rows.extend(stat_rows(
                model,
                key,
                &f,
                &orientation_errors_deg(robot, data),
            ));
            pair.push(f);
        }
        summaries.push(SetSummary {
            set: key.to_string(),
            observations: data.len(),
            before: pair[0],
            after: pair[1],
        });
        sets.push(SetTable {
            key: key.into(),
            title: title.into(),
            poses: data.len(),
            rows,
        });
    }

    // Figures: on the held-out poses when there are any.
    let (shown, shown_name) = if valid.is_empty() {
        (ident, "identification")
    } else {
        (valid, "held-out")
    };
    let eb = pose_errors(inp.nominal, shown);
    let ea = pose_errors(inp.model, shown);
    let q_deg: Vec<Vec<f64>> = shown
        .iter()
        .map(|m| m.q.iter().map(|q| q.to_degrees()).collect())
        .collect();
    let base_inv = inp.model.base().inverse();
    let pts: Vec<[f64; 3]> = shown
        .iter()
        .map(|m| {
            let p = base_inv.point(&m.point);
            [p.x, p.y, p.z]
        })
        .collect();
    let thinned = if shown.len() > plots::MAX_POINTS {
        format!(
            " One in {} of the {} observations is drawn.",
            shown.len().div_ceil(plots::MAX_POINTS),
            shown.len()
        )
    } else {
        String::new()
    };
    let figures = vec![
        Figure {
            id: "histogram".into(),
            svg: plots::histogram(
                &format!("position error on the {shown_name} poses"),
                &[
                    ("before (nominal model)".into(), &eb),
                    ("after calibration".into(), &ea),
                ],
            )?,
            caption: format!(
                "Distribution of the position error on the {shown_name} poses, before \
                 (nominal model) and after calibration, each on its own scale."
            ),
        },
        Figure {
            id: "joints".into(),
            svg: plots::error_vs_joints(&q_deg, &ea)?,
            caption: format!(
                "Position error after calibration against each joint angle on the \
                 {shown_name} poses. A pattern along a joint is an error the model does not \
                 describe (kinecal diagnose names it).{thinned}"
            ),
        },
        Figure {
            id: "workspace".into(),
            svg: plots::workspace(&pts, &ea)?,
            caption: format!(
                "Where the error after calibration is large: the measured points of the \
                 {shown_name} poses in the robot's base frame, coloured by their error (mm), \
                 largest drawn on top.{thinned}"
            ),
        },
    ];

    // ISO 9283: commanded by the nominal model (the controller's) and by the calibrated one.
    let mut iso = Vec::new();
    let mut iso_repeats = Vec::new();
    let mut iso_summary = Vec::new();
    for (set, data) in [("identification", ident), ("held out", valid)] {
        for (model, robot) in [
            ("nominal model", inp.nominal),
            ("calibrated model", inp.model),
        ] {
            let commanded: Vec<Vector3<f64>> = crate::calibration::pose_error_vectors(robot, data)
                .iter()
                .zip(data.iter())
                .map(|(e, m)| m.point - e)
                .collect();
            let Some(a) = iso9283::accuracy(data, &commanded) else {
                continue;
            };
            let key = format!(
                "iso.{}.{}",
                set.replace(' ', "_"),
                if model.starts_with("nominal") {
                    "before"
                } else {
                    "after"
                }
            );
            iso.push(IsoRow {
                set: set.into(),
                model: model.into(),
                cells: ["mean", "rms", "p95", "max", "s"]
                    .iter()
                    .zip([a.mean_mm, a.rms_mm, a.p95_mm, a.max_mm, a.s_mm])
                    .map(|(k, v)| Cell {
                        key: format!("{key}.{k}"),
                        text: sig(v, 4),
                    })
                    .collect(),
                repeated: a.repeated.len(),
            });
            if model.starts_with("nominal") {
                iso_repeats.extend(a.repeated.iter().take(20).map(|r| {
                    IsoRepeat {
                        set: set.into(),
                        rows: r
                            .rows
                            .iter()
                            .map(|k| k.to_string())
                            .collect::<Vec<_>>()
                            .join(", "),
                        approaches: r.rows.len(),
                        ap: sig(r.ap_mm, 4),
                        ap_xyz: r.ap_xyz_mm.map(|v| sig(v, 3)).join(", "),
                        rp: sig(r.rp_mm, 4),
                    }
                }));
            }
            iso_summary.push((key, a));
        }
    }
    let repeats: usize = iso_summary
        .iter()
        .filter(|(k, _)| k.ends_with("before"))
        .map(|(_, a)| a.repeated.len())
        .sum();
    let iso_note = format!(
        "Commanded position: where the nominal controller model puts the tool point for the \
         commanded joint readings; attained: the measured point. The distance between them is \
         the pose's accuracy error. {} The same statistics with the calibrated model as the \
         controller's are what a compensated robot would reach.",
        if repeats > 0 {
            format!(
                "{repeats} poses were approached more than once (identical joint readings): \
                 their AP and RP (ISO 9283 §7.2) are listed below."
            )
        } else {
            "No pose was approached twice (no identical joint readings), so ISO 9283 AP and RP \
             of a repeated pose cannot be given; the mean distance is the AP-style figure."
                .into()
        }
    );

    // 1-σ, held parameters and correlations: identify's fit over the identification data,
    // weighted as identify weighs them, from where identify starts; how closely it reproduces
    // the model is said on the page.
    let mut wdata = ident.clone();
    let stated = weights::stated(&wdata, inp.sigma);
    let (fit, _) = weights::weighted_fit(&mut wdata, &inp.pose_of, &stated, inp.weighting, |d| {
        crate::calibration::prior::fit_lm_with_prior(inp.start, &inp.estimated, &inp.prior, d)
    })?;
    let refit = crate::calibration::pose_error_vectors(&fit.robot, ident)
        .iter()
        .zip(crate::calibration::pose_error_vectors(inp.model, ident))
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    let rows = params::table(
        inp.nominal,
        inp.model,
        &inp.all_params,
        &inp.estimated,
        &fit,
    );
    let line = |r: &params::ParamRow| {
        let [nominal, calibrated, change, sigma] = r.cells();
        ParamLine {
            name: r.name.clone(),
            unit: r.unit.into(),
            nominal,
            calibrated,
            change,
            sigma,
            status: match r.status {
                params::Status::Estimated => "estimated",
                params::Status::Held { .. } => "held",
                params::Status::Fixed => "fixed",
            }
            .into(),
            reason: r.reason(),
        }
    };
    let param_lines: Vec<ParamLine> = rows.iter().map(line).collect();
    let held: Vec<ParamLine> = param_lines
        .iter()
        .filter(|p| p.status == "held")
        .cloned()
        .collect();
    let estimated = rows
        .iter()
        .filter(|r| r.status == params::Status::Estimated)
        .count();
    let fit_note = format!(
        "1-σ from the covariance s²(JᵀWJ)⁻¹ of the {}Jacobian at the calibrated model over the \
         {} identification observations{}.",
        if inp.sigma || inp.six_d {
            "weighted "
        } else {
            ""
        },
        ident.len(),
        fit.chi2_per_dof
            .filter(|_| inp.sigma)
            .map_or(String::new(), |c| format!(
                " (weighted cost per degree of freedom {})",
                sig(c, 3)
            ))
    ) + &format!(
        " Held parameters and 1-σ are those of identify's Levenberg–Marquardt fit from the robot \
         file over these data; its predicted points differ from the model's by at most {} mm \
         at the identification poses{}.",
        sig(refit, 2),
        if refit > 0.1 * after.identification_rms_mm {
            " (more than a tenth of the residual: the model was not fitted by LM to these data)"
        } else {
            ""
        }
    );

    // Data set.
    let ri = joint_ranges_deg(ident);
    let rv = joint_ranges_deg(valid);
    let data = DataSet {
        identification_poses: inp.ident_poses,
        validation_poses: inp.valid_poses,
        observations: ident.len() + valid.len(),
        points: inp.names.clone(),
        kind: match (inp.six_d, inp.sigma) {
            (true, true) => "6-D poses with the tracker's σ",
            (true, false) => "6-D poses",
            (false, true) => "positions with the tracker's σ",
            (false, false) => "positions",
        }
        .into(),
        units: inp.sources.units.clone(),
        base: if inp.base_fitted {
            "The robot file gives no base pose: it is fitted to the identification poses \
             (point-set registration), as identify does."
                .into()
        } else {
            "The base pose is the robot file's.".into()
        },
        joints: (0..N)
            .map(|j| JointRange {
                joint: j + 1,
                identification: range_text(ri[j].0, ri[j].1),
                validation: range_text(rv[j].0, rv[j].1),
                limits: inp
                    .limits_deg
                    .get(j)
                    .copied()
                    .flatten()
                    .map_or("-".into(), |[a, b]| range_text(a, b)),
            })
            .collect(),
    };

    let points = per_point
        .iter()
        .flatten()
        .map(|(name, p)| PointLine {
            name: name.clone(),
            observations: format!("{} + {}", p.n_identification, p.n_validation),
            cells: [
                (
                    "before.identification",
                    Some(p.before.identification_rms_mm),
                ),
                ("after.identification", Some(p.after.identification_rms_mm)),
                ("before.validation", p.before.validation_rms_mm),
                ("after.validation", p.after.validation_rms_mm),
            ]
            .into_iter()
            .map(|(k, v)| Cell {
                key: format!("point.{name}.{k}.rms"),
                text: v.map_or("-".into(), |v| sig(v, 4)),
            })
            .collect(),
        })
        .collect();

    let findings = match &inp.diagnose {
        Some((d, origin)) => {
            let r = joint_ranges_deg(&[ident.as_slice(), valid.as_slice()].concat());
            Some(findings::findings(d, origin, &r)?)
        }
        None => None,
    };

    let fits =
        after.identification_rms_mm.is_finite() && after.identification_rms_mm <= inp.stall_rms_mm;
    let mut warnings = inp.sources.told.clone();
    if !fits {
        warnings.push(format!(
            "The identified model misses the identification poses by {} mm RMS (above {} mm): \
             it is not a calibration of these data (wrong model, data or units).",
            sig(after.identification_rms_mm, 4),
            sig(inp.stall_rms_mm, 3)
        ));
    }
    let (b, a, on) = match (before.validation_rms_mm, after.validation_rms_mm) {
        (Some(b), Some(a)) => (b, a, "held-out"),
        _ => (
            before.identification_rms_mm,
            after.identification_rms_mm,
            "identification",
        ),
    };
    // An unknown tool has no "before": the nominal robot's figure is with a point started
    // from the data, and no reduction is claimed against it.
    let headline = if inp.tool_unknown {
        format!(
            "Position error (RMS, {on} poses): {} mm after calibration; the tool point was \
             unknown (started from the data, the nominal robot is at {} mm with it).",
            sig(a, 4),
            sig(b, 4)
        )
    } else {
        format!(
            "Position error (RMS, {on} poses): {} mm before, {} mm after calibration ({} % less).",
            sig(b, 4),
            sig(a, 4),
            sig(100.0 * (1.0 - a / b), 3)
        )
    };
    let validation = inp
        .validation
        .as_ref()
        .map(|(v, origin)| validation::section(v, origin));
    if let Some(v) = validation.as_ref().filter(|v| v.worse_than_nominal) {
        warnings.push(if v.other_verdict {
            format!("On another session ({}): {}.", v.data_file, v.verdict)
        } else {
            format!(
                "On another session ({}) the model predicts worse than the nominal robot: {}.",
                v.data_file, v.verdict
            )
        });
    }
    // Judged on the held-out poses as identify judges them: worse than the nominal robot is no
    // calibration (identify's exit 3), much worse than the identification poses a warning.
    let held_out = crate::calibration::acceptance::judge(
        (
            before.validation_rms_mm,
            after.validation_rms_mm,
            after.identification_rms_mm,
        ),
        ident,
        valid,
        Vec::new(),
    );
    // Poses that barely move some joints: judged across the joint ranges as identify judges.
    let held_out = match crate::calibration::extrapolation::check(
        (inp.nominal, inp.model),
        (&inp.estimated, &inp.prior),
        (ident, valid),
        after.identification_rms_mm / 3f64.sqrt(),
    ) {
        Some(m) => Some(crate::calibration::extrapolation::refuse(held_out, m)),
        None => held_out,
    };
    let held_out_worse = held_out.as_ref().is_some_and(|a| a.held_out_worse);
    let extrapolated = held_out.as_ref().is_some_and(|a| a.extrapolated);
    if let Some(why) = &inp.outliers {
        warnings.push(format!("The model {why}."));
    }
    if let Some(m) = held_out.and_then(|a| a.message) {
        let on = if extrapolated {
            "Across the joint ranges"
        } else {
            "Held-out poses"
        };
        warnings.push(format!("{on}: {m}."));
    }
    // Another session's verdict (validate's exit status) is the page's too.
    let session_fails = inp
        .validation
        .as_ref()
        .is_some_and(|(v, _)| !crate::reports::Report::converged(v));
    let verdict = if !fits {
        "not a calibration of these data"
    } else if extrapolated {
        "not a calibration: the model is not determined across the joint ranges"
    } else if held_out_worse {
        "not a calibration: the held-out poses are predicted worse than by the nominal robot"
    } else if inp.outliers.is_some() {
        "not a calibration: points far from the model (see the warning)"
    } else if session_fails {
        "does not hold on another session (see the validation)"
    } else {
        "calibrated"
    };
    let converged = verdict == "calibrated";
    let mut sources = inp.sources.files.clone();
    sources.push(("model name".into(), inp.model_name.clone()));
    let page = Page {
        title: format!("Calibration report: {}", inp.robot_name),
        robot_name: inp.robot_name.clone(),
        model_name: inp.model_name.clone(),
        sources,
        headline,
        verdict: verdict.into(),
        converged,
        warnings,
        data,
        sets,
        points,
        figures,
        iso,
        iso_repeats,
        iso_note,
        params: param_lines,
        estimated,
        held,
        correlations: params::correlation_cells(&fit.correlations),
        fit_note,
        findings,
        validation,
    };
    let html = template::render(&page)?;
    let summary = ReportSummary {
        out: None,
        bytes: html.len(),
        seconds: t0.elapsed().as_secs_f64(),
        n_identification: inp.ident_poses,
        n_validation: inp.valid_poses,
        before,
        after,
        per_point,
        sets: summaries,
        iso9283: iso_summary.into_iter().collect(),
        parameters: rows,
        correlations: fit.correlations.clone(),
        refit_max_mm: refit,
        findings: inp.diagnose.as_ref().map_or(0, |d| d.0.found.len()),
        figures: page.figures.len()
            + page.findings.as_ref().map_or(0, |f| {
                f.found.iter().filter(|x| x.svg.is_some()).count() + usize::from(f.svg.is_some())
            }),
        converged,
        verdict: verdict.into(),
    };
    Ok(Built { html, summary })
}
