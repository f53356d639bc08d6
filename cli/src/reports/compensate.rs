//! The report of `kinecal compensate` ([`crate::compensation`]).

use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

/// `kinecal compensate`: how the targets went and what was written.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CompensateReport {
    /// Target rows.
    pub targets: usize,
    /// Rows with status `ok`, and the others.
    pub ok: usize,
    pub failed: usize,
    /// Rows per status (`ok`, `singular`, `unreachable`, `limited`, `invalid`).
    pub status: BTreeMap<String, usize>,
    /// Rows with an orientation (rx, ry, rz), and without.
    pub pose_targets: usize,
    pub point_targets: usize,
    /// RMS of the model's remaining error at the commands of the `ok` rows (mm); `None`
    /// without such rows.
    pub model_error_rms_mm: Option<f64>,
    /// |command − seed| over every joint of every row (degrees).
    pub correction_rms_deg: f64,
    pub correction_max_deg: f64,
    /// `f64`, or `f32` as the controller computes.
    pub precision: String,
    /// Rows were a trajectory (each warm-started from the previous one).
    pub stream: bool,
    pub seconds: f64,
    pub microseconds_per_target: f64,
    /// The joint-command file written.
    pub out: String,
    /// The model's robot file, its name, joints and effects (text only).
    #[serde(skip)]
    pub model: String,
    #[serde(skip)]
    pub model_name: String,
    #[serde(skip)]
    pub joints: usize,
    #[serde(skip)]
    pub effects: usize,
    /// The model file has a `[base]` (otherwise the targets are in the robot base frame).
    #[serde(skip)]
    pub base_known: bool,
    /// The targets file (text only).
    #[serde(skip)]
    pub targets_file: String,
    /// `--cartesian`: the nominal robot file whose kinematics the controller keeps (the output
    /// then holds the targets to send it: x, y, z[, rx, ry, rz]).
    pub cartesian_nominal: Option<String>,
    /// The reflector the targets are points of (`--tool`, or the model's first `[[tools]]`
    /// name); `None` for a model of one unnamed tool point.
    pub reflector: Option<String>,
    /// Why targets were not reached, when they look given in another frame (also printed).
    pub hint: Option<String>,
    /// A model with thermal expansion and targets without the arm's temperature (`temp_c`):
    /// the expansion is evaluated at the model's reference temperature there (also printed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub temperature_warning: Option<String>,
    /// Targets were not reached: [`unreached_error`] (also printed; exit 3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// The error when `failed` of `targets` were not reached (the command line prints it as
/// `error: …` and exits 3; Python warns with it): their commands, or with `cartesian` the
/// targets to send a controller that keeps its nominal kinematics, must not be sent.
pub fn unreached_error(failed: usize, targets: usize, cartesian: bool) -> Option<String> {
    let rows = if cartesian {
        "their rows keep the target, with a failure status"
    } else {
        "their rows hold the best command found within --max-step-deg of the seed, with a \
         failure status"
    };
    (failed > 0).then(|| {
        format!(
            "{failed} of {targets} targets were not reached within --accept-mm, or only near a \
             singularity, past a joint limit or --max-step-deg (each row's status says which; \
             {rows}: do not send them; exit 3)"
        )
    })
}

impl super::Report for CompensateReport {
    fn to_json(&self) -> serde_json::Value {
        super::json_value(self)
    }
    /// A target the model cannot reach within `--accept-mm` is not a success: its row keeps
    /// the seed with a failure status, and the command exits 3.
    fn converged(&self) -> bool {
        self.failed == 0
    }
    fn non_finite(&self) -> Option<String> {
        super::finite::first_non_finite(self)
    }
}

impl fmt::Display for CompensateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "model    {}: \"{}\", {} joints, {} effects",
            self.model, self.model_name, self.joints, self.effects
        )?;
        writeln!(
            f,
            "targets  {}: {} ({} poses, {} points){}",
            self.targets_file,
            self.targets,
            self.pose_targets,
            self.point_targets,
            if self.stream { ", streamed" } else { "" }
        )?;
        let list: Vec<String> = self
            .status
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect();
        writeln!(f, "status   {}", list.join(", "))?;
        if let Some(rms) = self.model_error_rms_mm {
            writeln!(f, "model error at the commands (ok rows): RMS {rms:.2e} mm")?;
        }
        writeln!(
            f,
            "corrections |command − seed|: RMS {:.4}°, max {:.4}°",
            self.correction_rms_deg, self.correction_max_deg
        )?;
        writeln!(
            f,
            "{:.2} µs per target ({})",
            self.microseconds_per_target, self.precision
        )?;
        if let Some(n) = &self.cartesian_nominal {
            writeln!(
                f,
                "targets to send to a controller with the nominal kinematics of {n} (x, y, z[, rx, ry, rz])"
            )?;
        }
        writeln!(f, "wrote {}", self.out)
    }
}
