//! The reports of `identify` and `validate` on a constraint file (the JSON keys of their
//! tracker-point reports, docs/formats.md, and per kind what the constraints say).

use crate::calibration::acceptance::Acceptance;
use crate::calibration::Residuals;
use crate::output::numfmt::sig;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

/// One kind of constraint in a session: how many groups and rows, RMS before and after.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct KindSummary {
    pub kind: String,
    pub groups: usize,
    pub rows: usize,
    /// RMS over the identification rows of this kind (mm; a distance group counts once).
    pub before_rms_mm: f64,
    pub after_rms_mm: f64,
}

/// A fitted socket centre (measurement frame of the fit, mm).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FittedSocket {
    pub group: String,
    pub centre_mm: [f64; 3],
}

/// A fitted plane `normal·p = offset_mm`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FittedPlane {
    pub group: String,
    pub normal: [f64; 3],
    pub offset_mm: f64,
}

/// What the constraints said, per kind, and the fitted shapes.
#[derive(Clone, Debug, Serialize, PartialEq, Default)]
pub struct Constraints {
    pub kinds: Vec<KindSummary>,
    pub sockets: Vec<FittedSocket>,
    pub planes: Vec<FittedPlane>,
}

/// `identify` on a constraint file.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintIdentifyReport {
    pub method: String,
    /// What `n_identification` and `n_validation` count: groups (a held-out set is whole groups).
    pub count_unit: String,
    pub n_identification: usize,
    pub n_validation: usize,
    pub n_identification_rows: usize,
    pub n_validation_rows: usize,
    pub before: Residuals,
    pub after: Residuals,
    pub iterations: usize,
    /// Evaluations of the residuals of all rows (`identify`'s key on tracker points).
    pub evaluations: usize,
    pub seconds: f64,
    pub parameters: BTreeMap<String, f64>,
    /// The parameters estimated (the others are held at their file values).
    pub estimated: Vec<String>,
    pub unidentifiable: Vec<String>,
    /// Parameters that moved further from the robot file's values than a manufacturing
    /// tolerance explains (`--tolerance-mm`, `--tolerance-deg`), as on tracker points.
    pub suspicious: Vec<String>,
    pub converged: bool,
    pub stop: String,
    /// With a `sigma_mm` column: the weighted cost per degree of freedom (≈ 1 when the stated
    /// σ explain the residuals).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2_per_dof: Option<f64>,
    /// A few rows far beyond the others' errors, under the gross outliers' millimetre
    /// ([`super::outliers`]): warned about.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stray_points: Option<crate::calibration::outliers::Strays>,
    /// The warnings of a converged fit about its rows, one message each as stderr shows them:
    /// a few rows far from their constraints, χ²/dof far from 1.
    #[serde(skip)]
    pub warnings: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out_worse: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acceptance: Option<Acceptance>,
    pub constraints: Constraints,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub out: Option<String>,
}

impl crate::reports::Report for ConstraintIdentifyReport {
    fn to_json(&self) -> serde_json::Value {
        crate::reports::with_accepted(crate::reports::json_value(self), self)
    }
    fn converged(&self) -> bool {
        self.converged && self.held_out_worse != Some(true)
    }
    fn non_finite(&self) -> Option<String> {
        crate::reports::finite::first_non_finite(self)
    }
}

impl fmt::Display for ConstraintIdentifyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let g = |v: Option<f64>| v.map_or("-".to_string(), |x| sig(x, 4));
        writeln!(
            f,
            "constraint fit ({}): {} identification groups ({} rows), {} held-out groups",
            self.method, self.n_identification, self.n_identification_rows, self.n_validation
        )?;
        writeln!(
            f,
            "{:>8} {:>16} {:>16} {:>16} {:>16}",
            "", "ident RMS mm", "valid RMS mm", "valid mean mm", "valid max mm"
        )?;
        for (k, r) in [("before", &self.before), ("after", &self.after)] {
            writeln!(
                f,
                "{:>8} {:>16} {:>16} {:>16} {:>16}",
                k,
                g(Some(r.identification_rms_mm)),
                g(r.validation_rms_mm),
                g(r.validation_mean_mm),
                g(r.validation_max_mm)
            )?;
        }
        for k in &self.constraints.kinds {
            writeln!(
                f,
                "{:>8}: {} groups, {} rows, RMS {} → {} mm",
                k.kind,
                k.groups,
                k.rows,
                sig(k.before_rms_mm, 4),
                sig(k.after_rms_mm, 4)
            )?;
        }
        if !self.unidentifiable.is_empty() {
            writeln!(
                f,
                "held at the file's values (the constraints cannot determine them): {}",
                self.unidentifiable.join(", ")
            )?;
        }
        if let Some(c) = self.chi2_per_dof.filter(|_| self.converged) {
            writeln!(
                f,
                "χ²/dof with the file's σ: {} (≈ 1 when the σ explain the residuals)",
                sig(c, 3)
            )?;
        }
        if let Some(m) = self.acceptance.as_ref().and_then(|a| a.message.as_ref()) {
            writeln!(f, "{m}")?;
        }
        writeln!(f, "{} after {} iterations", self.stop, self.iterations)?;
        if let Some(o) = &self.out {
            writeln!(f, "model written to {o}")?;
        }
        Ok(())
    }
}

