//! How far a constraint fit is from what the session's rows and σ say: the tracker fit's
//! gross-outlier rule ([`crate::calibration::outliers`]) on each row's error against its
//! socket or plane (a distance group: its length error, at its first row), and χ² per degree
//! of freedom of the stated σ.
//!
//! Why: a ball-bar session of 60 distances with one length 10 mm off fitted with exit 0, and
//! so did one with a length 1 mm off. The first is a gross outlier (exit 3, its line named), the
//! second a stray and a χ²/dof far above 1 (both warned about;
//! `host-tests/tests/command_line/constraints/outliers.rs`).
//!
//! A wrong row pulls its own socket's centre or plane toward it, and with it the errors of its
//! group's good rows: a plane row 5 mm off left two good rows of its plane at 10 times the
//! median too. So a socket's or plane's rows are judged against the shape refitted without the
//! rows already found beyond the limit, worst first, while at least 4 rows remain. Each error
//! is scaled by the session's median σ over the row's own (a coarse row is judged by its σ).
//! What the model itself absorbs (a socket-only session whose overall scale is free, a few
//! planes) cannot be told apart here: χ²/dof and the arm-size check speak for those.

use super::read::{Group, Kind};
use super::shapes::{errors, fit as fit_shape, points, Shape};
use super::system::evaluate;
use crate::calibration::outliers::{of_distances, Outlier, Outliers, MEDIAN_FACTOR};
use crate::calibration::stats::quantile;
use crate::HostRobot;
use kinecal::Param;

/// What a row far from its constraint may be in a session of `groups`, as the end of "a wrong
/// reading (…)": per kind present.
pub fn causes<const N: usize>(groups: &[Group<N>]) -> String {
    let has = |k: Kind| groups.iter().any(|g| g.kind == k);
    let mut c = Vec::new();
    if has(Kind::Distance) {
        c.push("a mistyped length_mm, a bar seated in the wrong cup");
    }
    if has(Kind::Socket) || has(Kind::Plane) {
        c.push("a row of another socket or plane, a probe that slipped");
    }
    if has(Kind::Point) {
        c.push("a lost reflector, a point of another pose");
    }
    c.join(", ")
}

/// Each row's error and σ in `g` at `robot` (a distance group: one, at its first row), a
/// socket's or plane's against its shape refitted without the rows beyond `limit` (scaled),
/// worst first, while 4 rows remain. `limit` `None`: against the shape of all rows.
fn group_errors<const N: usize>(
    robot: &HostRobot<N>,
    g: &Group<N>,
    sigma_typical: f64,
    limit: Option<f64>,
) -> Vec<(u32, f64, f64)> {
    let pts = points(robot, g);
    let lines: Vec<u32> = g.rows.iter().map(|r| r.line as u32).collect();
    let scale: Vec<f64> = g.rows.iter().map(|r| sigma_typical / r.sigma_mm).collect();
    if matches!(g.kind, Kind::Distance) {
        let e = errors(g, &pts, &Shape::None);
        return vec![(lines[0], e[0].abs(), e[0].abs() * scale[0])];
    }
    if matches!(g.kind, Kind::Point) {
        let e = errors(g, &pts, &Shape::None);
        return (0..e.len())
            .map(|i| (lines[i], e[i].abs(), e[i].abs() * scale[i]))
            .collect();
    }
    let mut kept: Vec<bool> = vec![true; pts.len()];
    loop {
        let inside: Vec<_> = pts
            .iter()
            .zip(&kept)
            .filter(|(_, k)| **k)
            .map(|(p, _)| *p)
            .collect();
        let e = errors(g, &pts, &fit_shape(g.kind, &inside));
        let worst = (0..e.len())
            .filter(|&i| kept[i])
            .max_by(|&a, &b| (e[a].abs() * scale[a]).total_cmp(&(e[b].abs() * scale[b])));
        match (limit, worst) {
            (Some(l), Some(w)) if inside.len() > 4 && e[w].abs() * scale[w] > l => {
                kept[w] = false;
            }
            _ => {
                return (0..e.len())
                    .map(|i| (lines[i], e[i].abs(), e[i].abs() * scale[i]))
                    .collect();
            }
        }
    }
}

