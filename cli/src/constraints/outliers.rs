//! How far a constraint fit is from what the session's rows and σ say: the tracker fit's
//! gross-outlier rule ([`crate::calibration::outliers`]) on each row's error against its
//! socket or plane (a distance group: its length error, at its first row), and χ² per degree
//! of freedom of the stated σ.
//!
//! Why: a ball-bar session of 60 distances with one length 10 mm off fitted with exit 0, and
//! so did one with a length 1 mm off. The first is a gross outlier (exit 3, its line named), the
//! second a stray and a χ²/dof far above 1 (both warned about;
//! `host-tests/tests/command_line/constraints/outliers.rs`).

use super::read::{Group, Kind};
use super::shapes::{errors, points, Shape};
use super::system::evaluate;
use crate::calibration::outliers::{of_distances, Outlier, Outliers};
use crate::HostRobot;
use kinecal::Param;

/// What a row far from its constraint may be, as the end of "a wrong reading (…)".
pub const CAUSES: &str = "a mistyped length_mm, a row of another socket, plane or bar, a probe \
                          that slipped";

/// The gross outliers and strays of `robot` with its fitted `shapes` on `groups`.
pub fn find<const N: usize>(
    robot: &HostRobot<N>,
    groups: &[Group<N>],
    shapes: &[Shape],
) -> Outliers {
    let mut all = Vec::new();
    for (g, s) in groups.iter().zip(shapes) {
        let e = errors(g, &points(robot, g), s);
        let lines = g.rows.iter().map(|r| r.line as u32);
        let at: Vec<(u32, f64)> = match g.kind {
            Kind::Distance => lines.take(1).zip(e).collect(),
            _ => lines.zip(e).collect(),
        };
        all.extend(
            at.into_iter()
                .filter(|(_, e)| e.is_finite())
                .map(|(line, e)| Outlier {
                    line,
                    distance_mm: e.abs(),
                }),
        );
    }
    let n = all.len();
    of_distances(all, n, CAUSES)
}

/// χ² per degree of freedom of the rows' σ at `robot` and `shapes`, with `estimated`
/// parameters fitted (`None` when the rows do not exceed the unknowns or the residuals cannot
/// be evaluated).
pub fn chi2_per_dof<const N: usize>(
    robot: &HostRobot<N>,
    groups: &[Group<N>],
    shapes: &[Shape],
    estimated: &[Param],
) -> Option<f64> {
    let (r, _) = evaluate(robot, groups, shapes, estimated, false).ok()?;
    let unknowns = estimated.len() + shapes.iter().map(Shape::unknowns).sum::<usize>();
    (r.len() > unknowns).then(|| r.norm_squared() / (r.len() - unknowns) as f64)
}

/// The χ² warning (without "warning: ") when `chi2` is far from 1: outside 0.25–4, as on
/// tracker points.
pub fn chi2_warning(chi2: f64) -> Option<String> {
    (!(0.25..=4.0).contains(&chi2)).then(|| {
        format!(
            "χ²/dof = {} with the file's sigma_mm: the rows are {}× farther from their \
             constraints than the stated σ explain ({})",
            crate::output::numfmt::sig(chi2, 3),
            crate::output::numfmt::sig(chi2.sqrt(), 3),
            if chi2 > 1.0 {
                "a length_mm, socket or plane that is not what the file says, an effect the \
                 model misses (kinecal diagnose), or σ too small"
            } else {
                "the σ are too large"
            }
        )
    })
}