/// Figures of a model's constraint residuals (mm).
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Figures {
    pub rms_mm: f64,
    pub mean_mm: f64,
    pub max_mm: f64,
    pub p95_mm: f64,
}

impl Figures {
    /// The figures of absolute errors `e` (per group: see [`super::shapes::held_out_error`]).
    pub fn of(e: &[f64]) -> Figures {
        let mut a: Vec<f64> = e.iter().map(|x| x.abs()).collect();
        a.sort_by(f64::total_cmp);
        let n = a.len().max(1) as f64;
        let p95 = a
            .get(((0.95 * n).ceil() as usize).saturating_sub(1))
            .copied()
            .unwrap_or(f64::NAN);
        Figures {
            rms_mm: crate::calibration::stats::rms(&a),
            mean_mm: a.iter().sum::<f64>() / n,
            max_mm: a.last().copied().unwrap_or(f64::NAN),
            p95_mm: p95,
        }
    }
}

/// `validate` on a constraint file.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintValidateReport {
    /// What the figures are over: each group's residual against its own refitted shape.
    pub count_unit: String,
    pub groups: usize,
    pub model: Figures,
    pub nominal: Figures,
    /// Nothing is registered: a constraint residual does not depend on the base.
    pub registered: Vec<String>,
    pub worse_than_nominal: bool,
    /// The groups left out fold by fold, predicted by the model and by the robot calibrated
    /// again on the other groups ([`super::recalibration`]); `None` with fewer than four
    /// groups or a fold that could not be fitted.
    pub recalibration: Option<crate::calibration::recalibration::Recalibration>,
    /// The model predicts the left-out groups so much worse than a new calibration that the
    /// robot changed since its calibration (exit 3).
    pub changed_since_calibration: bool,
}

crate::reports::judged_report!(ConstraintValidateReport, |r| !r.worse_than_nominal
    && !r.changed_since_calibration);

impl fmt::Display for ConstraintValidateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} constraint groups, each against its own refitted shape",
            self.groups
        )?;
        for (k, v) in [("model", &self.model), ("nominal", &self.nominal)] {
            writeln!(
                f,
                "{k:>8}: RMS {} mm, mean {} mm, max {} mm, p95 {} mm",
                sig(v.rms_mm, 4),
                sig(v.mean_mm, 4),
                sig(v.max_mm, 4),
                sig(v.p95_mm, 4)
            )?;
        }
        if self.worse_than_nominal {
            writeln!(
                f,
                "the model predicts these constraints worse than the nominal robot"
            )?;
        }
        if let Some(r) = &self.recalibration {
            writeln!(
                f,
                "groups left out in {} folds: RMS {} mm with the model, {} mm with the robot \
                 calibrated again on the other groups",
                r.folds,
                sig(r.model_rms_mm, 4),
                sig(r.recalibrated_rms_mm, 4)
            )?;
        }
        Ok(())
    }
}

/// One kind of constraint in a checked session.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct KindFigures {
    pub kind: String,
    pub groups: usize,
    pub rows: usize,
    /// RMS of the nominal model's rows of this kind (mm; a distance group counts once).
    pub nominal_rms_mm: f64,
}

/// `check` on a constraint file.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintCheckReport {
    pub robot: String,
    pub data: String,
    /// What `groups` counts: groups of rows tied together (docs/formats.md).
    pub count_unit: String,
    pub joints: usize,
    pub groups: usize,
    pub rows: usize,
    /// The poses measured: every row is one (`check`'s key on tracker points).
    pub poses: usize,
    pub joint_ranges_deg: Vec<[f64; 2]>,
    pub outside_limits: usize,
    pub kinds: Vec<KindFigures>,
    /// The nominal model's RMS over every row, each group against the shape fitted to its own
    /// predicted points (mm).
    pub nominal_rms_mm: f64,
    /// What `identify` would hold: the parameters these constraints cannot determine at the
    /// nominal model.
    pub cannot_determine: Vec<String>,
    /// Socket and plane rows far from their group's other rows at the nominal model (a wrong
    /// group label).
    pub far_rows: Vec<super::far_rows::FarRow>,
}

