//! The rounding door: what the number of decimals a measurement file is written with says about
//! its rows (docs/formats.md, "Rounded and computed points").
//!
//! * **Computed points.** x, y, z that are the robot file's own forward kinematics at every
//!   pose — a controller's TCP columns mapped as the tracker's, or a simulation of this very
//!   model — are no measurement: a fit to them "calibrates" to nanometres and says nothing about
//!   the robot. Measured points differ from any model by the robot's repeatability and the
//!   instrument's noise (tens of micrometres at least), so a file is refused (exit 2) when, at
//!   [`FEWEST_POSES`] poses or more, every point lies within what the file's own rounding
//!   explains ([`Rounding::bound_mm`], × [`ROUNDING_SLACK`]) and within [`COMPUTED_MM`].
//! * **Coarse joint readings.** Joints written with few decimals (radians with 2 or 3) move the
//!   tool by the rounding alone: the expected RMS ([`Rounding::joint_rms_mm`]) is told as a
//!   warning from [`WARN_MM`], and refused when it is also at least [`REFUSE_SHARE`] of the
//!   nominal model's own error on the file (a fit would model the rounding). Rounding adds an
//!   error no model removes, so when the points fit the nominal model [`EXACT_RATIO`] times
//!   better than it allows, the readings were whole by design (a sweep commanded in steps of
//!   15°) and nothing is said.
//!
//! Both verdicts read at most [`crate::formats::units::SCORED_POSES`] evenly spaced poses, so a
//! file of a million rows costs no more than one of a few thousand.
//!
//! A column's step is the largest power of ten (down to [`FINEST_STEP`]) every value of it is a
//! multiple of; finer steps are "full precision" and round nothing.

use crate::compute::registration::fit_rigid;
use crate::formats::measurements::Dataset;
use kinecal::forward::ForwardKinematics;
use kinecal::{Frame, Robot};
use nalgebra::Vector3;

/// Fewest poses for the computed-points verdict.
pub const FEWEST_POSES: usize = 5;
/// Every point must lie within this of the model (mm) to be called computed.
pub const COMPUTED_MM: f64 = 0.01;
/// Computed points lie within their rounding bound; this much slack (and 1e-6 mm) is allowed.
pub const ROUNDING_SLACK: f64 = 1.5;
/// Joint rounding that moves the tool by this RMS (mm) or more is warned about.
pub const WARN_MM: f64 = 0.02;
/// Joint rounding at least this share of the nominal model's RMS error is refused.
pub const REFUSE_SHARE: f64 = 0.5;
/// A column with fewer different values tells nothing of its step (a joint held at 0, one row).
pub const FEWEST_DISTINCT: usize = 10;
/// Joint rounding this many times the nominal model's RMS error cannot have happened: the
/// readings are whole by design.
pub const EXACT_RATIO: f64 = 2.0;
/// Steps finer than this (in the file's unit) are full precision.
pub const FINEST_STEP: f64 = 1e-9;

/// The step a column of numbers is written with: the largest `10^-k` (k = 0…9) every finite
/// value is a multiple of, or 0 when they carry more decimals or hold fewer than
/// [`FEWEST_DISTINCT`] different values.
pub fn step(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let mut distinct: Vec<f64> = values.clone().filter(|v| v.is_finite()).collect();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    if distinct.len() < FEWEST_DISTINCT {
        return 0.0;
    }
    let mut s = 1.0;
    while s >= FINEST_STEP {
        let fits = values.clone().filter(|v| v.is_finite()).all(|v| {
            let k = v / s;
            (k - k.round()).abs() <= 1e-6 * k.abs().max(1.0)
        });
        if fits {
            return s;
        }
        s /= 10.0;
    }
    0.0
}

/// The steps of a file's columns, in mm and degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Steps<const N: usize> {
    pub xyz_mm: f64,
    pub q_deg: [f64; N],
    /// The joints' steps as written (the file's unit) and whether that unit is radians.
    pub q_written: [f64; N],
    pub radians: bool,
}

