//! The report of `kinecal identify`.

use crate::calibration::weights::Weighted;
use crate::calibration::{Held, Residuals};
use crate::formats::observations::Observed;
use crate::output::numfmt::sig;
use kinecal::{Measurement, Robot};
use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};
use std::collections::BTreeMap;
use std::fmt;

/// `kinecal identify`: residuals before and after, the parameters and the verdict.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct IdentifyReport {
    /// `lm`, `pso`, `bpnn-pso` or `pso+lm`.
    pub method: String,
    pub n_identification: usize,
    pub n_validation: usize,
    /// The robot file gave the tool point as unknown: `before` is the nominal robot with the
    /// point started from the data, not a tool anybody stated.
    pub tool_unknown: bool,
    pub before: Residuals,
    pub after: Residuals,
    pub iterations: u32,
    /// Model evaluations of all poses.
    pub evaluations: u64,
    pub seconds: f64,
    /// Every parameter of the identified model by name (mm, degrees, raw for effect values).
    pub parameters: BTreeMap<String, f64>,
    /// Names of parameters the data cannot determine.
    pub unidentifiable: Vec<String>,
    /// Held at their file values, and what they are confounded with (JSON: name → object).
    #[serde(serialize_with = "held_by_name")]
    pub held: Vec<Held>,
    /// What every estimated parameter did, in the order of the parameter list (JSON: name →
    /// object).
    #[serde(serialize_with = "changes_by_name")]
    pub changes: Vec<Change>,
    /// The numbers may be taken as a calibration (`false`: exit 3).
    pub converged: bool,
    /// How the fit ended, in words.
    pub stop: String,
    /// Parameters that moved further from their file value than a manufacturing tolerance.
    pub suspicious: Vec<String>,
    /// The identified model's robot file, when written.
    pub out: Option<String>,
    /// Best objective (mm²) per iteration, for methods that have one.
    pub fitness_history: Vec<f64>,
    /// Several reflectors: `before`/`after` per point name (the report's are totals).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_point: Option<BTreeMap<String, PointResiduals>>,
    /// With the file's σ as weights: weighted cost per degree of freedom (≈ 1 when the stated
    /// σ fit the residuals).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chi2_per_dof: Option<f64>,
    /// A few points far beyond the others' distance from the fitted model, under the gross
    /// outliers' millimetre (`crate::calibration::outliers`): warned about.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stray_points: Option<crate::calibration::outliers::Strays>,
    /// Further warnings about the data (a step along the rows' order), without "warning: ".
    #[serde(skip)]
    pub notes: Vec<String>,
    /// What the observations were (6-D, weighted, how many points).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observations: Option<ObservationSummary>,
    /// With held-out poses: the calibrated model predicts them worse than the model it started
    /// from (exit 3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out_worse: Option<bool>,
    /// With held-out poses: the verdict on them and its likely reasons.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acceptance: Option<crate::calibration::acceptance::Acceptance>,
    /// Nothing held out and thin data: the cross-validated figures `acceptance` judges
    /// (`crate::calibration::thin_data`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cross_validated: Option<crate::calibration::thin_data::CrossValidated>,
}

/// One reflector's residuals (`per_point`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointResiduals {
    pub n_identification: usize,
    pub n_validation: usize,
    pub before: Residuals,
    pub after: Residuals,
}

impl PointResiduals {
    /// Each reflector's `before` (`models.0`) and `after` (`models.1`) on the identification and
    /// held-out observations (`None` with one point).
    pub fn per_point<const N: usize, V: kinecal::ValueStorage>(
        names: &[String],
        models: (&Robot<f64, N, V>, &Robot<f64, N, V>),
        (ident, valid): (&[Measurement<f64, N>], &[Measurement<f64, N>]),
    ) -> Option<BTreeMap<String, PointResiduals>> {
        if names.len() < 2 {
            return None;
        }
        let of = |data: &[Measurement<f64, N>], k: usize| -> Vec<Measurement<f64, N>> {
            data.iter()
                .filter(|m| m.tool as usize == k)
                .copied()
                .collect()
        };
        Some(
            names
                .iter()
                .enumerate()
                .map(|(k, n)| {
                    let (i, v) = (of(ident, k), of(valid, k));
                    (
                        n.clone(),
                        PointResiduals {
                            n_identification: i.len(),
                            n_validation: v.len(),
                            before: Residuals::of(models.0, &i, &v),
                            after: Residuals::of(models.1, &i, &v),
                        },
                    )
                })
                .collect(),
        )
    }
}

