//! `kinecal check` on a constraint file: what the session holds (groups and rows per kind, the
//! joint ranges, rows outside the robot file's joint limits), how far the nominal model is from
//! it per kind (each group against the shape fitted to its own predicted points, as `identify`
//! reports its "before"), and which parameters its constraints cannot determine at the nominal
//! model (the analysis `identify` starts from), and the socket and plane rows far from their
//! group's other rows there (a wrong group label, [`super::far_rows`]).

use super::fit::{candidates, shapes_of, unidentifiable};
use super::read::{by_kind, Session};
use super::shapes::{errors, points};
use crate::calibration::stats::rms;
use crate::formats::robot_file::RobotFile;
use crate::HostRobot;

/// One kind of constraint in the session.
#[derive(Clone, Debug, PartialEq)]
pub struct KindCheck {
    pub kind: &'static str,
    pub groups: usize,
    pub rows: usize,
    /// RMS of the nominal model's rows of this kind (mm; a distance group counts once).
    pub nominal_rms_mm: f64,
}

/// What [`check`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstraintChecked {
    pub joints: usize,
    pub groups: usize,
    pub rows: usize,
    /// Per joint, the lowest and highest reading (degrees).
    pub joint_ranges_deg: Vec<[f64; 2]>,
    /// Rows with a reading outside the joint limits the robot file states.
    pub outside_limits: usize,
    pub kinds: Vec<KindCheck>,
    /// RMS of all the nominal model's rows (mm).
    pub nominal_rms_mm: f64,
    /// The parameters `identify` would estimate that these constraints cannot determine at the
    /// nominal model (names as `identify` prints them).
    pub cannot_determine: Vec<String>,
    /// Socket and plane rows far from their group's other rows at the nominal model
    /// ([`super::far_rows`]): rows under the wrong group label.
    pub far_rows: Vec<super::far_rows::FarRow>,
}

/// Checks the constraint session `session` (named `origin` in messages) against the robot file
/// `file` and its model `nominal`. Refuses (exit 2) a session without rows.
pub fn check<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    session: &Session<N>,
    origin: &str,
) -> anyhow::Result<ConstraintChecked> {
    let groups = &session.groups;
    if session.rows() == 0 {
        crate::refuse!("{origin}: no constraint rows after the header");
    }
    let rows = || groups.iter().flat_map(|g| g.rows.iter());
    let joint_ranges_deg = (0..N)
        .map(|j| {
            rows().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], r| {
                let q = r.q[j].to_degrees();
                [lo.min(q), hi.max(q)]
            })
        })
        .collect();
    let outside_limits =
        crate::calibration::check::OutsideLimits::of_rows(file, session.joint_rows())
            .map_or(0, |o| o.poses);
    let shapes = shapes_of(nominal, groups);
    let row_errors = |k: usize| errors(&groups[k], &points(nominal, &groups[k]), &shapes[k]);
    let mut kinds = Vec::new();
    for (kind, of) in by_kind(groups) {
        let e: Vec<f64> = of.iter().flat_map(|&k| row_errors(k)).collect();
        kinds.push(KindCheck {
            kind: kind.id(),
            groups: of.len(),
            rows: of.iter().map(|&k| groups[k].rows.len()).sum(),
            nominal_rms_mm: rms(&e),
        });
    }
    let all: Vec<f64> = (0..groups.len()).flat_map(row_errors).collect();
    let base_unknown = !(file.base_known() && session.has_points());
    let params = candidates(nominal, file, base_unknown, &[])?;
    let cannot_determine = unidentifiable(nominal, groups, &params)?
        .iter()
        .map(|p| p.name(nominal).to_string())
        .collect();
    Ok(ConstraintChecked {
        joints: N,
        groups: groups.len(),
        rows: session.rows(),
        joint_ranges_deg,
        outside_limits,
        kinds,
        nominal_rms_mm: rms(&all),
        cannot_determine,
        far_rows: super::far_rows::find(nominal, groups),
    })
}
