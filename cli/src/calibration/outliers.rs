//! Gross outliers: a row whose measured point lies far beyond the fitted model's typical error
//! (a reflector the tracker lost and found on something else, a row in another unit, joint
//! readings of another pose). One such row among hundreds pulls every parameter of a
//! least-squares fit: 600 UR10 rows with one `x` 100 mm off "calibrated" to 4.1 mm RMS with
//! exit 0, and `diagnose` took the 4.1 mm for the noise floor and named nothing. `identify`
//! and `diagnose` report such a fit as no calibration (exit 3), naming the rows to delete or
//! measure again.
//!
//! A point is a gross outlier when it lies more than [`MEDIAN_FACTOR`] times the median
//! distance from the fitted model, and more than [`MIN_MM`]. On the real UR10 series (geometric
//! fit, `kinecal identify --residuals`) the largest distance is 3.1–5.4 times the median
//! (series A, B, C, D); for Gaussian noise alone it is about 3.5 times the median in 10,000
//! points.

use crate::formats::observations::Pose;
use crate::output::numfmt::sig;
use kinecal::{ForwardKinematics, Measurement, Robot, ValueStorage};

/// How many times the median distance a point must lie from the model to be a gross outlier.
pub const MEDIAN_FACTOR: f64 = 10.0;
/// How far (mm) a point must lie from the model at least to be a gross outlier (data with
/// micrometre errors are not searched for millimetre-sized faults).
pub const MIN_MM: f64 = 1.0;

/// A point far from the model: its line in the data file and its distance (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outlier {
    pub line: u32,
    pub distance_mm: f64,
}

/// The gross outliers of a fit: one pass over its points, then read by the callers in the
/// order their reasons come ([`Outliers::few`] first, [`Outliers::reason`] last).
#[derive(Clone, Debug, PartialEq)]
pub struct Outliers {
    /// Farthest first, one per row.
    pub far: Vec<Outlier>,
    /// The median distance over every point (mm).
    pub median_mm: f64,
    /// Rows searched.
    pub rows: usize,
}

/// The gross outliers among the observations of `sets` (each its poses and the observation list
/// they index) by `model`.
pub fn find<const N: usize, V: ValueStorage>(
    model: &Robot<f64, N, V>,
    sets: &[(&[Pose], &[Measurement<f64, N>])],
) -> Outliers {
    let mut fk = ForwardKinematics::new();
    let mut all: Vec<Outlier> = Vec::new();
    for (poses, obs) in sets {
        for p in poses.iter() {
            for m in p.of(obs) {
                let Some(q) = fk.compute_at(model, &m.q, m.tool as usize, m.conditions()) else {
                    continue;
                };
                let d = (m.point - q).norm();
                if d.is_finite() {
                    all.push(Outlier {
                        line: p.line,
                        distance_mm: d,
                    });
                }
            }
        }
    }
    let rows = sets.iter().map(|(p, _)| p.len()).sum();
    let mut d: Vec<f64> = all.iter().map(|o| o.distance_mm).collect();
    if d.is_empty() {
        return Outliers {
            far: Vec::new(),
            median_mm: 0.0,
            rows,
        };
    }
    let mid = d.len() / 2;
    let (_, &mut median_mm, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    let limit = (MEDIAN_FACTOR * median_mm).max(MIN_MM);
    let mut far: Vec<Outlier> = all.into_iter().filter(|o| o.distance_mm > limit).collect();
    far.sort_by(|a, b| b.distance_mm.total_cmp(&a.distance_mm));
    // One row of several reflectors is one wrong reading: named once, at its farthest.
    let mut seen = std::collections::HashSet::new();
    far.retain(|o| seen.insert(o.line));
    Outliers {
        far,
        median_mm,
        rows,
    }
}

/// How many outliers are "a few": at most this share of the points (and at least 3). More
/// than that is no stray reading but a file the robot file does not describe, which the
/// convention and unit checks name better ([`crate::calibration::arm_size`]).
pub const FEW: f64 = 0.02;

impl Outliers {
    /// [`Self::reason`] when the outliers are a few ([`FEW`]), else `None`.
    pub fn few(&self) -> Option<String> {
        if self.far.len() as f64 > (FEW * self.rows as f64).max(3.0) {
            return None;
        }
        self.reason()
    }

    /// Why the fit is no calibration because of gross outliers, as the rest of a sentence
    /// that starts "the fit", or `None` when there are none.
    pub fn reason(&self) -> Option<String> {
        let first = self.far.first()?;
        let named: Vec<String> = self
            .far
            .iter()
            .take(3)
            .map(|o| format!("line {} {} mm", o.line, sig(o.distance_mm, 3)))
            .collect();
        let more = match self.far.len() {
            n if n > named.len() => format!(", {} more", n - named.len()),
            _ => String::new(),
        };
        Some(format!(
            "leaves {} point(s) far from the model ({}{more}; {}× the median {} mm): a wrong \
             reading (a lost reflector, a row in another unit or of another pose) pulls every \
             parameter; delete those rows or measure them again",
            self.far.len(),
            named.join(", "),
            sig(first.distance_mm / self.median_mm.max(f64::MIN_POSITIVE), 2),
            sig(self.median_mm, 3)
        ))
    }
}