impl<const N: usize> Steps<N> {
    /// The steps of `ds` as read from the file, before its units are converted: `mm_per_unit`
    /// and `radians` are the units it is read in.
    pub fn of(ds: &Dataset<N>, mm_per_unit: f64, radians: bool) -> Self {
        let xyz = (0..3)
            .map(|c| step(ds.records.iter().map(move |r| r.xyz_mm[c])))
            .fold(0.0, f64::max);
        let q_written: [f64; N] =
            core::array::from_fn(|j| step(ds.records.iter().map(move |r| r.q_deg[j])));
        Self {
            xyz_mm: xyz * mm_per_unit,
            q_deg: q_written.map(|s| if radians { s.to_degrees() } else { s }),
            q_written,
            radians,
        }
    }
}

/// What the rounding of a file does at its poses (at most
/// [`crate::formats::units::SCORED_POSES`] of them, evenly spaced).
#[derive(Clone, Debug, PartialEq)]
pub struct Rounding {
    /// Per pose, the most the rounding of x, y, z and the joints can move the point (mm).
    pub bound_mm: Vec<f64>,
    /// Expected RMS (mm) by which the joints' rounding moves the tool.
    pub joint_rms_mm: f64,
    /// The joint whose rounding moves it most (0-based).
    pub worst_joint: usize,
    /// Per pose, the distance of the point from the nominal model's (mm).
    pub residual_mm: Vec<f64>,
}

/// The rounding of `ds` (mm, degrees) with `steps`, against `nominal` placed at its base
/// (`base_known`) or best placed onto the points. `None` when the model cannot be evaluated or
/// placed.
pub fn rounding<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    steps: &Steps<N>,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
) -> Option<Rounding> {
    let mut placed = nominal.clone();
    if !base_known {
        placed.set_base(Frame::identity()).ok()?;
    }
    let records =
        crate::formats::units::evenly_spaced(&ds.records, crate::formats::units::SCORED_POSES);
    let mut fk = ForwardKinematics::<f64, N>::new();
    let h = 1e-6;
    let mut model = Vec::with_capacity(records.len());
    let mut bound_mm = Vec::with_capacity(records.len());
    let mut per_joint = [0.0; N];
    for r in records.iter() {
        let q: [f64; N] = r.q_deg.map(f64::to_radians);
        let p = fk.compute(&placed, &q);
        let mut bound = 3f64.sqrt() / 2.0 * steps.xyz_mm;
        for j in 0..N {
            let mut qh = q;
            qh[j] += h;
            let lever = (fk.compute(&placed, &qh) - p).norm() / h;
            let dq = steps.q_deg[j].to_radians();
            bound += lever * dq / 2.0;
            per_joint[j] += (lever * dq).powi(2) / 12.0;
        }
        if !(p.iter().all(|c| c.is_finite()) && bound.is_finite()) {
            return None;
        }
        model.push(p);
        bound_mm.push(bound);
    }
    let pts: Vec<Vector3<f64>> = records.iter().map(|r| Vector3::from(r.xyz_mm)).collect();
    let residual_mm: Vec<f64> = if base_known {
        pts.iter()
            .zip(&model)
            .map(|(p, m)| (p - m).norm())
            .collect()
    } else {
        let f = fit_rigid(&model, &pts).ok()?;
        pts.iter()
            .zip(&model)
            .map(|(p, m)| (f.point(m) - p).norm())
            .collect()
    };
    let n = records.len().max(1) as f64;
    let worst_joint = (0..N)
        .max_by(|&a, &b| per_joint[a].total_cmp(&per_joint[b]))
        .unwrap_or(0);
    Some(Rounding {
        bound_mm,
        joint_rms_mm: (per_joint.iter().sum::<f64>() / n).sqrt(),
        worst_joint,
        residual_mm,
    })
}

impl Rounding {
    /// Whether every point is the model's own, within the rounding (see the module's rule).
    pub fn computed(&self) -> bool {
        self.residual_mm.len() >= FEWEST_POSES
            && self
                .residual_mm
                .iter()
                .zip(&self.bound_mm)
                .all(|(r, b)| *r <= COMPUTED_MM && *r <= ROUNDING_SLACK * b + 1e-6)
    }

