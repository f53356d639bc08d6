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

/// Below and above these ratios of a bar's stated length to the nominal model's distance
/// between its poses (the median over the groups) the lengths are refused: a robot 30 % off is
/// no robot the file describes (the arm-size rule of `identify` stops at 20 %).
pub const LENGTH_RATIO: [f64; 2] = [0.7, 1.4];

/// Length-unit slips: the ratio they give, what they are, and what to do.
const LENGTH_SLIPS: [(f64, &str, &str); 6] = [
    (
        1e-3,
        "metres read as millimetres",
        "give --length-unit m (which reads sigma_mm and x, y, z in metres too: convert any of \
         them written in millimetres)",
    ),
    (
        1.0 / 25.4,
        "inches",
        "convert length_mm to millimetres (x 25.4)",
    ),
    (
        0.1,
        "centimetres",
        "convert length_mm to millimetres (x 10)",
    ),
    (
        1e3,
        "millimetres read as metres",
        "leave --length-unit m out",
    ),
    (
        1e3 / 25.4,
        "inches read as metres",
        "convert length_mm to millimetres (x 25.4) and leave --length-unit m out",
    ),
    (
        100.0,
        "centimetres read as metres",
        "convert length_mm to millimetres (x 10) and leave --length-unit m out",
    ),
];

/// Refuses (exit 2) distance groups whose stated lengths are, in the median, outside
/// [`LENGTH_RATIO`] of the nominal model's distances between their poses, naming the unit slip
/// within 10 % of the ratio (metres, inches or centimetres, read as millimetres or as metres)
/// when there is one: a length unit misstated, not a robot that far off.
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
    if (LENGTH_RATIO[0]..=LENGTH_RATIO[1]).contains(&median) {
        return Ok(());
    }
    let one_decimal = |v: f64| format!("{v:.1}").trim_end_matches(".0").to_string();
    let ratio = if median < 1.0 {
        format!("1/{}", one_decimal(1.0 / median))
    } else {
        format!("{}x", one_decimal(median))
    };
    let slip = LENGTH_SLIPS
        .iter()
        .find(|(f, _, _)| (median / f).ln().abs() < 1.1_f64.ln());
    match slip {
        Some((_, what, todo)) => crate::refuse!(
            "{origin}: the stated lengths are {ratio} of the nominal robot's distances between \
             their poses: they look like {what}; {todo}"
        ),
        None => crate::refuse!(
            "{origin}: the stated lengths are {ratio} of the nominal robot's distances between \
             their poses, and no length unit explains it: check length_mm against the bar's \
             certificate and the robot file"
        ),
    }
}