impl ConstraintCheckReport {
    /// The report of `c`, the check of the data file `data` against the robot file `robot`.
    pub fn of(c: &super::check::ConstraintChecked, robot: &str, data: &str) -> Self {
        Self {
            robot: robot.into(),
            data: data.into(),
            count_unit: "groups".into(),
            joints: c.joints,
            groups: c.groups,
            rows: c.rows,
            poses: c.rows,
            joint_ranges_deg: c.joint_ranges_deg.clone(),
            outside_limits: c.outside_limits,
            kinds: c
                .kinds
                .iter()
                .map(|k| KindFigures {
                    kind: k.kind.into(),
                    groups: k.groups,
                    rows: k.rows,
                    nominal_rms_mm: k.nominal_rms_mm,
                })
                .collect(),
            nominal_rms_mm: c.nominal_rms_mm,
            cannot_determine: c.cannot_determine.clone(),
            far_rows: c.far_rows.clone(),
        }
    }
}

crate::reports::plain_report!(ConstraintCheckReport);

impl fmt::Display for ConstraintCheckReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} constraint groups ({} rows) of a {}-joint robot ({})",
            self.data, self.groups, self.rows, self.joints, self.robot
        )?;
        for k in &self.kinds {
            writeln!(
                f,
                "{:>8}: {} groups, {} rows, nominal RMS {} mm",
                k.kind,
                k.groups,
                k.rows,
                sig(k.nominal_rms_mm, 4)
            )?;
        }
        if let Some(w) = super::far_rows::warning(&self.far_rows) {
            writeln!(f, "warning: {w}")?;
        }
        writeln!(
            f,
            "nominal RMS over all rows: {} mm (each group against its own fitted shape)",
            sig(self.nominal_rms_mm, 4)
        )?;
        let ranges: Vec<String> = self
            .joint_ranges_deg
            .iter()
            .enumerate()
            .map(|(i, [lo, hi])| format!("q{} {}..{}", i + 1, sig(*lo, 4), sig(*hi, 4)))
            .collect();
        writeln!(f, "joint ranges (deg): {}", ranges.join(", "))?;
        if self.outside_limits > 0 {
            writeln!(
                f,
                "warning: {} rows outside the robot file's joint limits",
                self.outside_limits
            )?;
        }
        if !self.cannot_determine.is_empty() {
            writeln!(
                f,
                "these constraints cannot determine (identify holds them at the file's values): {}",
                self.cannot_determine.join(", ")
            )?;
        }
        Ok(())
    }
}

/// `plan --constraints --accuracy-mm`: how many times the planned session's groups the
/// accuracy takes.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct AccuracyNeed {
    pub target_mm: f64,
    /// The plan with that many groups predicts the target (false: not within the most repeats
    /// tried).
    pub reached: bool,
    pub times_the_groups: usize,
    pub rows: usize,
    pub predicted_tool_mm: f64,
}

/// `plan --constraints`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintPlanReport {
    pub out: String,
    pub criterion: String,
    /// Groups per kind and the rows to measure.
    pub sockets: [usize; 2],
    pub planes: [usize; 2],
    pub distances: usize,
    pub points: usize,
    pub rows: usize,
    /// Candidate rows the plan chose among.
    pub pool_rows: usize,
    pub estimated: Vec<String>,
    /// What such a session cannot determine (held by `identify`).
    pub cannot_determine: Vec<String>,
    /// Predicted tool-point σ (mm) over random poses: the plan, and the random choice of as
    /// many rows from the same candidates.
    pub predicted_tool_mm: f64,
    pub random_tool_mm: f64,
    pub exchanges: usize,
    pub passes: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<AccuracyNeed>,
}

impl ConstraintPlanReport {
    /// The report of `design`, planned for `session` by `criterion`, written to `out`;
    /// parameters named by `name`.
    pub fn of<const N: usize>(
        design: &super::plan::SessionDesign<N>,
        session: super::simulate::SessionPlan,
        criterion: &str,
        out: &str,
        accuracy: Option<AccuracyNeed>,
        name: impl Fn(kinecal::Param) -> String,
    ) -> Self {
        let names =
            |ps: &[kinecal::Param]| -> Vec<String> { ps.iter().map(|p| name(*p)).collect() };
        Self {
            out: out.into(),
            criterion: criterion.into(),
            sockets: [session.sockets.0, session.sockets.1],
            planes: [session.planes.0, session.planes.1],
            distances: session.distances,
            points: session.points,
            rows: design.rows(),
            pool_rows: design.pool_rows,
            estimated: names(&design.estimated),
            cannot_determine: names(&design.held),
            predicted_tool_mm: design.planned_tool_mm,
            random_tool_mm: design.random_tool_mm,
            exchanges: design.exchanges,
            passes: design.passes,
            accuracy,
        }
    }
}

