//! What a group's rows are compared with: the socket centre or the plane fitted to the tool
//! points a model predicts (the nuisance parameters of the fit), and each row's error against
//! it in millimetres.

use super::read::{Group, Kind};
use crate::calibration::stats::rms;
use crate::HostRobot;
use kinecal::ForwardKinematics;
use nalgebra::{Matrix3, Vector3};

/// The unknown a group adds to the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A socket's centre (mm).
    Centre(Vector3<f64>),
    /// A plane `n·p = d` (unit normal, offset in mm).
    Plane(Vector3<f64>, f64),
    /// Distances and points add no unknown.
    None,
}

impl Shape {
    /// Nuisance parameters of the shape in the fit: 3 for a centre, 3 for a plane (two tilts of
    /// the normal on its tangent plane and the offset), none otherwise.
    pub fn unknowns(&self) -> usize {
        match self {
            Shape::None => 0,
            _ => 3,
        }
    }
}

/// The tool points `robot` predicts for the rows of `g`, each at its temperature.
pub fn points<const N: usize>(robot: &HostRobot<N>, g: &Group<N>) -> Vec<Vector3<f64>> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    g.rows
        .iter()
        .map(|r| {
            fk.compute_at(robot, &r.q, r.tool, r.temp_c)
                .unwrap_or(Vector3::repeat(f64::NAN))
        })
        .collect()
}

/// The least-squares shape of `kind` through `pts`: the mean for a socket (it minimises the
/// summed squared distances), the plane of the smallest singular vector of the centred points.
pub fn fit(kind: Kind, pts: &[Vector3<f64>]) -> Shape {
    let n = pts.len().max(1) as f64;
    let mean = pts.iter().sum::<Vector3<f64>>() / n;
    match kind {
        Kind::Socket => Shape::Centre(mean),
        Kind::Plane => {
            let mut m = Matrix3::zeros();
            for p in pts {
                let d = p - mean;
                m += d * d.transpose();
            }
            let e = m.symmetric_eigen();
            let k = e.eigenvalues.imin();
            let normal: Vector3<f64> = e.eigenvectors.column(k).into_owned().normalize();
            Shape::Plane(normal, normal.dot(&mean))
        }
        _ => Shape::None,
    }
}

/// Two unit vectors spanning the plane normal to `n` (the directions the normal tilts in).
pub fn tangents(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let e = if n.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let t1 = n.cross(&e).normalize();
    (t1, n.cross(&t1))
}

/// Each row's error (mm) against `shape`, for the points `pts` of group `g`: the distance to the
/// socket centre, the signed distance to the plane, the distance to the tracker point; a
/// distance group has one error, predicted minus stated length.
pub fn errors<const N: usize>(g: &Group<N>, pts: &[Vector3<f64>], shape: &Shape) -> Vec<f64> {
    match (g.kind, shape) {
        (Kind::Socket, Shape::Centre(c)) => pts.iter().map(|p| (p - c).norm()).collect(),
        (Kind::Plane, Shape::Plane(n, d)) => pts.iter().map(|p| n.dot(p) - d).collect(),
        (Kind::Distance, _) => {
            vec![(pts[0] - pts[1]).norm() - g.length_mm.unwrap_or(f64::NAN)]
        }
        (Kind::Point, _) => pts
            .iter()
            .zip(&g.rows)
            .map(|(p, r)| (p - Vector3::from(r.xyz.unwrap_or([f64::NAN; 3]))).norm())
            .collect(),
        _ => vec![f64::NAN],
    }
}

/// The held-out residual of group `g` under `robot` (mm): its own shape refitted to the
/// predicted points, then the RMS of its rows' errors (a distance group: the length error).
pub fn held_out_error<const N: usize>(robot: &HostRobot<N>, g: &Group<N>) -> f64 {
    let pts = points(robot, g);
    let shape = fit(g.kind, &pts);
    let e = errors(g, &pts, &shape);
    rms(&e)
}

/// Refuses (exit 2) distance groups whose stated lengths are, in the median, more than 20 times
/// longer or shorter than the nominal model's distances between their poses: a length unit
/// misstated (millimetres read as metres or the reverse), not a robot 20 times off.
pub fn check_lengths<const N: usize>(
    nominal: &HostRobot<N>,
    groups: &[Group<N>],
    origin: &str,
) -> anyhow::Result<()> {
    let mut ratios: Vec<f64> = groups
        .iter()
        .filter(|g| g.kind == Kind::Distance)
        .filter_map(|g| {
            let pts = points(nominal, g);
            let predicted = (pts.first()? - pts.get(1)?).norm();
            (predicted > 1.0).then(|| g.length_mm.unwrap_or(f64::NAN) / predicted)
        })
        .filter(|r| r.is_finite())
        .collect();
    if ratios.is_empty() {
        return Ok(());
    }
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    if median > 20.0 {
        crate::refuse!(
            "{origin}: the stated lengths are {:.0}x the nominal robot's distances between their \
             poses: they look like millimetres read as metres; leave --length-unit m out",
            median
        );
    }
    if median < 0.05 {
        crate::refuse!(
            "{origin}: the stated lengths are 1/{:.0} of the nominal robot's distances between \
             their poses: they look like metres read as millimetres; give --length-unit m",
            1.0 / median
        );
    }
    Ok(())
}
