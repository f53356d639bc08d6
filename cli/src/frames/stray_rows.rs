//! Rows of a sweep whose other joints stand elsewhere than on the sweep's other rows.
//!
//! A sweep turns one joint and holds the others. When a few rows of the file name the wrong
//! joint in their `sweep` column (rows of joint 2's sweep tagged 1), the library sees "another
//! joint moved" and the user would measure again, where correcting a column is enough. Before
//! the sweeps are fitted, each sweep's rows are compared with the median of its rows' model
//! angles: a minority of rows off by more than the library's
//! [`kinecal::frames::circle_point::FIXED_JOINT_TOLERANCE`] is named by line, with the sweep
//! whose held joints they match when there is one. A majority off is a joint that really moved:
//! left to the library's refusal.

use crate::formats::measurements::Dataset;
use crate::simulation::sweeps::SWEEP_COLUMN;
use crate::HostRobot;
use kinecal::frames::circle_point::FIXED_JOINT_TOLERANCE;

/// At most this many lines are named.
const NAMED: usize = 5;

/// The refusal's text for the first sweep (in joint order) with a minority of stray rows, or
/// `None`. `origin` names the file.
pub fn strays<const N: usize>(
    robot: &HostRobot<N>,
    data: &Dataset<N>,
    origin: &str,
) -> Option<String> {
    let k = data.extra_names.iter().position(|n| n == SWEEP_COLUMN)?;
    // Each tagged row: the joint it names (0-based), its line and its model angles (rad).
    let rows: Vec<(usize, u32, [f64; N])> = data
        .records
        .iter()
        .filter_map(|r| {
            let v = *r.extra.get(k)?;
            (v.fract() == 0.0 && (1.0..=N as f64).contains(&v)).then(|| {
                let q = r.q_deg.map(f64::to_radians);
                (v as usize - 1, r.line, robot.couplings().to_model(&q))
            })
        })
        .collect();
    // The median model angle of every joint over each sweep's rows.
    let medians: Vec<Option<[f64; N]>> = (0..N)
        .map(|j| {
            let of: Vec<&[f64; N]> = rows.iter().filter(|r| r.0 == j).map(|r| &r.2).collect();
            (!of.is_empty()).then(|| {
                std::array::from_fn(|a| {
                    let column: Vec<f64> = of.iter().map(|q| q[a]).collect();
                    crate::calibration::stats::quantile(&column, 0.5)
                })
            })
        })
        .collect();
    // Whether model angles `q` hold sweep `j`'s held joints.
    let holds = |j: usize, q: &[f64; N]| {
        medians[j]
            .is_some_and(|m| (0..N).all(|a| a == j || (q[a] - m[a]).abs() <= FIXED_JOINT_TOLERANCE))
    };
    (0..N).find_map(|j| {
        let of: Vec<&(usize, u32, [f64; N])> = rows.iter().filter(|r| r.0 == j).collect();
        let off: Vec<&&(usize, u32, [f64; N])> = of.iter().filter(|r| !holds(j, &r.2)).collect();
        if off.is_empty() || 2 * off.len() >= of.len() {
            return None;
        }
        let m = medians[j]?;
        // The held joint furthest off on those rows, and by how much.
        let (joint, by) = off
            .iter()
            .flat_map(|r| {
                (0..N)
                    .filter(|a| *a != j)
                    .map(move |a| (a, (r.2[a] - m[a]).abs()))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        let lines: Vec<String> = off.iter().take(NAMED).map(|r| r.1.to_string()).collect();
        let more = if off.len() > NAMED { ", …" } else { "" };
        let todo = (0..N)
            .find(|s| *s != j && off.iter().all(|r| holds(*s, &r.2)))
            .map_or(
                format!("correct their `{SWEEP_COLUMN}` column, or drop them"),
                |s| {
                    format!(
                        "they fit the sweep of joint {0} (its held joints): set their \
                         `{SWEEP_COLUMN}` to {0}",
                        s + 1
                    )
                },
            );
        Some(format!(
            "{origin}: sweep of joint {}: {} of its {} rows (lines {}{more}) have joint {} {}° \
             from where its other rows hold it: {todo}",
            j + 1,
            off.len(),
            of.len(),
            lines.join(", "),
            joint + 1,
            crate::output::numfmt::sig(by.to_degrees(), 3)
        ))
    })
}
