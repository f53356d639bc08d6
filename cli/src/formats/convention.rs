//! The convention door (docs/formats.md, "The convention check"): 6-D rows whose three angles
//! another of the six rotation orders explains far better than the one assumed are refused
//! (exit 2), naming the order and how to state it.
//!
//! # The test
//!
//! For each order, the file's angles are composed into rotations `M_i` and compared with the
//! nominal model's flange orientations `F_i` at the same joint readings. The base orientation
//! `B` (the tracker frame) and the measured frame's orientation on the flange `T` are unknown,
//! so both are fitted first: `M_i ≈ B·F_i·T` is linear in `B` and `Tᵀ`
//! (`M_i·Tᵀ − B·F_i = 0`), solved as the null vector of the 18 unknowns' normal equations, each
//! matrix projected onto the rotations, then refined by alternating rotation averages. The
//! order's score is the RMS angle of `(B·F_i·T)ᵀ·M_i` over an evenly spaced subset of rows.
//! Only the nominal geometry is needed, and its errors (tenths of a degree) are far below what
//! a wrong order leaves (tens of degrees).
//!
//! The file is refused when the best order is not the assumed one, explains the rows
//! [`CLEAR_RATIO`] times better, and the assumed order leaves more than [`FLOOR_DEG`].

use crate::formats::rotation_order::RotationOrder;
use kinecal::forward::ForwardKinematics;
use kinecal::{Frame, Robot};
use nalgebra::{DMatrix, Matrix3};

/// The best order must explain the rows this many times better than the assumed one.
pub const CLEAR_RATIO: f64 = 10.0;
/// The assumed order must leave at least this RMS angle, degrees, for a refusal.
pub const FLOOR_DEG: f64 = 1.0;
/// Most rows scored (evenly spaced over the file).
pub const SCORED_ROWS: usize = 500;
/// Fewest rows with an orientation for a verdict.
pub const FEWEST_ROWS: usize = 6;

/// A file whose angles compose in another order than the one assumed.
#[derive(Clone, Debug, PartialEq)]
pub struct Misstated {
    pub assumed: RotationOrder,
    pub found: RotationOrder,
    /// RMS angle, degrees, of the nominal model's orientations read in the assumed order.
    pub assumed_deg: f64,
    /// The same, read in the order found.
    pub found_deg: f64,
}

impl Misstated {
    /// The one-line reason; `map`: the map file the data were read with, if any.
    pub fn message(&self, origin: &str, map: Option<&std::path::Path>) -> String {
        let (a, f) = (self.assumed.text(), self.found.text());
        let how = match map {
            Some(m) => format!("set rotation = \"{f}\" under [units] in {}", m.display()),
            None => format!(
                "read the file with --map M.toml whose [units] say rotation = \"{f}\" \
                 (docs/formats.md, \"Files in other layouts\")"
            ),
        };
        format!(
            "{origin}: the orientation angles look composed as R = {f}, not {a} as assumed \
             (nominal orientation RMS {:.3}° read as {f}, {:.3}° as {a}): {how}",
            self.found_deg, self.assumed_deg
        )
    }
}

/// The rotation nearest to `m` (SVD projection; `None` when it fails).
fn nearest_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    Some(u * d * vt)
}

