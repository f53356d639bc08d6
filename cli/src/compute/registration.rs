//! Point-set registration (Kabsch): the base pose that best maps the model's points onto the
//! measured ones. `check` reports the nominal error with it, and identification starts the base
//! here when the robot file has no `[base]`.

use anyhow::{anyhow, bail};
use kinecal::forward::ForwardKinematics;
use kinecal::{Frame, Measurement, Robot};
use nalgebra::{Matrix3, Vector3};

/// The rigid transform `(R, t)` minimising `Σ |R·a_i + t − b_i|²` (Kabsch/Umeyama without
/// scale, reflections excluded), as a frame: `b ≈ frame.point(a)`. Fails for fewer than three
/// points, non-finite input, or points on a line (rotation about it undetermined).
pub fn fit_rigid(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> anyhow::Result<Frame<f64>> {
    if a.len() != b.len() {
        bail!(
            "point-set registration: {} model points but {} measured points",
            a.len(),
            b.len()
        );
    }
    // The data's failures are refusals (exit 2): the user measures again, nothing is broken.
    if a.len() < 3 {
        crate::refuse!(
            "point-set registration needs at least 3 points, got {}: measure more poses",
            a.len()
        );
    }
    if a.iter().chain(b).any(|p| !p.iter().all(|c| c.is_finite())) {
        crate::refuse!("point-set registration: a point is not a finite number: check the data");
    }
    let (ca, cb, h) = cross_covariance(a, b);
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        bail!("point-set registration: SVD failed");
    };
    let mut s = svd.singular_values.as_slice().to_vec();
    s.sort_by(|x, y| y.total_cmp(x));
    if s[1] <= 1e-9 * s[0] || s[0] == 0.0 {
        crate::refuse!(
            "point-set registration: the points lie on a line or at one place: measure poses \
             spread in space"
        );
    }
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let t = cb - r * ca;
    let mut f = Frame::from_parts(&r, t);
    f.orthonormalize();
    Ok(f)
}

/// The centroids of `a` and `b` (equally long, not empty) and their cross-covariance
/// `Σ (a − ā)(b − b̄)ᵀ`: what both registrations decompose.
fn cross_covariance(
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
) -> (Vector3<f64>, Vector3<f64>, Matrix3<f64>) {
    let n = a.len() as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (pa, pb) in a.iter().zip(b) {
        h += (pa - ca) * (pb - cb).transpose();
    }
    (ca, cb, h)
}

/// The centroids of `a` and `b` and the orthogonal map that best turns `a`'s spread onto `b`'s:
/// a rotation, or with `mirrored` a reflection times a rotation. `None` with fewer than 3
/// points, sets of different lengths or points that are not finite.
fn orthogonal_map(
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
    mirrored: bool,
) -> Option<(Vector3<f64>, Vector3<f64>, Matrix3<f64>)> {
    if a.len() != b.len()
        || a.len() < 3
        || a.iter().chain(b).any(|p| !p.iter().all(|c| c.is_finite()))
    {
        return None;
    }
    let (ca, cb, h) = cross_covariance(a, b);
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let last = if mirrored { -d } else { d };
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, last)) * u.transpose();
    Some((ca, cb, r))
}

/// The RMS (mm) of `b` against `a` placed by the best *mirrored* orthogonal map (a reflection
/// times a rotation, and a shift): small where the best rigid placement leaves much, when the
/// points `b` are `a` mirrored (an axis's sign flipped, two axes exchanged). Which axis cannot be
/// told: any two mirrorings differ by a rotation. `None` with fewer than 3 points or points that
/// are not finite.
pub fn mirrored_rms(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> Option<f64> {
    let (ca, cb, r) = orthogonal_map(a, b, true)?;
    let sq: f64 = a
        .iter()
        .zip(b)
        .map(|(pa, pb)| (r * (pa - ca) + cb - pb).norm_squared())
        .sum();
    Some((sq / a.len() as f64).sqrt())
}

/// The scale and RMS (mm) of `b` against `a` placed by the best *similarity* (a rotation, a
/// shift and one scale factor, Umeyama's): `b ≈ s·R·a + t`. A scale far from 1 that leaves a
/// far smaller RMS than the rigid placement says the points `b` are in another length unit
/// than `a`'s (inches read as millimetres: 0.0394). `None` with fewer than 3 points, points
/// that are not finite or `a` at one place.
pub fn scaled_fit(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> Option<(f64, f64)> {
    let (ca, cb, r) = orthogonal_map(a, b, false)?;
    let spread: f64 = a.iter().map(|p| (p - ca).norm_squared()).sum();
    if spread <= 0.0 {
        return None;
    }
    let scale = a
        .iter()
        .zip(b)
        .map(|(pa, pb)| (r * (pa - ca)).dot(&(pb - cb)))
        .sum::<f64>()
        / spread;
    let sq: f64 = a
        .iter()
        .zip(b)
        .map(|(pa, pb)| (scale * (r * (pa - ca)) + cb - pb).norm_squared())
        .sum();
    Some((scale, (sq / a.len() as f64).sqrt()))
}

/// Sets `robot`'s base to [`fit_base`]'s. Registration gives a rotation, so what the robot
/// refuses is a base beyond its bound (1 km): points far larger than the model's, in another
/// length unit than the one stated (refused, exit 2, saying so).
pub fn place_base<const N: usize, V: kinecal::ValueStorage>(
    robot: &mut Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<()> {
    let b = fit_base(robot, data)?;
    robot.set_base(b).map_err(|_| {
        crate::refused(format!(
            "the base that puts the model on the measured points lies {} m away: the points \
             are not in the length unit stated; check --length-unit or the map's [units] \
             length",
            crate::output::numfmt::sig(b.o.norm() / 1000.0, 3)
        ))
    })
}

/// The base pose that places `robot` (its own base ignored) best onto the measurements.
pub fn fit_base<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<Frame<f64>> {
    let mut placed = robot.clone();
    placed
        .set_base(Frame::identity())
        .map_err(|e| anyhow!("{e:?}"))?;
    let model: Vec<Vector3<f64>> = crate::compute::parallel::map_parts(data, |part| {
        let mut fk = ForwardKinematics::<f64, N>::new();
        part.iter()
            .map(|m| {
                fk.compute_at(&placed, &m.q, m.tool as usize, m.conditions())
                    .unwrap_or(Vector3::repeat(f64::NAN))
            })
            .collect::<Vec<_>>()
    })
    .concat();
    let measured: Vec<Vector3<f64>> = data.iter().map(|m| m.point).collect();
    fit_rigid(&model, &measured)
}

/// The measured frame's orientation in the flange frame that best explains 6-D observations
/// (the rotation nearest, in the Frobenius sense, to the mean of `R_flangeᵀ · R_measured`;
/// SVD projection): the start of identification when the robot file gives no `[tool]
/// rpy_deg`, as [`fit_base`] starts an unknown base. `None` without orientations.
pub fn fit_tool_axes<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Option<Frame<f64>> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut sum = nalgebra::Matrix3::zeros();
    let mut n = 0;
    for m in data {
        let Some(o) = &m.orientation else { continue };
        fk.compute_at(robot, &m.q, m.tool as usize, m.conditions())?;
        sum += fk.flange_pose().rotation().transpose() * o.rotation();
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let svd = sum.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut d = nalgebra::Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = u * d * vt;
    let f = Frame::from_parts(&r, Vector3::zeros());
    f.is_rotation().then_some(f)
}
