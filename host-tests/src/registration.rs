//! Point-set registration (Kabsch): the base pose that best maps the model's points onto the
//! measured ones. Identification starts the base here when the robot file has no `[base]`.

use kinecal::{ForwardKinematics, Frame, Measurement, Robot};
use nalgebra::{Matrix3, Vector3};

/// Rigid transform `(R, t)` minimising Σ |R·a_i + t − b_i|² (no scale), by SVD.
pub fn kabsch(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> anyhow::Result<Frame<f64>> {
    anyhow::ensure!(a.len() == b.len() && a.len() >= 3, "point-set registration needs at least 3 point pairs");
    let n = a.len() as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (p, q) in a.iter().zip(b) {
        h += (p - ca) * (q - cb).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u.ok_or_else(|| anyhow::anyhow!("SVD failed"))?, svd.v_t.ok_or_else(|| anyhow::anyhow!("SVD failed"))?);
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    anyhow::ensure!(r.iter().all(|x| x.is_finite()), "point-set registration failed (degenerate points)");
    Ok(Frame::from_parts(&r, cb - r * ca))
}

/// The base pose registering `robot`'s points (its base ignored) onto the measurements.
pub fn fit_base<const N: usize, const V: usize>(robot: &Robot<f64, N, V>, data: &[Measurement<f64, N>]) -> anyhow::Result<Frame<f64>> {
    let mut local = robot.clone();
    local.set_base(Frame::identity()).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let mut fk = ForwardKinematics::new();
    let a: Vec<Vector3<f64>> = data.iter().map(|m| fk.compute(&local, &m.q)).collect();
    let b: Vec<Vector3<f64>> = data.iter().map(|m| m.point).collect();
    kabsch(&a, &b)
}
