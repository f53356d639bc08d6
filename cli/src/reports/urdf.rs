//! The reports of `kinecal import --urdf` and `kinecal export`.

use super::plain_report;
use serde::Serialize;
use std::fmt;

/// `kinecal import --urdf`: which chain became which robot file.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ImportReport {
    pub urdf: String,
    pub out: String,
    pub base_link: String,
    pub tip_link: String,
    pub joints: usize,
    /// The URDF's revolute joints, base first (row i of the robot file is `joint_names[i]`).
    pub joint_names: Vec<String>,
    /// Fixed joints folded into the base, tool or neighbouring rows.
    pub fixed_folded: Vec<String>,
    pub tool_xyz_mm: [f64; 3],
    pub base_xyz_mm: [f64; 3],
    pub base_rpy_deg: [f64; 3],
    /// Whether the file holds that base as `[base]` (`--with-base`); otherwise the base is
    /// estimated from the data.
    pub base_written: bool,
}

plain_report!(ImportReport);

impl fmt::Display for ImportReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "wrote {} ({}-joint MDH robot from {}, '{}' to '{}')",
            self.out, self.joints, self.urdf, self.base_link, self.tip_link
        )?;
        writeln!(f, "joints: {}", self.joint_names.join(", "))?;
        if !self.fixed_folded.is_empty() {
            writeln!(
                f,
                "fixed joints folded in: {}",
                self.fixed_folded.join(", ")
            )?;
        }
        writeln!(
            f,
            "tool point {:?} mm in the last MDH frame; frame 0 in the base link {:?} mm, rpy {:?} deg",
            self.tool_xyz_mm, self.base_xyz_mm, self.base_rpy_deg
        )?;
        if self.base_written {
            writeln!(f, "[base] written: the data are in the base link's frame")
        } else {
            writeln!(
                f,
                "no [base] written: check and identify estimate it from the data (--with-base \
                 for data in the base link's frame)"
            )
        }
    }
}

/// `kinecal export`: what was written and what could not go into it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ExportReport {
    /// `urdf`, `dh-table` or `firmware`.
    pub format: String,
    pub out: String,
    /// URDF: the joints whose `<origin>` was rewritten.
    pub joints_rewritten: Vec<String>,
    /// Model parts the format cannot hold (effects, couplings, the calibrated base).
    pub dropped: Vec<String>,
    /// dh-table: the number of rows written.
    pub rows: usize,
    /// firmware: the size of the binary model written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bytes: Option<usize>,
}

plain_report!(ExportReport);

impl fmt::Display for ExportReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.format == "urdf" {
            writeln!(
                f,
                "wrote {} (origins of {} rewritten, tool frame kinecal_tool added)",
                self.out,
                self.joints_rewritten.join(", ")
            )?;
            writeln!(
                f,
                "the URDF keeps its nominal base: the calibrated [base] is where the tracker saw \
                 the robot, not part of it"
            )?;
        } else if let Some(bytes) = self.bytes {
            writeln!(f, "wrote {} ({bytes} bytes: the whole model)", self.out)?;
        } else {
            writeln!(f, "wrote {} ({} parameters)", self.out, self.rows)?;
        }
        for d in &self.dropped {
            writeln!(f, "not exported: {d}")?;
        }
        Ok(())
    }
}
