//! The Cholesky factor of a symmetric positive-definite band matrix and its solves.
//!
//! A correction table's knots touch only their neighbours: the two knots around a reading
//! share its rows, and the smoothness penalty couples a knot with the two on either side. So
//! a table candidate's `m × m` block of the normal matrix has half-bandwidth 2, and its factor
//! costs `O(m)` where a dense one costs `m³/3` (the discrepancy screen's tables have up to
//! several hundred knots).

use nalgebra::{DMatrix, DVector};

/// `R` of `D = R Rᵀ`, `R` lower triangular with the half-bandwidth of `D`.
#[derive(Clone, Debug)]
pub struct BandedFactor {
    /// Half-bandwidth: `D[i][j] = 0` for `|i − j| > band`.
    band: usize,
    /// `R[i][i − k]` at `r[i * (band + 1) + k]`, `k = 0 … band` (zero where `i < k`).
    r: Vec<f64>,
}

/// Whether the lower triangle of the square `d` is zero below its `band` lowest diagonals.
pub fn is_banded(d: &DMatrix<f64>, band: usize) -> bool {
    let m = d.nrows();
    (0..m).all(|j| ((j + band + 1)..m).all(|i| d[(i, j)] == 0.0))
}

impl BandedFactor {
    /// Factors the lower band of the square `d` (its entries beyond the band are not read:
    /// see [`is_banded`]). `None` when `d` is not positive definite (or not finite).
    pub fn new(d: &DMatrix<f64>, band: usize) -> Option<Self> {
        let m = d.nrows();
        let w = band + 1;
        let mut r = vec![0.0; m * w];
        for i in 0..m {
            // Off-diagonal entries R[i][j], j = i − band … i − 1, left to right.
            for j in i.saturating_sub(band)..i {
                let mut s = d[(i, j)];
                // Σ_l R[i][l] R[j][l] over the columns both rows reach.
                for l in i.saturating_sub(band)..j {
                    s -= r[i * w + (i - l)] * r[j * w + (j - l)];
                }
                r[i * w + (i - j)] = s / r[j * w];
            }
            let mut s = d[(i, i)];
            for l in i.saturating_sub(band)..i {
                s -= r[i * w + (i - l)] * r[i * w + (i - l)];
            }
            if !(s > 0.0 && s.is_finite()) {
                return None;
            }
            r[i * w] = s.sqrt();
        }
        Some(Self { band, r })
    }

    fn at(&self, i: usize, k: usize) -> f64 {
        self.r[i * (self.band + 1) + k]
    }

    /// Solves `X Rᵀ = B` in place (`x` holds `B` on entry, `X = B R⁻ᵀ` on return): column `i`
    /// of `X` from column `i` of `B` and the `band` columns before it.
    pub fn solve_right_transposed(&self, x: &mut DMatrix<f64>) {
        let m = x.ncols();
        for i in 0..m {
            for k in 1..=self.band.min(i) {
                let rik = self.at(i, k);
                let (done, mut col) = x.columns_range_pair_mut(i - k, i);
                col.axpy(-rik, &done.column(0), 1.0);
            }
            let d = self.at(i, 0);
            x.column_mut(i).unscale_mut(d);
        }
    }

    /// Solves `R y = v` in place.
    pub fn solve_lower(&self, v: &mut DVector<f64>) {
        for i in 0..v.len() {
            let mut s = v[i];
            for k in 1..=self.band.min(i) {
                s -= self.at(i, k) * v[i - k];
            }
            v[i] = s / self.at(i, 0);
        }
    }

    /// Solves `Rᵀ y = v` in place.
    pub fn solve_upper(&self, v: &mut DVector<f64>) {
        let m = v.len();
        for i in (0..m).rev() {
            let mut s = v[i];
            for k in 1..=self.band.min(m - 1 - i) {
                s -= self.at(i + k, k) * v[i + k];
            }
            v[i] = s / self.at(i, 0);
        }
    }
}
