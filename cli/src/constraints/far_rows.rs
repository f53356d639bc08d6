//! Rows far from their group's other rows at the robot file's model: a socket's rows meet in
//! one point and a plane's lie in one plane, to the robot file's errors (millimetres). A row
//! that lies hundreds of millimetres from where the others meet is under the wrong group label
//! (or its socket or plane moved), whatever the calibration: `check` names it, and so does
//! `identify` when its fit fails (instead of units or a bar offset: a socket row relabelled to
//! a socket 1 m away made the fit stretch the arm 1.3 times).
//!
//! Each row of a socket group of at least 4 rows, or a plane group of at least
//! [`PLANE_ROWS`], is compared with the shape fitted to the group's other rows (a wrong row
//! would pull a shape fitted to all of them, and with it the good rows' errors), and named
//! when it lies more than [`FAR_MM`] and more than [`FAR_FACTOR`] times the other rows' RMS
//! (and the session's median row error) from it. Three rows meet any plane exactly, and the
//! robot file's few millimetres tilt it: a fourth row 28 mm from it was named on correct data.
//! Worst first: a row named is left out of the shapes the others are judged against. Far rows
//! beyond [`MOST_SHARE`] of the rows judged (and beyond 2) are the robot file's (another arm),
//! not labels: none is named then.

use super::read::{Group, Kind};
use super::shapes::{errors, fit as fit_shape, points};
use crate::calibration::stats::{quantile, rms};
use crate::HostRobot;
use serde::Serialize;

/// Least distance (mm) of a far row from its group's other rows' shape.
pub const FAR_MM: f64 = 20.0;
/// Least ratio of that distance over the other rows' RMS and the session's median row error.
pub const FAR_FACTOR: f64 = 10.0;
/// Least rows of a plane group judged (the others leave three more than a plane takes).
pub const PLANE_ROWS: usize = 7;
/// Most far rows, as a share of the rows judged, that are named as labels.
pub const MOST_SHARE: f64 = 0.05;

/// A row far from its group's other rows at the robot file's model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FarRow {
    /// Line of the file.
    pub line: usize,
    pub kind: String,
    pub group: String,
    /// Its distance from the shape of the group's other rows (mm).
    pub distance_mm: f64,
    /// The RMS of the other rows against that shape (mm).
    pub others_rms_mm: f64,
}

/// The rows of `groups` far from their group's other rows at `robot` (see the module), in the
/// groups' order.
pub fn find<const N: usize>(robot: &HostRobot<N>, groups: &[Group<N>]) -> Vec<FarRow> {
    let judged = |g: &&Group<N>| match g.kind {
        Kind::Socket => g.rows.len() >= 4,
        Kind::Plane => g.rows.len() >= PLANE_ROWS,
        _ => false,
    };
    let pts: Vec<_> = groups.iter().map(|g| points(robot, g)).collect();
    // The session's typical row error, each group against its own shape.
    let all: Vec<f64> = groups
        .iter()
        .zip(&pts)
        .filter(|(g, _)| judged(g))
        .flat_map(|(g, p)| errors(g, p, &fit_shape(g.kind, p)))
        .map(f64::abs)
        .filter(|e| e.is_finite())
        .collect();
    if all.is_empty() {
        return Vec::new();
    }
    let typical = quantile(&all, 0.5);
    let mut far = Vec::new();
    for (g, p) in groups.iter().zip(&pts).filter(|(g, _)| judged(g)) {
        // Worst first: each row against the shape of the rows neither it nor one already
        // named, while the rows a shape takes remain (one wrong row tilts a plane of few rows
        // far enough to make a good row look far).
        let least = if g.kind == Kind::Plane {
            PLANE_ROWS - 1
        } else {
            3
        };
        let mut named: Vec<usize> = Vec::new();
        while p.len() - named.len() > least {
            let mut worst: Option<(f64, usize, f64)> = None;
            for k in (0..p.len()).filter(|k| !named.contains(k)) {
                let keep = |i: &usize| *i != k && !named.contains(i);
                let others: Vec<_> = (0..p.len()).filter(keep).map(|i| p[i]).collect();
                let e = errors(g, p, &fit_shape(g.kind, &others));
                let others_rms = rms(&(0..e.len())
                    .filter(keep)
                    .map(|i| e[i])
                    .collect::<Vec<f64>>());
                let d = e[k].abs();
                if d > FAR_MM
                    && d > FAR_FACTOR * others_rms.max(typical)
                    && worst.is_none_or(|(w, _, _)| d > w)
                {
                    worst = Some((d, k, others_rms));
                }
            }
            let Some((d, k, others_rms)) = worst else {
                break;
            };
            named.push(k);
            far.push(FarRow {
                line: g.rows[k].line,
                kind: g.kind.id().into(),
                group: g.name.clone(),
                distance_mm: d,
                others_rms_mm: others_rms,
            });
        }
    }
    let rows: usize = groups.iter().filter(judged).map(|g| g.rows.len()).sum();
    if far.len() as f64 > (MOST_SHARE * rows as f64).max(2.0) {
        return Vec::new();
    }
    far
}

/// The sentence naming the first rows of `far` (without "warning: "), `None` without any.
pub fn warning(far: &[FarRow]) -> Option<String> {
    use crate::output::numfmt::sig;
    let head = match far {
        [] => return None,
        [r] => {
            let (from, others) = if r.kind == "plane" {
                ("the plane of its group's other rows", "they lie within")
            } else {
                ("where its group's other rows meet", "they meet within")
            };
            format!(
                "line {} ({} {}) lies {} mm from {from} at the robot file's model ({others} {} \
                 mm RMS)",
                r.line,
                r.kind,
                r.group,
                sig(r.distance_mm, 4),
                sig(r.others_rms_mm, 3)
            )
        }
        _ => {
            let named: Vec<String> = far
                .iter()
                .take(5)
                .map(|r| {
                    format!(
                        "{} ({} {}, {} mm)",
                        r.line,
                        r.kind,
                        r.group,
                        sig(r.distance_mm, 4)
                    )
                })
                .collect();
            let more = if far.len() > named.len() {
                format!(" and {} more", far.len() - named.len())
            } else {
                String::new()
            };
            format!(
                "lines {}{more} lie far from their group's other rows at the robot file's model \
                 (a socket's rows meet in one point, a plane's lie in one plane)",
                named.join(", ")
            )
        }
    };
    Some(format!(
        "{head}: a row under the wrong group label, or a socket or plane that moved; correct \
         its group or leave the row out"
    ))
}
