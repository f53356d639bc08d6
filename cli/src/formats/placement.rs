//! The placement door (docs/formats.md, "Base"): a `[base]` that the robot file states but
//! that puts the measured points far from where the model reaches them — the data are in
//! another frame than the one the base was given in — is refused (exit 2), since everything
//! fitted with that base held would absorb the error.

use crate::compute::registration::fit_rigid;
use crate::formats::measurements::Dataset;
use crate::output::numfmt::sig;
use kinecal::forward::ForwardKinematics;
use kinecal::Robot;
use nalgebra::Vector3;

/// The stated base must leave this many times the RMS of the base fitted to the data…
pub const CLEAR_RATIO: f64 = 10.0;
/// …and at least this fraction of the reach, for a refusal…
pub const FLOOR_OF_REACH: f64 = 0.05;
/// …and the fitted base must place the points within this fraction of their spread (two
/// tiny clusters — metres read as millimetres, radians as degrees — can be placed onto each
/// other closely whatever they are: that is the units door's to judge).
pub const FIT_OF_SPREAD: f64 = 0.1;
/// Most rows compared (evenly spaced over the file).
pub const SCORED_ROWS: usize = 4096;

/// A stated base that misplaces the data.
#[derive(Clone, Debug, PartialEq)]
pub struct Misplaced {
    /// RMS distance, mm, between the points and the model placed at the stated base.
    pub stated_mm: f64,
    /// The same with the base fitted to the points.
    pub fitted_mm: f64,
    /// Distance, mm, between the points' centroid and the model's at the stated base.
    pub offset_mm: f64,
    /// How far (degrees) the fitted base turns the model from the stated one.
    pub turned_deg: f64,
}

impl Misplaced {
    /// The one-line reason.
    pub fn message(&self, origin: &str) -> String {
        // The RMS distance, not the centroids': a base turned about the points' centre moves
        // their centre little and the points far.
        let far = if self.stated_mm >= 1000.0 {
            format!("{} m", sig(self.stated_mm / 1000.0, 3))
        } else {
            format!("{} mm", sig(self.stated_mm, 3))
        };
        format!(
            "{origin}: the robot file's [base] puts the measured points {far} from the model \
             (RMS; {} mm with the base fitted to the data, which turns it {}° and moves the \
             points' centre {} mm): the data are in another frame; remove [base] from the \
             robot file to have the base estimated, or correct it",
            sig(self.fitted_mm, 3),
            sig(self.turned_deg, 3),
            sig(self.offset_mm, 3)
        )
    }
}

/// The verdict: `Some` when the robot's stated base misplaces the data (rows with one
/// measured point, in mm and degrees). `None` too when nothing can be told (fewer than three
/// points, points on a line, several reflectors).
pub fn check<const N: usize, V: kinecal::ValueStorage>(
    ds: &Dataset<N>,
    nominal: &Robot<f64, N, V>,
) -> Option<Misplaced> {
    let rows: Vec<usize> = (0..ds.len())
        .filter(|&i| ds.records[i].xyz_mm.iter().all(|v| v.is_finite()))
        .collect();
    let picked: Vec<usize> = (0..rows.len().min(SCORED_ROWS))
        .map(|k| rows[k * rows.len() / rows.len().min(SCORED_ROWS)])
        .collect();
    let mut fk = ForwardKinematics::<f64, N>::new();
    let model: Vec<Vector3<f64>> = picked
        .iter()
        .map(|&i| fk.compute(nominal, &ds.records[i].q_deg.map(f64::to_radians)))
        .collect();
    let pts: Vec<Vector3<f64>> = picked
        .iter()
        .map(|&i| Vector3::from(ds.records[i].xyz_mm))
        .collect();
    let fit = fit_rigid(&model, &pts).ok()?;
    let n = pts.len() as f64;
    let rms = |f: &dyn Fn(&Vector3<f64>) -> Vector3<f64>| {
        (pts.iter()
            .zip(&model)
            .map(|(p, m)| (f(m) - p).norm_squared())
            .sum::<f64>()
            / n)
            .sqrt()
    };
    let stated_mm = rms(&|m| *m);
    let fitted_mm = rms(&|m| fit.point(m));
    let centroid = |v: &[Vector3<f64>]| v.iter().sum::<Vector3<f64>>() / n;
    let offset_mm = (centroid(&pts) - centroid(&model)).norm();
    let spread = |v: &[Vector3<f64>]| {
        let c = centroid(v);
        (v.iter().map(|p| (p - c).norm_squared()).sum::<f64>() / n).sqrt()
    };
    let scale = spread(&pts).max(spread(&model));
    (stated_mm.is_finite()
        && fitted_mm <= FIT_OF_SPREAD * scale
        && stated_mm >= CLEAR_RATIO * fitted_mm
        && stated_mm >= FLOOR_OF_REACH * nominal.reach())
    .then_some(Misplaced {
        stated_mm,
        fitted_mm,
        offset_mm,
        turned_deg: ((fit.x.x + fit.y.y + fit.z.z - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees(),
    })
}