/// The gross outliers and strays of `robot` on the identification groups `ident` and the
/// held-out groups `held` of the same session (each socket and plane against its own shape,
/// see the module).
pub fn find<const N: usize>(
    robot: &HostRobot<N>,
    ident: &[Group<N>],
    held: &[Group<N>],
) -> Outliers {
    let groups: Vec<&Group<N>> = ident.iter().chain(held).collect();
    let sigmas: Vec<f64> = groups
        .iter()
        .flat_map(|g| g.rows.iter().map(|r| r.sigma_mm))
        .collect();
    let typical = quantile(&sigmas, 0.5);
    let first: Vec<f64> = groups
        .iter()
        .flat_map(|g| group_errors(robot, g, typical, None))
        .map(|(_, _, s)| s)
        .collect();
    let limit = MEDIAN_FACTOR * quantile(&first, 0.5);
    let all: Vec<Outlier> = groups
        .iter()
        .flat_map(|g| group_errors(robot, g, typical, Some(limit)))
        .filter(|(_, d, s)| d.is_finite() && s.is_finite())
        .map(|(line, distance_mm, scaled_mm)| Outlier {
            line,
            distance_mm,
            scaled_mm,
        })
        .collect();
    let n = all.len();
    let all_groups: Vec<Group<N>> = groups.into_iter().cloned().collect();
    of_distances(all, n, causes(&all_groups))
}

/// Fewest degrees of freedom for a χ²/dof to say anything about σ: with ν of them it falls
/// outside 1/4–4 by chance 38 % of the time at ν = 1, under 1 % from ν = 10.
pub const MIN_DOF: usize = 10;

/// χ² per degree of freedom of the rows' σ at `robot` and `shapes`, with `estimated`
/// parameters fitted (`None` with fewer than [`MIN_DOF`] degrees of freedom or residuals that
/// cannot be evaluated).
pub fn chi2_per_dof<const N: usize>(
    robot: &HostRobot<N>,
    groups: &[Group<N>],
    shapes: &[Shape],
    estimated: &[Param],
) -> Option<f64> {
    let (r, _) = evaluate(robot, groups, shapes, estimated, false).ok()?;
    let unknowns = estimated.len() + shapes.iter().map(Shape::unknowns).sum::<usize>();
    (r.len() >= unknowns + MIN_DOF).then(|| r.norm_squared() / (r.len() - unknowns) as f64)
}

/// Whether a χ²/dof lies far from 1: outside 1/4–4, as on tracker points.
pub fn chi2_far(chi2: f64) -> bool {
    !(0.25..=4.0).contains(&chi2)
}

/// The χ² warning (without "warning: ") when `chi2` is far from 1 ([`chi2_far`]) in a session
/// of `groups`; `tool_moved`: the tool's coordinates and the last joint's `d` that moved beyond
/// a manufacturing tolerance, named first among the causes (a probe other than the robot
/// file's tool: the fit holds what it cannot see at the file's tool, and misses the rest).
pub fn chi2_warning<const N: usize>(
    chi2: f64,
    groups: &[Group<N>],
    tool_moved: &[String],
) -> Option<String> {
    let tool = if tool_moved.is_empty() {
        String::new()
    } else {
        format!(
            "a probe other than the robot file's tool ({} moved further than a manufacturing \
             tolerance explains: give the probe's nominal offset in [tool] and run again), ",
            tool_moved.join(", ")
        )
    };
    chi2_far(chi2).then(|| {
        format!(
            "χ²/dof = {} with the file's sigma_mm: the rows are {}× {} their constraints than \
             the stated σ explain ({})",
            crate::output::numfmt::sig(chi2, 3),
            crate::output::numfmt::sig(chi2.sqrt(), 3),
            if chi2 > 1.0 {
                "farther from"
            } else {
                "closer to"
            },
            if chi2 > 1.0 {
                format!(
                    "{tool}wrong rows ({}), an effect the model misses (kinecal diagnose), or σ \
                     too small",
                    causes(groups)
                )
            } else {
                "the σ are too large".to_string()
            }
        )
    })
}
