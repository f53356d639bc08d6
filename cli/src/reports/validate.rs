//! The report of `kinecal validate` (docs/formats.md, "Validation on another session"). It
//! also reads back (`Deserialize`): `kinecal report --validate-json V.json` shows it.

use super::finite::first_non_finite;
use crate::calibration::outliers::Outlier;
use crate::calibration::recalibration::Recalibration;
use crate::calibration::stats::SetFigures;
use crate::calibration::validate::{Judged, Validation};
use crate::output::numfmt::sig;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;

/// The reason `validate` gives when the model is worse than the nominal robot (stderr, exit 3).
pub const RECALIBRATE: &str = "the robot or the set-up changed since calibration: recalibrate";

pub use crate::calibration::validate::MISMATCH_RMS_MM;

/// [`crate::calibration::wrapped_readings::Wrapped`] as the report gives it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WrappedReport {
    pub joint: usize,
    pub effect: String,
    pub rows: usize,
    pub of: usize,
    pub turned_rms_mm: f64,
    /// Every joint turned on some row, the one above first.
    #[serde(default)]
    pub joints: Vec<usize>,
}

/// A registered tool point this far (mm) from the model's is a new probe or reflector, which the
/// "changed since calibration" verdict names.
pub const NEW_TOOL_MM: f64 = 5.0;

/// `verdict` with, when registering the tool too lets the model hold (`--register base` or
/// `none`), the clause that says so.
fn tool_moved_clause(v: &Validation, verdict: String) -> String {
    match v.tool_moved {
        Some(rms) => format!(
            "{verdict}; registered with the tool too, the model leaves {} mm RMS: the probe or \
             reflector moved since calibration: validate with --register base+tool",
            sig(rms, 4)
        ),
        None => verdict,
    }
}

/// `kinecal validate`: both robots registered onto the session the same way, and their errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValidateReport {
    pub robot_file: String,
    pub model_file: String,
    pub data_file: String,
    /// `none`, `base` or `base+tool`.
    pub register: String,
    /// Names of the parameters fitted (`base.x` …, `tool.x` …).
    pub registered: Vec<String>,
    pub poses: usize,
    pub observations: usize,
    /// Equations of the registration: three per position, three more per orientation.
    #[serde(default)]
    pub equations: usize,
    /// The calibrated model, registered.
    pub model: Figures,
    /// The nominal robot, registered the same way.
    pub nominal: Figures,
    /// Several reflectors: each one's figures (name → `model`, `nominal`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub per_point: BTreeMap<String, PointFigures>,
    /// The model's position RMS is above the nominal robot's (strictly): exit 3.
    pub worse_than_nominal: bool,
    /// Both robots' position RMS are above [`MISMATCH_RMS_MM`]: the data do not fit the robot
    /// file at all (exit 3).
    #[serde(default)]
    pub data_mismatch: bool,
    /// Effects of the model whose values look written in degrees (`joint 2's joint-table`):
    /// read so, the model predicts the session many times better than as written.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects_in_degrees: Vec<String>,
    /// The model's position RMS (mm) with those values read as degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effects_as_degrees_rms_mm: Option<f64>,
    /// The model predicts left-out poses of the session many times worse than the robot
    /// calibrated again on the others (`recalibration`): the robot changed since its
    /// calibration, although the model may still beat the nominal robot (exit 3).
    #[serde(default)]
    pub changed_since_calibration: bool,
    /// The session is too short to calibrate the robot again on part of it, the check that
    /// tells whether it changed since: no verdict (exit 3). Eight poses of a robot whose joint
    /// 2 was re-mastered by 0.1° said "the model still holds" at 90 times the unchanged
    /// robot's RMS.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub too_few_to_judge: bool,
    /// The session's residuals step at one row (a reflector re-seated, the tracker bumped):
    /// the warning that names the rows; no verdict (exit 3). A 3 mm reflector step halfway
    /// through a session "held" at 1.5 mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session_step: Option<String>,
    /// The model and a new calibration on left-out poses of the session (`folds`,
    /// `model_rms_mm`, `recalibrated_rms_mm`); absent when the model is worse than the nominal
    /// robot or the session has gross outliers.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recalibration: Option<Recalibration>,
    /// A few rows far from both registered robots (`line`, `distance_mm`): wrong readings that
    /// pull the registration, so there is no verdict (exit 3).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gross_outliers: Vec<Outlier>,
    /// The joint whose readings are a turn (360°) from those the model's scale or table was
    /// calibrated on, on many rows (`joint`, `effect`, `rows`, `of`, `turned_rms_mm`): no
    /// verdict (exit 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrapped_readings: Option<WrappedReport>,
    /// With a bad verdict, the joint whose zero moved since the calibration (`joint`,
    /// `shift_deg`, `rms_mm` as registered, `freed_rms_mm` with that zero free too,
    /// `mean_reading_deg`, `reading_span_deg`, `last_joint`): the verdict names it (exit 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zero_moved: Option<crate::calibration::zero_moved::ZeroMoved>,
    /// The verdict in one line.
    pub verdict: String,
}