/// The kind of observations a fit used.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObservationSummary {
    /// Orientation observed (`rx_deg`, `ry_deg`, `rz_deg`).
    pub six_d: bool,
    /// Weighted by the file's σ columns.
    pub sigma: bool,
    /// Measured points per pose (reflectors).
    pub points: usize,
    /// Observations (points seen) among the identification poses.
    pub identification_observations: usize,
    /// Millimetres a degree of orientation error weighs, when set with `--deg-weight-mm`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deg_weight_mm: Option<f64>,
    /// Error floor added to each point coordinate's σ (mm): what the model cannot explain
    /// (crate::calibration::weights); 0 when the stated σ explain the residuals.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub floor_mm: Option<f64>,
    /// The same for each orientation component (degrees).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub floor_deg: Option<f64>,
    /// Factor on the balanced orientation weight, chosen by cross-validating position
    /// prediction over the identification poses (6-D without `--deg-weight-mm`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_factor: Option<f64>,
    /// Cross-validated position RMS (mm) per factor compared.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_cv_rms_mm: Option<BTreeMap<String, f64>>,
}

impl ObservationSummary {
    /// What a fit over `observations` observations of `observed` used: the file's kind, the
    /// user's `--deg-weight-mm` and what the weighting settled on (`w`).
    pub fn new<const N: usize>(
        observed: &Observed<N>,
        observations: usize,
        deg_weight_mm: Option<f64>,
        w: &Weighted,
    ) -> Self {
        Self {
            six_d: observed.six_d,
            sigma: observed.sigma,
            points: observed.names.len().max(1),
            identification_observations: observations,
            deg_weight_mm,
            floor_mm: w.floors.map(|f| f.point_mm),
            floor_deg: w
                .floors
                .filter(|_| observed.six_d)
                .map(|f| f.orientation_rad.to_degrees()),
            orientation_factor: w.orientation_cv.as_ref().map(|c| c.0),
            orientation_cv_rms_mm: w
                .orientation_cv
                .as_ref()
                .map(|c| c.1.iter().map(|(f, r)| (format!("{f}"), *r)).collect()),
        }
    }
}

/// One estimated parameter: file value, calibrated value, change and 1-σ (file units).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Change {
    #[serde(skip)]
    pub name: String,
    #[serde(skip)]
    pub length: bool,
    /// Not compared with a tolerance (base estimated from the data, effect values).
    #[serde(skip)]
    pub free_start: bool,
    pub nominal: f64,
    pub calibrated: f64,
    pub change: f64,
    /// 1-σ of the estimate (with a prior: the posterior's).
    pub sigma: Option<f64>,
    /// 1-σ from the data alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub data_sigma: Option<f64>,
    /// The prior's 1-σ on the change, when the parameter has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior_sigma: Option<f64>,
    /// How much of the estimate the data determined (0 … 1; the rest is the prior's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub data_share: Option<f64>,
}

impl Change {
    /// Moved further than `mm` (lengths) or `deg` (angles) from the file value.
    pub fn beyond_tolerance(&self, mm: f64, deg: f64) -> bool {
        !self.free_start && self.change.abs() > if self.length { mm } else { deg }
    }

    /// The data alone determine it no better than `mm` (lengths) or `deg` (angles) 1-σ.
    pub fn barely_determined(&self, mm: f64, deg: f64) -> bool {
        let effect = ["joint-", "thermal-expansion", "base-drift"]
            .iter()
            .any(|k| self.name.starts_with(k));
        let tolerance = if self.length { mm } else { deg };
        !effect
            && match self.data_sigma {
                Some(s) => {
                    s.partial_cmp(&tolerance) != Some(std::cmp::Ordering::Less) && s != tolerance
                }
                // Estimated by the prior alone (the data did not determine it).
                None => self.data_share.is_some(),
            }
    }
}

