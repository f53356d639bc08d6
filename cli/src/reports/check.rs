//! The report of `kinecal check`.

use super::{plain_report, FrameReport};
use crate::calibration::check::Checked;
use crate::calibration::coupling_hint::CouplingHint;
use crate::formats::robot_file::RobotFile;
use crate::output::numfmt::sig;
use serde::Serialize;
use std::fmt;

/// `kinecal check`: the files, what the data cover and the nominal model's error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CheckReport {
    /// Robot file path.
    pub robot: String,
    /// Measurement file path.
    pub data: String,
    /// The robot's name in its file.
    pub name: String,
    pub joints: usize,
    pub poses: usize,
    /// Columns carried along without a fixed meaning (not q1…qN, x, y, z, the orientations,
    /// the stated σ or the reflectors' points).
    pub extra_columns: Vec<String>,
    /// Per joint, the lowest and highest reading (degrees).
    pub joint_ranges_deg: Vec<[f64; 2]>,
    /// Poses with a reading outside the joint limits the robot file states.
    pub outside_limits: usize,
    /// The robot file has no `[base]`: the base was fitted to the data.
    pub base_fitted: bool,
    pub base: FrameReport,
    /// The robot file gives the tool point as unknown: it was started from the data
    /// (`tool_xyz_mm`), and the nominal error is with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tool_started_mm: Option<[f64; 3]>,
    pub nominal_rms_mm: f64,
    pub nominal_mean_mm: f64,
    pub nominal_max_mm: f64,
    /// A `[[couplings]]` entry that would explain the data far better (robot files without
    /// couplings only).
    pub coupling_hint: Option<CouplingHintReport>,
    /// With the base fitted: the RMS (mm) the nominal model leaves when the data are placed by a
    /// mirrored map, present when far under `nominal_rms_mm` (an axis of the data mirrored or
    /// two exchanged).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mirrored_rms_mm: Option<f64>,
    /// The scale of the best similarity placement of the nominal points on the data and the RMS
    /// it leaves (mm of the model, the data rescaled), present when the scale is a tenth or more off 1
    /// and the RMS far under `nominal_rms_mm` (the points in another length unit).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_scale: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scaled_rms_mm: Option<f64>,
    /// Two joint columns exchanged (`{"change": {"exchanged": [2, 3]}, …}`) or one negated
    /// (`{"negated": 3}`) that explain the data far better: `rms_mm` with it, `nominal_rms_mm`
    /// as written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub column_hint: Option<crate::calibration::column_hint::ColumnHint>,
    /// The joint limits the robot file states (degrees), per joint (text only).
    #[serde(skip)]
    pub limits_deg: Vec<Option<[f64; 2]>>,
}

impl CheckReport {
    /// The report of `c`, what [`crate::calibration::check::check`] found for the robot file
    /// `file` (named `robot`) and the measurement set named `data`.
    pub fn of(c: &Checked, file: &RobotFile, robot: &str, data: &str) -> Self {
        Self {
            robot: robot.to_string(),
            data: data.to_string(),
            name: file.name.clone(),
            joints: c.joints,
            poses: c.poses,
            extra_columns: c.extra_columns.clone(),
            joint_ranges_deg: c.joint_ranges_deg.clone(),
            outside_limits: c.outside_limits,
            base_fitted: c.base_fitted,
            base: FrameReport {
                xyz_mm: c.base_xyz_mm,
                rpy_deg: c.base_rpy_deg,
            },
            tool_started_mm: c.tool_started_mm,
            nominal_rms_mm: c.nominal.rms_mm,
            nominal_mean_mm: c.nominal.mean_mm,
            nominal_max_mm: c.nominal.max_mm,
            coupling_hint: c.coupling_hint.as_ref().map(CouplingHintReport::from),
            mirrored_rms_mm: c.mirrored_rms_mm,
            length_scale: c.scaled.map(|(s, _)| s),
            scaled_rms_mm: c.scaled.map(|(_, r)| r),
            column_hint: c.column_hint.clone(),
            limits_deg: file.joints.iter().map(|j| j.limits_deg).collect(),
        }
    }
}

/// The `coupling_hint` object.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CouplingHintReport {
    pub joint: usize,
    pub from: usize,
    pub ratio: f64,
    /// The robot file states couplings and this reading replaces them (`ratio` 0: none).
    pub replaces_stated: bool,
    /// Every coupling of the reading that fits, 1-based `[joint, from, ratio]`.
    pub couplings: Vec<(usize, usize, f64)>,
    pub rms_mm: f64,
    pub nominal_rms_mm: f64,
    /// The one-line warning (also printed on stderr).
    pub message: String,
}

impl From<&CouplingHint> for CouplingHintReport {
    fn from(h: &CouplingHint) -> Self {
        Self {
            joint: h.joint,
            from: h.from,
            ratio: h.ratio,
            replaces_stated: h.replaces_stated,
            couplings: h.couplings.clone(),
            rms_mm: h.rms_mm,
            nominal_rms_mm: h.nominal_rms_mm,
            message: h.message(),
        }
    }
}

plain_report!(CheckReport);

impl fmt::Display for CheckReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "robot  {}: \"{}\", {} joints, {}",
            self.robot,
            self.name,
            self.joints,
            if self.base_fitted {
                "no [base]: base fitted to the data"
            } else {
                "base from the file"
            }
        )?;
        let extra = if self.extra_columns.is_empty() {
            String::new()
        } else {
            format!(", extra columns: {}", self.extra_columns.join(", "))
        };
        writeln!(f, "data   {}: {} poses{extra}", self.data, self.poses)?;
        writeln!(f, "joint ranges covered (deg):")?;
        for (i, [lo, hi]) in self.joint_ranges_deg.iter().enumerate() {
            let limits = match self.limits_deg.get(i).copied().flatten() {
                Some([llo, lhi]) => format!("limits {} .. {}", sig(llo, 6), sig(lhi, 6)),
                None => "no limits in the robot file".to_string(),
            };
            writeln!(f, "  q{}: {lo:9.3} .. {hi:9.3}   ({limits})", i + 1)?;
        }
        if self.outside_limits > 0 {
            writeln!(
                f,
                "warning: {} of {} poses have readings outside the joint limits of the robot file",
                self.outside_limits, self.poses
            )?;
        }
        if self.base_fitted {
            // Coordinates: fixed decimals (an absolute resolution), unlike the error figures.
            let (xyz, rpy) = (self.base.xyz_mm, self.base.rpy_deg);
            writeln!(
                f,
                "fitted base: xyz_mm = [{:.3}, {:.3}, {:.3}], rpy_deg = [{:.4}, {:.4}, {:.4}]",
                xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]
            )?;
        }
        if let Some(t) = self.tool_started_mm {
            writeln!(
                f,
                "tool point unknown, started from the data: xyz_mm = [{:.3}, {:.3}, {:.3}]",
                t[0], t[1], t[2]
            )?;
        }
        writeln!(
            f,
            "nominal model error: RMS {} mm, mean {} mm, max {} mm",
            sig(self.nominal_rms_mm, 3),
            sig(self.nominal_mean_mm, 3),
            sig(self.nominal_max_mm, 3)
        )
    }
}
