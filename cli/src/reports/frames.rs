//! The report of `kinecal frames` ([`crate::frames`]).

use super::{plain_report, FrameReport};
use crate::output::numfmt::sig;
use serde::Serialize;
use std::fmt;

/// `kinecal frames`: the base frame and the tool distances found from single-joint sweeps.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FramesReport {
    /// The robot's name in its file.
    pub robot: String,
    pub base: FrameReport,
    /// Distance of the measured point from the flange axis (mm); `None`: no flange sweep.
    pub tool_radial_mm: Option<f64>,
    /// `d_N` + tool z (mm); `None`: no wrist sweep.
    pub tool_axial_mm: Option<f64>,
    pub tool: Option<ToolReport>,
    /// Every sweep's circle.
    pub circles: Vec<CircleReport>,
    /// Common normal of axes 1 and 2 (mm), and the nominal model's (row 2's `a`).
    pub axis_distance_mm: f64,
    pub nominal_axis_distance_mm: f64,
    pub axis_angle_deg: f64,
    /// What makes the result doubtful (also printed on stderr).
    pub warnings: Vec<String>,
    pub notes: Vec<String>,
    /// The robot file written with the base found.
    pub out: Option<String>,
}

/// How the tool distances were found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ToolReport {
    /// `flange-axis`, `centre-to-wrist-axis` or `wrist-radius`.
    pub method: String,
    pub radial_resolved: bool,
    pub nominal_radial_mm: f64,
    pub nominal_axial_mm: f64,
}

/// One sweep's circle, or a flange sweep whose point does not move (it is on the axis).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum CircleReport {
    Fitted(FittedCircle),
    OnAxis(OnAxis),
}

/// A circle fitted to a sweep's points.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FittedCircle {
    /// 1-based joint swept.
    pub joint: usize,
    pub points: usize,
    pub radius_mm: f64,
    pub rms_mm: f64,
    pub span_deg: f64,
    pub centre_mm: [f64; 3],
    pub axis: [f64; 3],
    pub sd_centre_mm: f64,
    pub sd_axis_deg: f64,
    pub sd_radius_mm: f64,
}

/// A flange sweep that moves the point by no more than the noise.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OnAxis {
    pub joint: usize,
    pub points: usize,
    /// How far the point moves (mm).
    pub radius_mm: f64,
    /// Always `None` (no circle).
    pub rms_mm: Option<f64>,
    /// Always `false`.
    pub resolved: bool,
}

impl CircleReport {
    /// The joint swept (1-based).
    pub fn joint(&self) -> usize {
        match self {
            CircleReport::Fitted(c) => c.joint,
            CircleReport::OnAxis(c) => c.joint,
        }
    }
    /// Radius of the circle, or how far an on-axis point moves (mm).
    pub fn radius_mm(&self) -> f64 {
        match self {
            CircleReport::Fitted(c) => c.radius_mm,
            CircleReport::OnAxis(c) => c.radius_mm,
        }
    }
    /// RMS distance of the points from their circle (mm); `None` on the axis.
    pub fn rms_mm(&self) -> Option<f64> {
        match self {
            CircleReport::Fitted(c) => Some(c.rms_mm),
            CircleReport::OnAxis(_) => None,
        }
    }
}

plain_report!(FramesReport);

/// Lengths to the micrometre, and small ones with two significant digits (never "0.000").
fn len(x: f64) -> String {
    if x.abs() >= 0.1 {
        format!("{x:.3}")
    } else {
        sig(x, 2)
    }
}

impl fmt::Display for FramesReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let f4 = |v: [f64; 3]| v.map(|x| format!("{x:.4}")).join(", ");
        writeln!(f, "[base]")?;
        writeln!(f, "xyz_mm = [{}]", f4(self.base.xyz_mm))?;
        writeln!(f, "rpy_deg = [{}]", f4(self.base.rpy_deg))?;
        writeln!(f)?;
        writeln!(
            f,
            "axes 1 and 2: {} mm apart (nominal {} mm), {}° between them",
            len(self.axis_distance_mm),
            len(self.nominal_axis_distance_mm),
            sig(self.axis_angle_deg, 6)
        )?;
        match (self.tool_radial_mm, self.tool_axial_mm) {
            (radial, Some(axial)) => {
                let radial =
                    radial.map_or("not measured".to_string(), |v| format!("{} mm", len(v)));
                writeln!(
                    f,
                    "tool: radial {radial}, axial (d_N + tool z) {} mm",
                    len(axial)
                )?;
            }
            _ => writeln!(f, "tool: not measured")?,
        }
        writeln!(f, "circles:")?;
        for c in &self.circles {
            match c {
                CircleReport::OnAxis(c) => writeln!(
                    f,
                    "  joint {}: {} points, no circle (moves {} mm: the point is on the axis)",
                    c.joint,
                    c.points,
                    sig(c.radius_mm, 2)
                )?,
                CircleReport::Fitted(c) => writeln!(
                    f,
                    "  joint {}: {} points over {}°, radius {} mm, rms {} mm, axis ±{}°, centre ±{} mm",
                    c.joint,
                    c.points,
                    sig(c.span_deg, 3),
                    len(c.radius_mm),
                    sig(c.rms_mm, 2),
                    sig(c.sd_axis_deg, 2),
                    sig(c.sd_centre_mm, 2),
                )?,
            }
        }
        for n in &self.notes {
            writeln!(f, "note: {n}")?;
        }
        if let Some(o) = &self.out {
            writeln!(f, "wrote {o}")?;
        }
        Ok(())
    }
}
