//! The information matrix of a set of measurement poses and the parameter covariance it
//! predicts, on the identifiable subspace.
//!
//! A laser tracker measures a point, so each pose contributes a 3-row block `G` of the
//! identification Jacobian and the information matrix grows by the rank-3 update `GᵀG`.
//! Parameters are scaled ([`crate::Param::scale`]: angles × reach, so a unit of every scaled
//! parameter moves the tool by about a millimetre); the information and covariance here are in those scaled units,
//! which leaves every quantity at the tool (the KPI) unchanged.
//!
//! With independent measurement noise σ (mm, per coordinate) the least-squares estimate has
//! covariance `C = σ²·(JᵀJ)⁺`. Directions no pose can excite (base z against d1, theta of the
//! last joint against the tool, d of parallel axes) have zero information; they are dropped by
//! eigenvalue thresholding, so `⁺` is the pseudo-inverse on the identifiable subspace. Those
//! directions are structural (the same for every pose), so they do not move any measured
//! point, and the covariance of the tool point at a working configuration, `C_s = J_s C J_sᵀ`,
//! does not depend on how they are handled.
//!
//! ```
//! use kinecal::forward::ForwardKinematics;
//! use kinecal::model::param::Param;
//! use kinecal::planning::information::{
//!     default_tolerance, scaled_rows, Covariance, Information, PoseRows,
//! };
//! use kinecal::planning::observability::indices;
//! use kinecal::{Frame, Joint, Robot};
//! use nalgebra::Vector3;
//!
//! let rows = [
//!     Joint::mdh_deg(0.0, 0.0, 0.0, 400.0),
//!     Joint::mdh_deg(90.0, 100.0, 0.0, 0.0),
//!     Joint::mdh_deg(0.0, 500.0, 0.0, 0.0),
//! ];
//! let robot: Robot<f64, 3> =
//!     Robot::new(Frame::identity(), rows, Vector3::new(300.0, 0.0, 0.0)).unwrap();
//!
//! // d1 and base.z move the point the same way in every pose: only their sum is identifiable.
//! let params = [Param::D(0), Param::BaseZ, Param::A(2), Param::Theta(1)];
//! let mut info: Information<f64, 4> = Information::new(params.len()).unwrap();
//! let mut fk = ForwardKinematics::new();
//! let mut g: PoseRows<f64, 4> = [[0.0; 4]; 3];
//! for k in 0..8 {
//!     let q = [0.4 * k as f64, 0.2 + 0.15 * k as f64, -0.3 * k as f64];
//!     fk.compute(&robot, &q);
//!     scaled_rows(&robot, &fk, &params, &mut g).unwrap();
//!     info.add_pose(&g).unwrap();
//! }
//! // Tracker noise 0.01 mm per coordinate.
//! let cov = Covariance::new(&info, 0.01, default_tolerance()).unwrap();
//! assert_eq!((cov.dim(), cov.rank()), (4, 3));
//!
//! // Observability indices of these 8 poses (see [`crate::planning::observability`]).
//! let o = indices(&cov, info.poses());
//! assert!(o.o2 >= 1.0 && o.o3 > 0.0);
//! ```

// `!(x > y)` is deliberate: it is also true for NaN. Index loops mirror the formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::model::param::{Param, ParamError};
use crate::num::linalg::{symmetric_eigen, LinalgError, Square};
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};

/// The 3-row Jacobian block of one pose in scaled parameters: `rows[k][j] = ∂p_k/∂x_j`.
pub type PoseRows<T, const P: usize> = [[T; P]; 3];