/// Angle, degrees, of the rotation `aᵀ·b`.
fn angle_deg(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let c = (((a.transpose() * b).trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    c.acos().to_degrees()
}

/// `B` and `T` with `m[i] ≈ B·f[i]·T` (see the module documentation).
fn fit_both(m: &[Matrix3<f64>], f: &[Matrix3<f64>]) -> Option<(Matrix3<f64>, Matrix3<f64>)> {
    // Unknowns: X = Tᵀ (column-major, 0..9) and B (9..18); rows: the entries of M·X − B·F.
    let mut ata = DMatrix::<f64>::zeros(18, 18);
    let mut row = [0.0f64; 18];
    for (mi, fi) in m.iter().zip(f) {
        for r in 0..3 {
            for c in 0..3 {
                row.fill(0.0);
                for k in 0..3 {
                    row[k + 3 * c] += mi[(r, k)];
                    row[9 + r + 3 * k] -= fi[(k, c)];
                }
                for a in 0..18 {
                    if row[a] != 0.0 {
                        for b in 0..18 {
                            ata[(a, b)] += row[a] * row[b];
                        }
                    }
                }
            }
        }
    }
    let eig = ata.symmetric_eigen();
    let k = eig.eigenvalues.imin();
    let v = eig.eigenvectors.column(k);
    let x = Matrix3::from_column_slice(&v.as_slice()[0..9]);
    let b = Matrix3::from_column_slice(&v.as_slice()[9..18]);
    // The null vector's sign is free: a rotation has a positive determinant.
    let s = if x.determinant() + b.determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    let mut t = nearest_rotation(&(x * s))?.transpose();
    let mut b = nearest_rotation(&(b * s))?;
    for _ in 0..10 {
        let sum_b: Matrix3<f64> = m
            .iter()
            .zip(f)
            .map(|(mi, fi)| mi * t.transpose() * fi.transpose())
            .sum();
        b = nearest_rotation(&sum_b)?;
        let sum_t: Matrix3<f64> = m
            .iter()
            .zip(f)
            .map(|(mi, fi)| fi.transpose() * b.transpose() * mi)
            .sum();
        t = nearest_rotation(&sum_t)?;
    }
    Some((b, t))
}

/// RMS angle, degrees, left by the best `B`, `T` (`None` when no fit is possible).
pub fn score(m: &[Matrix3<f64>], f: &[Matrix3<f64>]) -> Option<f64> {
    let (b, t) = fit_both(m, f)?;
    let ss: f64 = m
        .iter()
        .zip(f)
        .map(|(mi, fi)| angle_deg(&(b * fi * t), mi).powi(2))
        .sum();
    let rms = (ss / m.len() as f64).sqrt();
    rms.is_finite().then_some(rms)
}

/// The RMS angle, degrees, of each of the six orders (in [`RotationOrder::all`]'s order) for
/// rows of joint readings `q_deg` and the file's angles `angles` (degrees about x, y, z);
/// `None` with fewer than [`FEWEST_ROWS`] usable rows.
pub fn scores<const N: usize, V: kinecal::ValueStorage>(
    q_deg: &[[f64; N]],
    angles: &[[f64; 3]],
    nominal: &Robot<f64, N, V>,
) -> Option<Vec<(RotationOrder, f64)>> {
    let mut placed = nominal.clone();
    placed.set_base(Frame::identity()).ok()?;
    let usable: Vec<usize> = (0..q_deg.len().min(angles.len()))
        .filter(|&i| angles[i].iter().chain(&q_deg[i]).all(|v| v.is_finite()))
        .collect();
    if usable.len() < FEWEST_ROWS {
        return None;
    }
    let picked: Vec<usize> = (0..usable.len().min(SCORED_ROWS))
        .map(|k| usable[k * usable.len() / usable.len().min(SCORED_ROWS)])
        .collect();
    let mut fk = ForwardKinematics::<f64, N>::new();
    let f: Vec<Matrix3<f64>> = picked
        .iter()
        .map(|&i| {
            fk.compute(&placed, &q_deg[i].map(f64::to_radians));
            fk.flange_pose().rotation()
        })
        .collect();
    if f.iter().any(|r| !r.iter().all(|v| v.is_finite())) {
        return None;
    }
    RotationOrder::all()
        .into_iter()
        .map(|o| {
            let m: Vec<Matrix3<f64>> = picked.iter().map(|&i| o.matrix(angles[i])).collect();
            score(&m, &f).map(|s| (o, s))
        })
        .collect()
}

/// The verdict of the convention door: `Some` when the angles are misstated.
pub fn check<const N: usize, V: kinecal::ValueStorage>(
    q_deg: &[[f64; N]],
    angles: &[[f64; 3]],
    assumed: RotationOrder,
    nominal: &Robot<f64, N, V>,
) -> Option<Misstated> {
    let s = scores(q_deg, angles, nominal)?;
    let assumed_deg = s.iter().find(|(o, _)| *o == assumed)?.1;
    let (found, found_deg) = *s.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    (found != assumed && found_deg * CLEAR_RATIO <= assumed_deg && assumed_deg > FLOOR_DEG)
        .then_some(Misstated {
            assumed,
            found,
            assumed_deg,
            found_deg,
        })
}
