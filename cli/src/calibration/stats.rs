//! Accuracy statistics of one model on one set of poses: per axis (the signed component of
//! measured − model) and in total (the distance), RMS, mean, largest and 95th percentile.
//!
//! The totals come from [`crate::calibration::ErrorStats`] over
//! [`crate::calibration::pose_errors`], the very functions `identify` reports with, so the
//! report's RMS, mean and largest error equal `identify`'s. The calibration report
//! (`crate::report_html`) and `validate` ([`crate::calibration::validate`]) both take their
//! per-axis and 95 % figures from here.

use crate::calibration::{pose_error_vectors, ErrorStats};
use kinecal::{Measurement, Robot};
use nalgebra::Vector3;
use serde::Serialize;

/// Root mean square of `values` (NaN when there are none): the one place it is written.
pub fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// The mean of a column every row logs (a time, a temperature), when each row has one and
/// their spread `highest − lowest` is `enough`; `None` otherwise (a reference the data cannot
/// give).
pub fn mean_if_spread(
    values: impl Iterator<Item = Option<f64>>,
    enough: impl Fn(f64) -> bool,
) -> Option<f64> {
    let t: Vec<f64> = values.collect::<Option<_>>()?;
    let (lo, hi) = t
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    (!t.is_empty() && enough(hi - lo)).then(|| t.iter().sum::<f64>() / t.len() as f64)
}

/// Statistics of one quantity over the poses (mm).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Figures {
    pub rms: f64,
    /// Mean of the signed value (per axis) or of the distance (total).
    pub mean: f64,
    /// Largest magnitude.
    pub max: f64,
    /// 95th percentile of the magnitude.
    pub p95: f64,
}

/// The statistics of one model on one set: x, y, z and the distance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SetFigures {
    pub poses: usize,
    pub x: Figures,
    pub y: Figures,
    pub z: Figures,
    pub total: Figures,
}

/// The `p`-quantile (0 ≤ p ≤ 1) of `values`, linear between order statistics (the default of
/// NumPy and R's type 7); NaN when empty.
pub fn quantile(values: &[f64], p: f64) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let h = (v.len() - 1) as f64 * p.clamp(0.0, 1.0);
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    v[lo] + (h - lo as f64) * (v[hi] - v[lo])
}

fn axis(values: &[f64]) -> Figures {
    let n = values.len().max(1) as f64;
    let abs: Vec<f64> = values.iter().map(|v| v.abs()).collect();
    Figures {
        rms: if values.is_empty() { 0.0 } else { rms(values) },
        mean: values.iter().sum::<f64>() / n,
        max: abs.iter().copied().fold(0.0, f64::max),
        p95: quantile(&abs, 0.95),
    }
}

impl SetFigures {
    /// The figures of error vectors (measured − model); `None` for no poses.
    pub fn of_vectors(errors: &[Vector3<f64>]) -> Option<Self> {
        let dist: Vec<f64> = errors.iter().map(|e| e.norm()).collect();
        let t = ErrorStats::of(&dist)?;
        let comp = |a: usize| axis(&errors.iter().map(|e| e[a]).collect::<Vec<_>>());
        Some(Self {
            poses: errors.len(),
            x: comp(0),
            y: comp(1),
            z: comp(2),
            total: Figures {
                rms: t.rms_mm,
                mean: t.mean_mm,
                max: t.max_mm,
                p95: quantile(&dist, 0.95),
            },
        })
    }

    /// The figures of `robot` on `data`, with the error vectors (measured − model).
    pub fn of<const N: usize, V: kinecal::ValueStorage>(
        robot: &Robot<f64, N, V>,
        data: &[Measurement<f64, N>],
    ) -> (Option<Self>, Vec<Vector3<f64>>) {
        let e = pose_error_vectors(robot, data);
        (Self::of_vectors(&e), e)
    }
}
