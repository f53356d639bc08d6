//! Dense factorisations and solves of the discrepancy search, arranged as matrix products.
//!
//! nalgebra's Cholesky factorisation and triangular solves work column by column (vector
//! operations). With the `p × p` normal matrices of the fits (p up to ~310) and the `p × m`
//! right-hand sides of the screen, the same arithmetic arranged by blocks of [`BLOCK`] rows,
//! where nearly everything is a matrix product (blocked, vectorised kernels), is several times
//! faster.

use nalgebra::{Cholesky, DMatrix, DMatrixView, DMatrixViewMut, Dyn};

/// Rows per block.
pub const BLOCK: usize = 32;

/// A lower-triangular factor `L` prepared for solves with many right-hand sides: the inverses
/// of its diagonal blocks are formed once (by substitution), so that a solve is matrix
/// products only.
#[derive(Clone, Debug)]
pub struct LowerFactor {
    /// `L` (only its lower triangle is read).
    l: DMatrix<f64>,
    /// The inverse of each diagonal block of `L`.
    block_inverses: Vec<DMatrix<f64>>,
}

impl LowerFactor {
    /// Prepares `l` (its strict upper triangle is ignored); `None` when a diagonal element is
    /// zero.
    pub fn new(l: DMatrix<f64>) -> Option<Self> {
        let p = l.nrows();
        let block_inverses = (0..p)
            .step_by(BLOCK)
            .map(|start| {
                let nb = BLOCK.min(p - start);
                lower_inverse(l.view((start, start), (nb, nb)))
            })
            .collect::<Option<_>>()?;
        Some(Self { l, block_inverses })
    }

    /// `L` itself (strict upper triangle unspecified).
    pub fn l(&self) -> &DMatrix<f64> {
        &self.l
    }

    /// Solves `L X = B` in place (`x` holds `B` on entry, `X` on return).
    pub fn solve_in_place(&self, x: &mut DMatrix<f64>) {
        for (b, inv) in self.block_inverses.iter().enumerate() {
            let (start, nb) = (b * BLOCK, inv.nrows());
            let (done, mut rows) = x.rows_range_pair_mut(0..start, start..start + nb);
            if start > 0 {
                rows.gemm(-1.0, &self.l.view((start, 0), (nb, start)), &done, 1.0);
            }
            let solved = inv * &rows;
            rows.copy_from(&solved);
        }
    }
}

/// The inverse of the lower-triangular `l` (its strict upper triangle is ignored), column by
/// column by forward substitution from the column's diagonal on (the rows above it are zero):
/// a sixth of `n³` multiply-adds, a third of solving for the identity's columns in full, with
/// the same operations on the rows that are not zero. `None` when a diagonal element is zero.
fn lower_inverse(l: DMatrixView<f64>) -> Option<DMatrix<f64>> {
    let n = l.nrows();
    let l = l.clone_owned();
    let columns: Vec<&[f64]> = l.as_slice().chunks_exact(n.max(1)).collect();
    let mut inv = DMatrix::identity(n, n);
    for (j, x) in inv.as_mut_slice().chunks_exact_mut(n.max(1)).enumerate() {
        for (k, lk) in columns.iter().enumerate().skip(j) {
            let diag = lk[k];
            if diag == 0.0 {
                return None;
            }
            let xk = x[k] / diag;
            x[k] = xk;
            for (xi, li) in x[k + 1..].iter_mut().zip(&lk[k + 1..]) {
                *xi -= li * xk;
            }
        }
    }
    Some(inv)
}

/// The Cholesky factor of the symmetric positive-definite `h` (only its lower triangle is
/// read) by blocks: the diagonal blocks by [`Cholesky::new`], the panels below them and the
/// updates of the trailing matrix by matrix products. `None` when `h` is not positive
/// definite.
pub fn cholesky(mut h: DMatrix<f64>) -> Option<Cholesky<f64, Dyn>> {
    let p = h.nrows();
    for start in (0..p).step_by(BLOCK) {
        let end = (start + BLOCK).min(p);
        let nb = end - start;
        let l11 = Cholesky::new(h.view((start, start), (nb, nb)).clone_owned())?.unpack_dirty();
        h.view_mut((start, start), (nb, nb)).copy_from(&l11);
        if end < p {
            // The panel `L21 = A21 L11⁻ᵀ`, i.e. `L11 L21ᵀ = A21ᵀ`.
            let mut l21t = h.view((end, start), (p - end, nb)).transpose();
            LowerFactor::new(l11)?.solve_in_place(&mut l21t);
            let l21 = l21t.transpose();
            h.view_mut((end, start), (p - end, nb)).copy_from(&l21);
            // The trailing matrix `A22 − L21 L21ᵀ` (its lower triangle).
            sub_gram_lower(
                h.view_mut((end, end), (p - end, p - end)),
                l21.as_view(),
                l21t.as_view(),
            );
        }
    }
    Some(Cholesky::pack_dirty(h))
}

/// `S − A Aᵀ` into the square `s`, on and below its diagonal blocks of [`BLOCK`] columns
/// only (half the products of the whole; the rest of the upper triangle is left as it was).
/// `at` is `Aᵀ`.
pub fn sub_gram_lower(mut s: DMatrixViewMut<f64>, a: DMatrixView<f64>, at: DMatrixView<f64>) {
    let n = s.nrows();
    for j0 in (0..n).step_by(BLOCK) {
        let w = BLOCK.min(n - j0);
        s.view_mut((j0, j0), (n - j0, w))
            .gemm(-1.0, &a.rows(j0, n - j0), &at.columns(j0, w), 1.0);
    }
}

/// `H⁻¹` from the Cholesky factor `H = L Lᵀ`: `L⁻ᵀ L⁻¹`. `None` when not finite.
pub fn cholesky_inverse(chol: &Cholesky<f64, Dyn>) -> Option<DMatrix<f64>> {
    let l = chol.l_dirty();
    let mut l_inv = DMatrix::identity(l.nrows(), l.ncols());
    LowerFactor::new(l.clone())?.solve_in_place(&mut l_inv);
    let h_inv = l_inv.transpose() * &l_inv;
    h_inv.iter().all(|v| v.is_finite()).then_some(h_inv)
}