    /// RMS of the points' distances from the model (mm).
    pub fn residual_rms_mm(&self) -> f64 {
        let n = self.residual_mm.len().max(1) as f64;
        (self.residual_mm.iter().map(|r| r * r).sum::<f64>() / n).sqrt()
    }
}

/// Refuses (exit 2) computed points and joints rounded past use; returns the warning about
/// coarse joints, if any. `ds` is in mm and degrees; `steps` from the file as read.
pub fn check<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    steps: &Steps<N>,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    origin: &str,
) -> anyhow::Result<Option<String>> {
    let Some(r) = rounding(ds, steps, nominal, base_known) else {
        return Ok(None);
    };
    if r.computed() {
        let largest = r.residual_mm.iter().copied().fold(0.0, f64::max);
        crate::refuse!(
            "{origin}: x, y, z are the robot file's own model at every one of the {} poses{} \
             (largest difference {} mm{}): points computed from the joints (a controller's TCP \
             columns, or a simulation of this very model), not measured; map x, y, z to the \
             instrument's columns (--map) and give the robot's nominal model",
            r.residual_mm.len(),
            if r.residual_mm.len() < ds.len() {
                format!(" read (evenly spaced, of {})", ds.len())
            } else {
                String::new()
            },
            crate::output::numfmt::sig(largest, 2),
            if base_known {
                ""
            } else {
                " after placing its base"
            }
        );
    }
    if r.joint_rms_mm < WARN_MM {
        return Ok(None);
    }
    let j = r.worst_joint;
    let written = steps.q_written[j];
    let decimals = (-written.log10()).round().max(0.0) as usize;
    let what = format!(
        "{origin}: the joint readings are written with {decimals} decimal{s} (q{} in steps of \
         {written} {unit}, {deg}°): rounding alone moves the tool by ~{mm} mm RMS",
        j + 1,
        unit = if steps.radians { "rad" } else { "°" },
        s = if decimals == 1 { "" } else { "s" },
        deg = crate::output::numfmt::sig(steps.q_deg[j], 2),
        mm = crate::output::numfmt::sig(r.joint_rms_mm, 2),
    );
    let nominal_rms = r.residual_rms_mm();
    // Rounding adds an error no model removes: points that fit the nominal model far better
    // than the rounding allows were written from readings that are whole by design (a sweep
    // commanded in steps of 15°), not rounded.
    if r.joint_rms_mm > EXACT_RATIO * nominal_rms {
        return Ok(None);
    }
    if r.joint_rms_mm >= REFUSE_SHARE * nominal_rms {
        crate::refuse!(
            "{what}, {} the nominal model's own error on this file ({} mm RMS): a \
             calibration would fit the rounding; export the joints with more decimals (6 for \
             radians, 4 for degrees)",
            if r.joint_rms_mm >= nominal_rms {
                "more than".to_string()
            } else {
                format!("{:.0} % of", 100.0 * r.joint_rms_mm / nominal_rms)
            },
            crate::output::numfmt::sig(nominal_rms, 3)
        );
    }
    Ok(Some(format!(
        "warning: {what}, which stays in every residual; export the joints with more decimals \
         (6 for radians, 4 for degrees)"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_s_step_is_the_coarsest_power_of_ten_its_values_are_multiples_of() {
        let with = |v: &[f64]| -> Vec<f64> {
            (0..10).map(|k| k as f64).chain(v.iter().copied()).collect()
        };
        assert_eq!(step(with(&[0.57, -1.2]).into_iter()), 0.01);
        assert_eq!(step(with(&[12.0, -400.0]).into_iter()), 1.0);
        assert!((step(with(&[0.123, 1.5]).into_iter()) - 0.001).abs() < 1e-15);
        assert_eq!(step(with(&[0.1234567891234]).into_iter()), 0.0);
        // Too few different values: a joint held at 0, one row.
        assert_eq!(step([0.0; 40].into_iter()), 0.0);
        assert_eq!(step([-180.0].into_iter()), 0.0);
        assert_eq!(step([f64::NAN].into_iter()), 0.0);
    }
}