/// "; joint J's zero moved …" when one joint's zero explains a bad verdict of `model` on
/// `data` (the files' names), else nothing.
fn zero_clause(v: &crate::calibration::validate::Validation, model: &str, data: &str) -> String {
    v.zero_moved.map_or(String::new(), |z| {
        format!("; {}", z.clause(v.register.id(), model, data))
    })
}

/// Below this many equations per registered parameter `validate` warns that its verdict is
/// uncertain (30 positions for `base+tool`): the registration absorbs part of either robot's
/// errors, by about `p/m` of their squares.
pub const EQUATIONS_PER_REGISTERED: usize = 10;

impl ValidateReport {
    /// The warning when the session is thin for its registration (fewer than
    /// [`EQUATIONS_PER_REGISTERED`] equations per registered parameter).
    pub fn thin(&self) -> Option<String> {
        let params = self.registered.len();
        let thin =
            params > 0 && !self.data_mismatch && self.equations < EQUATIONS_PER_REGISTERED * params;
        thin.then(|| {
            let per_pose = self.equations as f64 / self.poses.max(1) as f64;
            format!(
                "warning: {} poses ({} equations) for {params} registered parameters ({}): the \
                 registration absorbs part of either robot's errors, so the verdict is \
                 uncertain; measure about {} poses{}",
                self.poses,
                self.equations,
                self.register,
                crate::calibration::thin_data::poses_for(
                    EQUATIONS_PER_REGISTERED * params,
                    per_pose
                ),
                if self.register == "base+tool" {
                    ", or register the base alone (--register base)"
                } else {
                    ""
                }
            )
        })
    }
}

/// One robot's errors on the session (mm; orientation in degrees with 6-D data), and the
/// registration fitted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Figures {
    pub rms_mm: f64,
    pub mean_mm: f64,
    pub max_mm: f64,
    pub p95_mm: f64,
    pub rms_x_mm: f64,
    pub rms_y_mm: f64,
    pub rms_z_mm: f64,
    /// Signed means (measured − model): what a registration left over.
    pub mean_x_mm: f64,
    pub mean_y_mm: f64,
    pub mean_z_mm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rms_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub p95_deg: Option<f64>,
    /// The registration fitted: name → value (mm, degrees).
    #[serde(default)]
    pub registration: BTreeMap<String, f64>,
    /// Registration parameters the session could not determine.
    #[serde(default)]
    pub held: Vec<String>,
}

/// One reflector's position errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointFigures {
    pub observations: usize,
    pub model: PointStats,
    pub nominal: PointStats,
}

/// RMS, mean, largest and 95th percentile of a reflector's distance errors (mm).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointStats {
    pub rms_mm: f64,
    pub mean_mm: f64,
    pub max_mm: f64,
    pub p95_mm: f64,
}

impl From<&SetFigures> for PointStats {
    fn from(f: &SetFigures) -> Self {
        Self {
            rms_mm: f.total.rms,
            mean_mm: f.total.mean,
            max_mm: f.total.max,
            p95_mm: f.total.p95,
        }
    }
}

impl From<&Judged> for Figures {
    fn from(j: &Judged) -> Self {
        let f = &j.figures;
        let o = j.orientation;
        Self {
            rms_mm: f.total.rms,
            mean_mm: f.total.mean,
            max_mm: f.total.max,
            p95_mm: f.total.p95,
            rms_x_mm: f.x.rms,
            rms_y_mm: f.y.rms,
            rms_z_mm: f.z.rms,
            mean_x_mm: f.x.mean,
            mean_y_mm: f.y.mean,
            mean_z_mm: f.z.mean,
            rms_deg: o.map(|(s, _)| s.rms_mm),
            mean_deg: o.map(|(s, _)| s.mean_mm),
            max_deg: o.map(|(s, _)| s.max_mm),
            p95_deg: o.map(|(_, p)| p),
            registration: j.registration.clone(),
            held: j.held.clone(),
        }
    }
}