crate::reports::plain_report!(ConstraintPlanReport);

impl fmt::Display for ConstraintPlanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "planned {} rows ({} criterion, from {} candidates) into {}",
            self.rows, self.criterion, self.pool_rows, self.out
        )?;
        writeln!(
            f,
            "predicted tool-point σ over random poses: {} mm (a random choice of as many rows: {} mm)",
            sig(self.predicted_tool_mm, 3),
            sig(self.random_tool_mm, 3)
        )?;
        if !self.cannot_determine.is_empty() {
            writeln!(
                f,
                "such a session cannot determine: {}",
                self.cannot_determine.join(", ")
            )?;
        }
        if let Some(a) = &self.accuracy {
            if a.times_the_groups == 1 && a.reached {
                writeln!(f, "{} mm is reached with this session", sig(a.target_mm, 3))?;
            } else if a.reached {
                writeln!(
                    f,
                    "{} mm takes {}× the groups: {} rows (predicted {} mm)",
                    sig(a.target_mm, 3),
                    a.times_the_groups,
                    a.rows,
                    sig(a.predicted_tool_mm, 3)
                )?;
            } else {
                writeln!(
                    f,
                    "{} mm is not reached with {}× the groups ({} mm): add distances or points, \
                     or measure with less noise",
                    sig(a.target_mm, 3),
                    a.times_the_groups,
                    sig(a.predicted_tool_mm, 3)
                )?;
            }
        }
        Ok(())
    }
}

/// One kind of constraint among the held-out groups: each group against its own refitted
/// shape (a distance's length error), RMS over the groups.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct HeldOutKind {
    pub kind: String,
    pub groups: usize,
    pub before_rms_mm: f64,
    pub after_rms_mm: f64,
}

/// A parameter the model changed: its value in the robot file and in the model (mm or
/// degrees; an effect's value in its own unit).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Change {
    pub name: String,
    pub unit: String,
    pub nominal: f64,
    pub model: f64,
}

/// `kinecal report` on a constraint file: what the page shows.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ConstraintReportSummary {
    /// The page written.
    pub out: Option<String>,
    pub bytes: usize,
    pub seconds: f64,
    pub count_unit: String,
    pub n_identification: usize,
    pub n_validation: usize,
    pub n_identification_rows: usize,
    pub n_validation_rows: usize,
    /// The nominal robot and the model, by `identify`'s keys on a constraint file.
    pub before: Residuals,
    pub after: Residuals,
    /// Per kind on the identification groups, and the shapes the model fits to them.
    pub constraints: Constraints,
    /// Per kind on the held-out groups.
    pub held_out: Vec<HeldOutKind>,
    pub changed: Vec<Change>,
    /// What these identification groups cannot determine at the nominal model (held by
    /// `identify`).
    pub cannot_determine: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acceptance: Option<Acceptance>,
    /// The model predicts the held-out groups worse than the nominal robot.
    pub held_out_worse: Option<bool>,
    /// The model is a calibration of these data (`false`: exit 3).
    pub converged: bool,
    pub figures: usize,
}

crate::reports::judged_report!(ConstraintReportSummary, |r| r.converged);

impl fmt::Display for ConstraintReportSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(out) = &self.out {
            writeln!(f, "wrote {out} ({} bytes)", self.bytes)?;
        }
        writeln!(
            f,
            "{} identification groups ({} rows): RMS {} -> {} mm",
            self.n_identification,
            self.n_identification_rows,
            sig(self.before.identification_rms_mm, 4),
            sig(self.after.identification_rms_mm, 4)
        )?;
        if let (Some(b), Some(a)) = (self.before.validation_rms_mm, self.after.validation_rms_mm) {
            writeln!(
                f,
                "{} held-out groups ({} rows): RMS {} -> {} mm",
                self.n_validation,
                self.n_validation_rows,
                sig(b, 4),
                sig(a, 4)
            )?;
        }
        if let Some(a) = &self.acceptance {
            if let Some(m) = &a.message {
                writeln!(f, "{m}")?;
            }
        }
        Ok(())
    }
}