fn held_by_name<S: Serializer>(held: &[Held], s: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    struct Entry<'a> {
        confounded_with: &'a [String],
    }
    let mut m = s.serialize_map(Some(held.len()))?;
    for h in held {
        m.serialize_entry(
            &h.name,
            &Entry {
                confounded_with: &h.confounded_with,
            },
        )?;
    }
    m.end()
}

fn changes_by_name<S: Serializer>(changes: &[Change], s: S) -> Result<S::Ok, S::Error> {
    let mut m = s.serialize_map(Some(changes.len()))?;
    for c in changes {
        m.serialize_entry(&c.name, c)?;
    }
    m.end()
}

impl super::Report for IdentifyReport {
    fn to_json(&self) -> serde_json::Value {
        super::with_accepted(super::json_value(self), self)
    }
    fn converged(&self) -> bool {
        self.converged && self.held_out_worse != Some(true)
    }
    fn non_finite(&self) -> Option<String> {
        super::finite::first_non_finite(self)
    }
}

impl fmt::Display for IdentifyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let g = |v: Option<f64>| v.map_or("-".to_string(), |x| sig(x, 4));
        writeln!(
            f,
            "method {}: {} identification poses, {} validation poses",
            self.method, self.n_identification, self.n_validation
        )?;
        writeln!(
            f,
            "{:>8} {:>16} {:>16} {:>16} {:>16}",
            "", "ident RMS mm", "valid RMS mm", "valid mean mm", "valid max mm"
        )?;
        if self.tool_unknown {
            writeln!(
                f,
                "the tool point was unknown: \"before\" is the nominal robot with the point \
                 started from the data"
            )?;
        }
        for (k, r) in [("before", &self.before), ("after", &self.after)] {
            writeln!(
                f,
                "{:>8} {:>16} {:>16} {:>16} {:>16}",
                k,
                g(Some(r.identification_rms_mm).filter(|x| x.is_finite())),
                g(r.validation_rms_mm),
                g(r.validation_mean_mm),
                g(r.validation_max_mm)
            )?;
        }
        if self.after.identification_rms_deg.is_some() {
            for (k, r) in [("before", &self.before), ("after", &self.after)] {
                writeln!(
                    f,
                    "{:>8} {:>16} {:>16}   (orientation, degrees)",
                    k,
                    g(r.identification_rms_deg),
                    g(r.validation_rms_deg)
                )?;
            }
        }
        if let Some(pp) = &self.per_point {
            for (name, p) in pp {
                writeln!(
                    f,
                    "{:>8} {:>16} {:>16}   point {name}: {} + {} observations, before {} / {} mm",
                    "after",
                    g(Some(p.after.identification_rms_mm)),
                    g(p.after.validation_rms_mm),
                    p.n_identification,
                    p.n_validation,
                    g(Some(p.before.identification_rms_mm)),
                    g(p.before.validation_rms_mm),
                )?;
            }
        }
        if let Some(c) = self.chi2_per_dof {
            writeln!(
                f,
                "χ²/dof with the file's σ: {} (≈ 1 when the σ explain the residuals)",
                sig(c, 3)
            )?;
        }
        writeln!(
            f,
            "{} iterations, {} evaluations, {} s: {}",
            self.iterations,
            self.evaluations,
            sig(self.seconds, 3),
            self.stop
        )?;
        let moved: Vec<&Change> = self.changes.iter().filter(|c| c.change != 0.0).collect();
        if !moved.is_empty() {
            writeln!(f)?;
            let shares = moved.iter().any(|c| c.data_share.is_some());
            writeln!(
                f,
                "{:<16} {:>14} {:>14} {:>12} {:>10}{}",
                "parameter",
                "file",
                "calibrated",
                "change",
                "1-σ",
                if shares {
                    "   data share (prior 1-σ)"
                } else {
                    ""
                }
            )?;
            for c in moved {
                // Effect values are in their raw units (docs/formats.md#effects): rad, rad
                // per m, per kelvin; a drift in mm per second.
                let effect = ["joint-", "thermal-expansion", "base-drift"]
                    .iter()
                    .any(|k| c.name.starts_with(k));
                let unit = if c.name.starts_with("base-drift") {
                    " mm/s"
                } else if effect || (c.free_start && !c.length && c.name.contains('[')) {
                    ""
                } else if c.length {
                    " mm"
                } else {
                    " °"
                };
                let flag = if self.suspicious.contains(&c.name) {
                    "  <- suspicious"
                } else {
                    ""
                };
                let share = match (c.data_share, c.prior_sigma) {
                    (Some(d), Some(p)) => format!("   {:>3.0} % ({})", 100.0 * d, sig(p, 2)),
                    _ => String::new(),
                };
                writeln!(
                    f,
                    "{:<16} {:>14} {:>14} {:>12} {:>10}{unit}{share}{flag}",
                    c.name,
                    sig(c.nominal, 7),
                    sig(c.calibrated, 7),
                    sig(c.change, 3),
                    c.sigma.map_or("-".into(), |s| sig(s, 2)),
                )?;
            }
        }
        // +v is how the robot's base appeared to move in the tracker's frame (the tracker
        // itself moved by −v).
        let drift: Vec<&Change> = self
            .changes
            .iter()
            .filter(|c| c.name.starts_with("base-drift"))
            .collect();
        if drift.len() == 3 && drift.iter().any(|c| c.calibrated != 0.0) {
            let v: Vec<f64> = drift.iter().map(|c| c.calibrated * 3600.0).collect();
            let sd = drift.iter().filter_map(|c| c.sigma).fold(0.0f64, f64::max) * 3600.0;
            writeln!(f)?;
            writeln!(
                f,
                "the robot's base appeared to move by {} mm per hour in the measurement frame (x {}, y {}, z {} mm per hour, 1-σ up to {}): the tracker drifting (or the robot moving) during the session; fitted with the model, not written to it (it is this session's, not the arm's)",
                sig(v.iter().map(|x| x * x).sum::<f64>().sqrt(), 3),
                sig(v[0], 3),
                sig(v[1], 3),
                sig(v[2], 3),
                sig(sd, 2)
            )?;
        }
        if !self.held.is_empty() {
            writeln!(f)?;
            writeln!(
                f,
                "held at their file values (the data cannot determine them):"
            )?;
            for h in &self.held {
                if h.confounded_with.is_empty() {
                    writeln!(f, "  {:<14} no observation moves with it", h.name)?;
                } else {
                    writeln!(
                        f,
                        "  {:<14} confounded with {}",
                        h.name,
                        h.confounded_with.join(", ")
                    )?;
                }
            }
        }
        if let Some(a) = &self.acceptance {
            writeln!(f)?;
            let what = if a.extrapolated {
                "poses across the joint ranges"
            } else if self.cross_validated.is_some() {
                "left-out poses"
            } else {
                "held-out poses"
            };
            match &a.message {
                Some(m) => writeln!(f, "{what}: {m}")?,
                None => writeln!(
                    f,
                    "{what}: predicted better than by the starting model ({}× the \
                     identification RMS)",
                    sig(a.held_out_ratio, 3)
                )?,
            }
        }
        if let Some(out) = &self.out {
            writeln!(f, "wrote the identified model to {out}")?;
        }
        Ok(())
    }
}

