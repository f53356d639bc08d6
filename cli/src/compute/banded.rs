//! The Cholesky factor of a symmetric positive-definite band matrix and its solves.
//!
//! A correction table's knots touch only their neighbours: the two knots around a reading
//! share its rows, and the smoothness penalty couples a knot with the two on either side. So
//! a table candidate's `m × m` block of the normal matrix has half-bandwidth 2, and its factor
//! costs `O(m)` where a dense one costs `m³/3` (the discrepancy screen's tables have up to
//! several hundred knots).

use nalgebra::{DMatrix, DVector};

/// A symmetric `m × m` matrix zero beyond its half-bandwidth, stored as its lower band:
/// `O(m)` memory and work where a dense one takes `m²` (a table with hundreds of knots).
#[derive(Clone, Debug, PartialEq)]
pub struct SymmetricBand {
    m: usize,
    band: usize,
    /// `D[i][i − k]` at `v[i * (band + 1) + k]`, `k = 0 … band` (zero where `i < k`).
    v: Vec<f64>,
}

impl SymmetricBand {
    /// The `m × m` zero matrix of half-bandwidth `band`.
    pub fn zeros(m: usize, band: usize) -> Self {
        Self {
            m,
            band,
            v: vec![0.0; m * (band + 1)],
        }
    }

    /// Rows (and columns).
    pub fn len(&self) -> usize {
        self.m
    }

    /// Whether it has no rows.
    pub fn is_empty(&self) -> bool {
        self.m == 0
    }

    /// `D[i][j]` (and `D[j][i]`) `+= x`, for `j ≤ i ≤ j + band`.
    ///
    /// # Panics
    /// When the entry lies outside the lower band (a caller's mistake).
    pub fn add_lower(&mut self, i: usize, j: usize, x: f64) {
        assert!(
            j <= i && i - j <= self.band && i < self.m,
            "({i}, {j}) outside the band"
        );
        self.v[i * (self.band + 1) + (i - j)] += x;
    }

    /// `D[i][j]` (zero beyond the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = (i.max(j), i.min(j));
        if i - j > self.band || i >= self.m {
            0.0
        } else {
            self.v[i * (self.band + 1) + (i - j)]
        }
    }

    /// The diagonal.
    pub fn diagonal(&self) -> DVector<f64> {
        DVector::from_fn(self.m, |i, _| self.v[i * (self.band + 1)])
    }

    /// Replaces each diagonal element `D[i][i]` by `f(i, D[i][i])`.
    pub fn update_diagonal(&mut self, mut f: impl FnMut(usize, f64) -> f64) {
        for i in 0..self.m {
            let d = &mut self.v[i * (self.band + 1)];
            *d = f(i, *d);
        }
    }

    /// `self += other` (same shape).
    pub fn add_assign(&mut self, other: &Self) {
        debug_assert_eq!((self.m, self.band), (other.m, other.band));
        for (a, b) in self.v.iter_mut().zip(&other.v) {
            *a += b;
        }
    }

    /// `self − other` (same shape).
    pub fn minus(&self, other: &Self) -> Self {
        debug_assert_eq!((self.m, self.band), (other.m, other.band));
        let v = self.v.iter().zip(&other.v).map(|(a, b)| a - b).collect();
        Self { v, ..*self }
    }

    /// `D x`, each row's band in increasing column order (as a dense product adds it).
    pub fn mul_vector(&self, x: &DVector<f64>) -> DVector<f64> {
        DVector::from_fn(self.m, |i, _| {
            let lo = i.saturating_sub(self.band);
            let hi = (i + self.band + 1).min(self.m);
            (lo..hi).map(|j| self.get(i, j) * x[j]).sum()
        })
    }

    /// The dense matrix.
    pub fn to_dense(&self) -> DMatrix<f64> {
        DMatrix::from_fn(self.m, self.m, |i, j| self.get(i, j))
    }
}

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
        Self::of_entries(d.nrows(), band, |i, j| d[(i, j)])
    }

    /// Factors the symmetric band matrix `d` with its own half-bandwidth.
    pub fn of_band(d: &SymmetricBand) -> Option<Self> {
        Self::of_entries(d.len(), d.band, |i, j| d.get(i, j))
    }

    /// Factors the `m × m` matrix whose lower band's entry `(i, j)` is `entry(i, j)`.
    fn of_entries(m: usize, band: usize, entry: impl Fn(usize, usize) -> f64) -> Option<Self> {
        let w = band + 1;
        let mut r = vec![0.0; m * w];
        for i in 0..m {
            // Off-diagonal entries R[i][j], j = i − band … i − 1, left to right.
            for j in i.saturating_sub(band)..i {
                let mut s = entry(i, j);
                // Σ_l R[i][l] R[j][l] over the columns both rows reach.
                for l in i.saturating_sub(band)..j {
                    s -= r[i * w + (i - l)] * r[j * w + (j - l)];
                }
                r[i * w + (i - j)] = s / r[j * w];
            }
            let mut s = entry(i, i);
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
