//! Positional accuracy and repeatability in the sense of ISO 9283 (§7.2.1, §7.2.2).
//!
//! The commanded position of a pose is where the controller's model puts the tool for the
//! commanded joint readings: the nominal robot file (its base fitted to the data when the file
//! has none), or the calibrated model for the "after" figures. The attained position is the
//! measured one. Every pose gives a distance `l = |attained − commanded|`; poses whose joint
//! readings are identical (a pose approached several times) form a group, for which
//!
//! - AP = |barycentre of the attained positions − commanded position| (with its x, y, z
//!   components), and
//! - RP = l̄ + 3·S_l, with l_j the distance of each attained position from the barycentre,
//!   l̄ their mean and S_l their sample standard deviation.

use super::stats::quantile;
use kinecal::Measurement;
use nalgebra::Vector3;
use serde::Serialize;
use std::collections::BTreeMap;

/// A pose approached at least twice.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RepeatedPose {
    /// 1-based row numbers (among the poses of the set) of its approaches.
    pub rows: Vec<usize>,
    /// Joint readings (degrees).
    pub q_deg: Vec<f64>,
    pub ap_mm: f64,
    pub ap_xyz_mm: [f64; 3],
    pub rp_mm: f64,
    pub mean_l_mm: f64,
    pub s_l_mm: f64,
}

/// The ISO 9283 figures of one model on one set.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Accuracy {
    /// Poses (one measured point each; the first point with several reflectors).
    pub poses: usize,
    /// Mean, RMS, 95th percentile and largest distance between commanded and attained (mm).
    pub mean_mm: f64,
    pub rms_mm: f64,
    pub p95_mm: f64,
    pub max_mm: f64,
    /// Sample standard deviation of the distances (mm).
    pub s_mm: f64,
    /// Groups of identical joint readings (empty when no pose was repeated).
    pub repeated: Vec<RepeatedPose>,
}

/// The figures of `commanded` (model positions) against the attained positions of `data`, one
/// point per pose (the first tool point).
pub fn accuracy<const N: usize>(
    data: &[Measurement<f64, N>],
    commanded: &[Vector3<f64>],
) -> Option<Accuracy> {
    let rows: Vec<(usize, &Measurement<f64, N>, Vector3<f64>)> = data
        .iter()
        .zip(commanded)
        .filter(|(m, c)| m.tool == 0 && c.iter().all(|v| v.is_finite()))
        .enumerate()
        .map(|(i, (m, c))| (i, m, *c))
        .collect();
    if rows.is_empty() {
        return None;
    }
    let l: Vec<f64> = rows.iter().map(|(_, m, c)| (m.point - c).norm()).collect();
    let n = l.len() as f64;
    let mean = l.iter().sum::<f64>() / n;
    let s = if l.len() > 1 {
        (l.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    // Group by the exact joint readings (bit patterns: "identical" means identical).
    let mut groups: BTreeMap<[u64; N], Vec<usize>> = BTreeMap::new();
    for (k, (_, m, _)) in rows.iter().enumerate() {
        groups.entry(m.q.map(f64::to_bits)).or_default().push(k);
    }
    let repeated = groups
        .values()
        .filter(|g| g.len() >= 2)
        .map(|g| {
            let pts: Vec<Vector3<f64>> = g.iter().map(|&k| rows[k].1.point).collect();
            let bary = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
            let d = bary - rows[g[0]].2;
            let lj: Vec<f64> = pts.iter().map(|p| (p - bary).norm()).collect();
            let m = lj.iter().sum::<f64>() / lj.len() as f64;
            let sl =
                (lj.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (lj.len() - 1) as f64).sqrt();
            RepeatedPose {
                rows: g.iter().map(|&k| rows[k].0 + 1).collect(),
                q_deg: rows[g[0]].1.q.iter().map(|q| q.to_degrees()).collect(),
                ap_mm: d.norm(),
                ap_xyz_mm: [d.x, d.y, d.z],
                rp_mm: m + 3.0 * sl,
                mean_l_mm: m,
                s_l_mm: sl,
            }
        })
        .collect();
    Some(Accuracy {
        poses: l.len(),
        mean_mm: mean,
        rms_mm: crate::calibration::stats::rms(&l),
        p95_mm: quantile(&l, 0.95),
        max_mm: l.iter().copied().fold(0.0, f64::max),
        s_mm: s,
        repeated,
    })
}