impl IdentifyReport {
    /// Why the fitted model is no calibration, as the note of a `--out` not written says
    /// (`None`: it is one).
    pub fn unfit(&self) -> Option<String> {
        let unseen = match self.cross_validated {
            _ if self.acceptance.as_ref().is_some_and(|a| a.extrapolated) => {
                "poses across the joint ranges (as far as these poses tell)"
            }
            Some(_) => "left-out poses",
            None => "held-out poses",
        };
        let worse = self.held_out_worse == Some(true);
        let started = "the model it started from";
        crate::reports::model_out::unfit(worse, self.converged, unseen, started)
    }

    /// The warnings of a finished fit, one message each as stderr shows them: no held-out
    /// poses, χ²/dof far from 1, suspicious parameters, the held-out verdict, not converged.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        use crate::calibration::thin_data::{enough_poses, MIN_SUPPORT};
        let cv = self
            .cross_validated
            .as_ref()
            .filter(|_| self.n_validation == 0);
        let enough = |cv: &crate::calibration::thin_data::CrossValidated| {
            enough_poses(
                cv.parameters,
                cv.equations as f64 / self.n_identification.max(1) as f64,
            )
        };
        match cv.map(|cv| (cv, cv.figures(), cv.not_validated())) {
            Some((cv, Some((start, after)), _)) => out.push(format!(
                "note: nothing was held out and the data are thin ({} equations for {} \
                 parameters), so the fit was cross-validated ({} folds{}): the poses left out \
                 are predicted to {} mm RMS, against {} mm by the model it started from; \
                 --holdout 0.2 (or --validate FILE) judges it on unseen data",
                cv.equations,
                cv.parameters,
                cv.folds,
                if cv.unsupported > 0 {
                    format!(
                        "; {} of {} left-out observations on an effect value fewer than \
                         {MIN_SUPPORT} of the other poses move, predicted with it held",
                        cv.unsupported, cv.observations
                    )
                } else {
                    String::new()
                },
                sig(after, 4),
                sig(start, 4)
            )),
            Some((cv, None, _)) => out.push(format!(
                "warning: nothing was held out, and the data are too thin to cross-validate: \
                 without the poses of one of {} folds, the others ({} equations in all) could \
                 not be fitted for {} parameters, so the fit's RMS says little about new \
                 poses: measure about {} poses spread over the working range, or hold \
                 parameters with --fix",
                cv.folds,
                cv.equations,
                cv.parameters,
                enough(cv)
            )),
            _ if self.n_validation == 0 => {
                out.push(crate::calibration::acceptance::NOT_JUDGED.to_string())
            }
            _ => {}
        }
        if let Some(c) = self
            .changes
            .iter()
            .find(|c| c.name == "thermal-expansion1")
            .filter(|_| self.converged)
        {
            out.extend(crate::calibration::thermal::undetermined(
                c.calibrated,
                c.sigma,
            ));
        }
        if let Some(c) = self.chi2_per_dof {
            if !(0.25..=4.0).contains(&c) {
                out.push(format!(
                    "warning: χ²/dof = {} with the file's σ: the residuals are {}× what the \
                     stated uncertainties explain ({}); the fit added an error floor (JSON \
                     `observations`)",
                    sig(c, 3),
                    sig(c.sqrt(), 3),
                    if c > 1.0 {
                        "the model misses an effect (kinecal diagnose) or the σ are too small"
                    } else {
                        "the σ are too large"
                    }
                ));
            }
        }
        out.extend(self.notes.iter().map(|n| format!("warning: {n}")));
        if let Some(s) = &self.stray_points {
            out.push(format!("warning: {}", s.warning()));
        }
        if let Some(w) = suspicious_warning(&self.suspicious) {
            out.push(format!("warning: {w}"));
        }
        if let Some(m) = self.acceptance.as_ref().and_then(|a| a.message.as_ref()) {
            let level = if self.held_out_worse == Some(true) {
                "error"
            } else {
                "warning"
            };
            out.push(format!("{level}: {m}"));
        }
        if !self.converged {
            out.push(format!(
                "error: the fit {}; these numbers are not a calibration (exit 3)",
                self.stop
            ));
        }
        out
    }
}

/// The warning about parameters that moved beyond a manufacturing tolerance (tracker and
/// constraint sessions alike), or `None` when none did.
pub fn suspicious_warning(suspicious: &[String]) -> Option<String> {
    (!suspicious.is_empty()).then(|| {
        format!(
            "{} moved further than a manufacturing tolerance explains: check the units, the tool \
             point and the robot file (--tolerance-mm/--tolerance-deg set the limit)",
            suspicious.join(", ")
        )
    })
}