impl ValidateReport {
    /// The report of `v`, with the files' names `(robot, model, data)`.
    pub fn of(v: &Validation, (robot, model, data): (&str, &str, &str)) -> Self {
        let per_point = v
            .model
            .per_point
            .iter()
            .zip(&v.nominal.per_point)
            .map(|((name, m), (_, n))| {
                (
                    name.clone(),
                    PointFigures {
                        observations: m.poses,
                        model: m.into(),
                        nominal: n.into(),
                    },
                )
            })
            .collect();
        let (m, n) = (v.model.figures.total.rms, v.nominal.figures.total.rms);
        let orientation = match (v.model.orientation, v.nominal.orientation) {
            (Some((m, _)), Some((n, _))) => format!(
                ", orientation RMS {}° with the model, {}° with the nominal robot",
                sig(m.rms_mm, 4),
                sig(n.rms_mm, 4)
            ),
            _ => String::new(),
        };
        // Nothing else decided, and the recalibration check could not run.
        let unjudged = v.recalibration.is_none()
            && !v.worse_than_nominal
            && v.outlier_reason.is_none()
            && v.gross_outliers.is_empty()
            && v.wrapped.is_none()
            && v.effects_in_degrees.is_none()
            && !v.orientation_off
            && !(m > MISMATCH_RMS_MM && n > MISMATCH_RMS_MM);
        let figures = format!(
            "position RMS {} mm with the model, {} mm with the nominal robot{orientation}, both \
             registered `{}` on {} poses",
            sig(m, 4),
            sig(n, 4),
            v.register.id(),
            v.poses
        );
        Self {
            robot_file: robot.to_string(),
            model_file: model.to_string(),
            data_file: data.to_string(),
            register: v.register.id().to_string(),
            registered: v.registered.clone(),
            poses: v.poses,
            observations: v.observations,
            equations: v.equations,
            model: (&v.model).into(),
            nominal: (&v.nominal).into(),
            per_point,
            worse_than_nominal: v.worse_than_nominal,
            data_mismatch: m > MISMATCH_RMS_MM && n > MISMATCH_RMS_MM,
            effects_in_degrees: v
                .effects_in_degrees
                .as_ref()
                .map_or(Vec::new(), |d| d.effects.clone()),
            effects_as_degrees_rms_mm: v.effects_in_degrees.as_ref().map(|d| d.rms_mm),
            changed_since_calibration: v.changed,
            too_few_to_judge: unjudged,
            session_step: v.step.clone(),
            recalibration: v.recalibration.clone(),
            gross_outliers: v.gross_outliers.clone(),
            zero_moved: v.zero_moved,
            wrapped_readings: v.wrapped.as_ref().map(|w| WrappedReport {
                joint: w.joint,
                effect: w.effect.to_string(),
                rows: w.rows,
                of: w.of,
                turned_rms_mm: w.turned_rms_mm,
                joints: w.joints.clone(),
            }),
            verdict: tool_moved_clause(
                v,
                if let Some(z) = v
                    .zero_moved
                    .filter(|_| m > MISMATCH_RMS_MM && n > MISMATCH_RMS_MM)
                {
                    // Not the units: one joint's zero explains the session.
                    format!("{} ({figures})", z.clause(v.register.id(), model, data))
                } else if m > MISMATCH_RMS_MM && n > MISMATCH_RMS_MM {
                    format!(
                    "the data do not fit the robot file ({figures}; above {MISMATCH_RMS_MM} mm \
                     neither robot describes the session): check the units, the axes (swapped \
                     or mirrored), the joint columns' order and signs and the couplings \
                     (`kinecal check`); if they are right, the robot changed beyond what a \
                     calibration corrects"
                )
                } else if let Some(w) = &v.wrapped {
                    format!(
                    "no verdict: {} of {} rows read joint {} a turn (360°) from the readings the \
                     model's {} was calibrated on (with the readings of joint{} {} turned where \
                     that brings a row much closer, the model leaves {} mm RMS instead of {}): the \
                     readings were wrapped (into ±180°, or by another turn) where the \
                     calibration's were not, or the other way round; unwrap them to the \
                     calibration's turn (add or subtract 360°) and validate again ({figures})",
                    w.rows,
                    w.of,
                    w.joint,
                    w.effect,
                    if w.joints.len() > 1 { "s" } else { "" },
                    w.joints
                        .iter()
                        .map(|j| j.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                    sig(w.turned_rms_mm, 4),
                    sig(w.rms_mm, 4)
                )
                } else if let Some(why) = &v.outlier_reason {
                    format!("no verdict: {why}, and validate again ({figures})")
                } else if let Some(step) = &v.step {
                    format!("no verdict: {step}; validate each part ({figures})")
                } else if let Some(d) = &v.effects_in_degrees {
                    let still = if d.rms_mm > n {
                        ", still worse than the nominal robot: recalibrate after converting them"
                    } else {
                        ""
                    };
                    format!(
                    "the values of {} look written in degrees: read as degrees the model predicts \
                     the session to {} mm{still} ({figures}); the file holds them in radians \
                     (docs/formats.md#effects): multiply them by π/180 and validate again",
                    d.effects.join(", "),
                    sig(d.rms_mm, 4)
                )
                } else if v.orientation_off {
                    format!(
                    "the tool orientation the model states does not hold: its median row is {}° \
                     off, where a calibrated tool frame is within a degree ({figures}); the \
                     model's rpy_deg was fitted to orientation columns that do not describe the \
                     tool (radians, another order or frame), or the probe was mounted again \
                     since: recalibrate, or judge positions alone with --positions-only",
                    sig(v.model.orientation_median_deg.unwrap_or(f64::NAN), 3)
                )
                } else if v.worse_than_nominal {
                    format!("{RECALIBRATE} ({figures}){}", zero_clause(v, model, data))
                } else if let Some(r) = v.recalibration.as_ref().filter(|_| v.changed) {
                    let left_out = format!(
                        "left-out poses of the session: {} mm RMS with the model, {} mm with the \
                         robot calibrated again on the others{}; {figures}",
                        sig(r.model_rms_mm, 4),
                        sig(r.recalibrated_rms_mm, 4),
                        match r.with_joint_scales_rms_mm.filter(|_| r.joint_scale()) {
                            Some(s) => format!(
                                ", {} mm with a scale on each joint's readings too: a joint's \
                                 readings changed their scale since calibration (a gear ratio or \
                                 an encoder's resolution set anew, a bad export); kinecal \
                                 diagnose names the joint",
                                sig(s, 4)
                            ),
                            None => String::new(),
                        }
                    );
                    // A new tool: the model's fitted wrist errors act differently at its
                    // point, so the robot need not have changed.
                    if v.tool_shift_mm > NEW_TOOL_MM {
                        format!(
                            "the model no longer fits this set-up: recalibrate ({left_out}); the \
                             tool point registered {} mm from the model's: a new probe or \
                             reflector, which the model's fitted wrist errors move differently \
                             (calibrate again with it), or the robot changed since calibration{}",
                            sig(v.tool_shift_mm, 3),
                            zero_clause(v, model, data)
                        )
                    } else {
                        format!(
                            "the robot changed since calibration: recalibrate ({left_out}){}",
                            zero_clause(v, model, data)
                        )
                    }
                } else if unjudged {
                    format!(
                        "no verdict: {} poses are too few to calibrate the robot again on part \
                         of them, the check that tells whether it changed since calibration \
                         ({figures}); measure more poses (as many as the model has parameters \
                         on each part), then validate again",
                        v.poses
                    )
                } else {
                    format!("the model still holds ({figures})")
                },
            ),
        }
    }
}

impl super::Report for ValidateReport {
    fn to_json(&self) -> serde_json::Value {
        super::with_accepted(super::json_value(self), self)
    }
    /// A model worse than the nominal robot or of a robot that changed since must not be
    /// used, and data that neither robot describes or that hold wrong readings judge nothing:
    /// exit 3.
    fn converged(&self) -> bool {
        !self.worse_than_nominal
            && !self.data_mismatch
            && !self.changed_since_calibration
            && !self.too_few_to_judge
            && self.session_step.is_none()
            && self.gross_outliers.is_empty()
            && self.wrapped_readings.is_none()
    }
    fn non_finite(&self) -> Option<String> {
        first_non_finite(self)
    }
}

impl fmt::Display for ValidateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "validate {} on {}: {} poses ({} observations), robot file {}",
            self.model_file, self.data_file, self.poses, self.observations, self.robot_file
        )?;
        writeln!(
            f,
            "registered ({}): {}",
            self.register,
            if self.registered.is_empty() {
                "nothing, both as their files give them".to_string()
            } else {
                self.registered.join(", ")
            }
        )?;
        writeln!(
            f,
            "{:<8} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
            "(mm)", "RMS", "mean", "max", "95 %", "RMS x", "RMS y", "RMS z"
        )?;
        for (name, r) in [("model", &self.model), ("nominal", &self.nominal)] {
            let cells = [
                r.rms_mm, r.mean_mm, r.max_mm, r.p95_mm, r.rms_x_mm, r.rms_y_mm, r.rms_z_mm,
            ]
            .map(|v| format!("{:>10}", sig(v, 4)));
            writeln!(f, "{name:<8} {}", cells.join(" "))?;
        }
        for (name, r) in [("model", &self.model), ("nominal", &self.nominal)] {
            if let (Some(rms), Some(p95)) = (r.rms_deg, r.p95_deg) {
                writeln!(
                    f,
                    "{name:<8} orientation RMS {}°, 95 % {}°",
                    sig(rms, 4),
                    sig(p95, 4)
                )?;
            }
        }
        for (name, p) in &self.per_point {
            writeln!(
                f,
                "point {name}: {} observations, RMS {} mm (model), {} mm (nominal)",
                p.observations,
                sig(p.model.rms_mm, 4),
                sig(p.nominal.rms_mm, 4)
            )?;
        }
        writeln!(f, "{}", self.verdict)
    }
}
