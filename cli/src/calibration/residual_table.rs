//! Each pose's residual, identification and held-out (`identify --residuals R.csv`): to find
//! the one bad pose of a set without re-running on one-row files (docs/formats.md
//! "Residuals file").
//!
//! One row per observation (a pose with several reflectors has one per reflector seen):
//! `set` (`identification` or `held-out`), `pose` (1-based, in its file's order), `line` (the
//! pose's line in its file), `point` (the reflector's name, empty with one tool), `dx_mm`,
//! `dy_mm`, `dz_mm` (measured − calibrated model, measurement frame), `error_mm` (their
//! length), `start_mm` (the same length for the model the fit started from) and, with 6-D
//! data, `error_deg` (the angle between measured and model tool frame).

use crate::formats::observations::Pose;
use kinecal::{ForwardKinematics, Measurement, Robot};
use std::fmt::Write as _;

/// A set's poses and the observation list they index.
pub type PoseSet<'a, const N: usize> = (&'a [Pose], &'a [Measurement<f64, N>]);

/// One observation's residual.
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualRow {
    pub held_out: bool,
    pub pose: usize,
    pub line: u32,
    pub point: String,
    /// Measured − calibrated model (mm).
    pub error: [f64; 3],
    /// Length of the starting model's error (mm).
    pub start_mm: f64,
    /// Orientation error of the calibrated model (degrees), for a 6-D observation.
    pub error_deg: Option<f64>,
}

/// The residuals of a fit, identification poses first, each set in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ResidualTable {
    pub rows: Vec<ResidualRow>,
}

impl ResidualTable {
    /// The residuals of `models` (start, calibrated) on the identification and held-out
    /// poses (each set's poses and the observation list they index); `separate_file`: the
    /// held-out poses come from another file (numbered on their own), else both sets are
    /// numbered in the data file's order.
    pub fn of<const N: usize, V: kinecal::ValueStorage>(
        (start, model): (&Robot<f64, N, V>, &Robot<f64, N, V>),
        ((ident, ident_obs), (valid, valid_obs)): (PoseSet<'_, N>, PoseSet<'_, N>),
        separate_file: bool,
        names: &[String],
    ) -> Self {
        // The pose number of a line: its rank among the lines of its file.
        let sorted = |poses: &[&[Pose]]| {
            let mut l: Vec<u32> = poses
                .iter()
                .flat_map(|s| s.iter().map(|p| p.line))
                .collect();
            l.sort_unstable();
            l
        };
        let ident_lines = if separate_file {
            sorted(&[ident])
        } else {
            sorted(&[ident, valid])
        };
        let valid_lines = sorted(&[valid]);
        let rank = |lines: &[u32], l: u32| lines.binary_search(&l).map_or(0, |k| k + 1);
        let mut fk = ForwardKinematics::new();
        let mut rows = Vec::new();
        for (held_out, poses, all) in [(false, ident, ident_obs), (true, valid, valid_obs)] {
            for p in poses {
                let pose = if held_out && separate_file {
                    rank(&valid_lines, p.line)
                } else {
                    rank(&ident_lines, p.line)
                };
                for m in p.of(all) {
                    let tool = m.tool as usize;
                    let start_mm = fk
                        .compute_at(start, &m.q, tool, m.conditions())
                        .map_or(f64::NAN, |q| (m.point - q).norm());
                    let Some(q) = fk.compute_at(model, &m.q, tool, m.conditions()) else {
                        continue;
                    };
                    let e = m.point - q;
                    let error_deg = m.orientation.as_ref().map(|o| {
                        kinecal::model::frame::orientation_error(o, &fk.tool_pose(model))
                            .norm()
                            .to_degrees()
                    });
                    rows.push(ResidualRow {
                        held_out,
                        pose,
                        line: p.line,
                        point: names.get(tool).cloned().unwrap_or_default(),
                        error: [e.x, e.y, e.z],
                        start_mm,
                        error_deg,
                    });
                }
            }
        }
        Self { rows }
    }

    /// The CSV text (numbers to 1 nm and 1e-6°).
    pub fn to_csv(&self) -> String {
        let six_d = self.rows.iter().any(|r| r.error_deg.is_some());
        let mut s = String::from("set,pose,line,point,dx_mm,dy_mm,dz_mm,error_mm,start_mm");
        s.push_str(if six_d { ",error_deg\n" } else { "\n" });
        let num = |v: f64, d: usize| {
            if v.is_finite() {
                format!("{v:.d$}")
            } else {
                String::new()
            }
        };
        for r in &self.rows {
            let [x, y, z] = r.error;
            let _ = write!(
                s,
                "{},{},{},{},{},{},{},{},{}",
                if r.held_out {
                    "held-out"
                } else {
                    "identification"
                },
                r.pose,
                r.line,
                r.point,
                num(x, 6),
                num(y, 6),
                num(z, 6),
                num((x * x + y * y + z * z).sqrt(), 6),
                num(r.start_mm, 6),
            );
            if six_d {
                let _ = write!(s, ",{}", r.error_deg.map_or(String::new(), |d| num(d, 6)));
            }
            s.push('\n');
        }
        s
    }
}