/// Fills `rows` with the scaled identification Jacobian of the point at the pose last computed
/// in `fk` (columns `params`, divided by [`Param::scale`] with the robot's reach: the
/// derivative with respect to the parameter in mm-equivalent units).
pub fn scaled_rows<T: Real, const N: usize, V: ValueStorage, const P: usize>(
    robot: &Robot<T, N, V>,
    fk: &ForwardKinematics<T, N>,
    params: &[Param],
    rows: &mut PoseRows<T, P>,
) -> Result<(), ParamError> {
    if params.len() > P {
        return Err(ParamError::Capacity);
    }
    let reach = robot.reach();
    for r in rows.iter_mut() {
        for v in r.iter_mut() {
            *v = T::zero();
        }
    }
    for (j, p) in params.iter().enumerate() {
        let c = fk.column(robot, *p)? / p.scale(reach);
        rows[0][j] = c.x;
        rows[1][j] = c.y;
        rows[2][j] = c.z;
    }
    Ok(())
}

/// `JᵀJ` of the poses added so far, for `n ≤ P` scaled parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Information<T: Real, const P: usize> {
    m: Square<T, P>,
    n: usize,
    poses: usize,
}

impl<T: Real, const P: usize> Information<T, P> {
    /// An empty information matrix for `n` parameters.
    pub fn new(n: usize) -> Result<Self, LinalgError> {
        if n > P {
            return Err(LinalgError::Size);
        }
        Ok(Self {
            m: [[T::zero(); P]; P],
            n,
            poses: 0,
        })
    }

    /// Number of parameters `n` (the matrix is `n × n` in the top-left of its storage).
    pub fn dim(&self) -> usize {
        self.n
    }
    /// Number of poses added (minus those removed).
    pub fn poses(&self) -> usize {
        self.poses
    }
    /// The accumulated `Σ GᵀG`; only the top-left `dim() × dim()` block is used.
    pub fn matrix(&self) -> &Square<T, P> {
        &self.m
    }

    /// Adds one pose: the rank-3 update `M ← M + GᵀG`. Non-finite rows are refused.
    pub fn add_pose(&mut self, g: &PoseRows<T, P>) -> Result<(), LinalgError> {
        self.update(g, T::one())?;
        self.poses += 1;
        Ok(())
    }

    /// Removes a pose added before: `M ← M − GᵀG` (used by exchange algorithms).
    pub fn remove_pose(&mut self, g: &PoseRows<T, P>) -> Result<(), LinalgError> {
        self.update(g, -T::one())?;
        self.poses = self.poses.saturating_sub(1);
        Ok(())
    }

    fn update(&mut self, g: &PoseRows<T, P>, sign: T) -> Result<(), LinalgError> {
        let n = self.n;
        if g.iter().any(|r| r.iter().take(n).any(|v| !v.finite())) {
            return Err(LinalgError::Size);
        }
        for i in 0..n {
            let (a, b, c) = (g[0][i] * sign, g[1][i] * sign, g[2][i] * sign);
            for j in 0..=i {
                let v = a * g[0][j] + b * g[1][j] + c * g[2][j];
                self.m[i][j] += v;
            }
        }
        for i in 0..n {
            for j in i + 1..n {
                self.m[i][j] = self.m[j][i];
            }
        }
        Ok(())
    }

    /// Clears to no poses.
    pub fn clear(&mut self) {
        self.m = [[T::zero(); P]; P];
        self.poses = 0;
    }
}

/// Default relative eigenvalue threshold below which a direction counts as unidentifiable:
/// 1e-10 in `f64`, 1.2e-5 in `f32`. Structural null directions come out at rounding level
/// (~1e-16·λmax in `f64`, ~1e-7·λmax in `f32`); the weakest genuine direction of a tracker
/// pool is around 1e-4·λmax.
pub fn default_tolerance<T: Real>() -> T {
    (T::EPS * T::of(100.0)).max(T::of(1e-10))
}

/// The eigen-decomposition of an information matrix, split into the identifiable subspace
/// (eigenvalues above `tol·λmax`) and the rest; from it the pseudo-inverse covariance.
#[derive(Clone, Debug, PartialEq)]
pub struct Covariance<T: Real, const P: usize> {
    /// Eigenvalues of `JᵀJ`, ascending.
    values: [T; P],
    /// Eigenvectors (columns), same order.
    vectors: Square<T, P>,
    n: usize,
    rank: usize,
    sigma2: T,
}

impl<T: Real, const P: usize> Covariance<T, P> {
    /// Decomposes `info` (destroyed copy) for noise `sigma` (mm per coordinate).
    pub fn new(info: &Information<T, P>, sigma: T, tol: T) -> Result<Self, LinalgError> {
        Self::from_matrix(info.matrix(), info.dim(), sigma, tol)
    }

    /// The same from a raw symmetric matrix (leading `n × n` block).
    pub fn from_matrix(m: &Square<T, P>, n: usize, sigma: T, tol: T) -> Result<Self, LinalgError> {
        if n > P {
            return Err(LinalgError::Size);
        }
        if !(sigma.finite() && tol.finite())
            || m.iter()
                .take(n)
                .any(|r| r.iter().take(n).any(|v| !v.finite()))
        {
            return Err(LinalgError::NotPositiveDefinite);
        }
        let mut a = *m;
        let mut values = [T::zero(); P];
        let mut vectors = [[T::zero(); P]; P];
        symmetric_eigen(&mut a, n, &mut values, &mut vectors)?;
        let max = if n > 0 { values[n - 1] } else { T::zero() };
        let limit = tol * max;
        let rank = if max > T::zero() {
            values.iter().take(n).filter(|v| **v > limit).count()
        } else {
            0
        };
        Ok(Self {
            values,
            vectors,
            n,
            rank,
            sigma2: sigma * sigma,
        })
    }

    /// Number of identifiable directions.
    pub fn rank(&self) -> usize {
        self.rank
    }
    /// Number of parameters.
    pub fn dim(&self) -> usize {
        self.n
    }
    /// The eigenvalues of `JᵀJ` on the identifiable subspace, ascending (`σ_i²` of `J`).
    pub fn identifiable_eigenvalues(&self) -> &[T] {
        &self.values[self.n - self.rank..self.n]
    }
    /// Noise variance σ² (mm²).
    pub fn sigma2(&self) -> T {
        self.sigma2
    }
    /// Eigenvector `k` of the identifiable subspace (`k < rank`, weakest first), or `None`.
    pub fn direction(&self, k: usize) -> Option<impl Iterator<Item = T> + '_> {
        if k >= self.rank {
            return None;
        }
        let c = self.n - self.rank + k;
        Some(self.vectors.iter().take(self.n).map(move |r| r[c]))
    }

    /// `C = σ²·(JᵀJ)⁺` into `out` (leading `n × n`).
    pub fn matrix(&self, out: &mut Square<T, P>) {
        for r in out.iter_mut().take(self.n) {
            for v in r.iter_mut().take(self.n) {
                *v = T::zero();
            }
        }
        for k in self.n - self.rank..self.n {
            let w = self.sigma2 / self.values[k];
            for i in 0..self.n {
                let vi = self.vectors[i][k] * w;
                for j in 0..self.n {
                    out[i][j] += vi * self.vectors[j][k];
                }
            }
        }
    }

    /// Covariance (mm²) of the tool point at a working configuration whose scaled Jacobian is
    /// `js`: `C_s = J_s C J_sᵀ`.
    pub fn tool_covariance(&self, js: &PoseRows<T, P>) -> [[T; 3]; 3] {
        let mut out = [[T::zero(); 3]; 3];
        for k in self.n - self.rank..self.n {
            let w = self.sigma2 / self.values[k];
            let mut proj = [T::zero(); 3];
            for (pr, row) in proj.iter_mut().zip(js.iter()) {
                for i in 0..self.n {
                    *pr += row[i] * self.vectors[i][k];
                }
            }
            for a in 0..3 {
                for b in 0..3 {
                    out[a][b] += w * proj[a] * proj[b];
                }
            }
        }
        out
    }

    /// Trace of [`Covariance::tool_covariance`] (mm²): the expected squared tool-point error.
    pub fn tool_variance(&self, js: &PoseRows<T, P>) -> T {
        let c = self.tool_covariance(js);
        c[0][0] + c[1][1] + c[2][2]
    }
}
