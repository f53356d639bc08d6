//! Dense symmetric linear algebra on fixed-capacity storage `[[T; P]; P]` with `n ≤ P` in use.
//!
//! Normal equations of identification and information matrices of measurement planning are
//! symmetric positive (semi)definite; these routines are all they need, without allocation.
//! Every routine checks `n ≤ P` and returns an error rather than indexing out of range.

use crate::Real;

/// A linear-algebra failure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinalgError {
    /// The matrix is not (numerically) positive definite.
    NotPositiveDefinite,
    /// `n` exceeds the capacity or a slice is too short.
    Size,
}

/// Square matrix storage with capacity `P`.
pub type Square<T, const P: usize> = [[T; P]; P];

/// Cholesky factorisation `A = L·Lᵀ` of the leading `n × n` block, in place (lower triangle
/// holds L; the upper triangle is left as it was).
pub fn cholesky<T: Real, const P: usize>(
    a: &mut Square<T, P>,
    n: usize,
) -> Result<(), LinalgError> {
    if n > P {
        return Err(LinalgError::Size);
    }
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if !(d > T::zero()) || !d.finite() {
            return Err(LinalgError::NotPositiveDefinite);
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s / d;
        }
    }
    Ok(())
}

/// Solves `L·Lᵀ·x = b` in place with the factor from [`cholesky`].
pub fn cholesky_solve<T: Real, const P: usize>(
    l: &Square<T, P>,
    n: usize,
    b: &mut [T],
) -> Result<(), LinalgError> {
    if n > P || b.len() < n {
        return Err(LinalgError::Size);
    }
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * b[k];
        }
        b[i] = s / l[i][i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k][i] * b[k];
        }
        b[i] = s / l[i][i];
    }
    Ok(())
}

/// Rank-revealing Cholesky with diagonal pivoting of a positive semidefinite `A` (leading
/// `n × n` block, destroyed). `order` receives the pivot order: its first `rank` entries index
/// columns that are linearly independent to the relative tolerance `tol` (a pivot is accepted
/// while it exceeds `tol` times the largest original diagonal); the rest are the dependent
/// ones, the directions the data cannot determine. Returns the rank.
pub fn pivoted_cholesky<T: Real, const P: usize>(
    a: &mut Square<T, P>,
    n: usize,
    order: &mut [usize],
    tol: T,
) -> Result<usize, LinalgError> {
    pivoted_cholesky_preferring(a, n, order, tol, &[], tol)
}

/// [`pivoted_cholesky`] that takes the columns marked in `preferred` (indexed like `A`; missing
/// entries count as not preferred) as pivots first, while their pivots pass `tol`, and only
/// then the others, which must pass `tol_other`. Re-deciding identifiability with the
/// parameters estimated so far preferred keeps a confounded pair (theta6 vs the tool point)
/// from swapping at every call: a column joins only when it adds a direction the preferred
/// ones do not span, by the margin `tol_other`.
pub fn pivoted_cholesky_preferring<T: Real, const P: usize>(
    a: &mut Square<T, P>,
    n: usize,
    order: &mut [usize],
    tol: T,
    preferred: &[bool],
    tol_other: T,
) -> Result<usize, LinalgError> {
    if n > P || order.len() < n {
        return Err(LinalgError::Size);
    }
    for (i, o) in order.iter_mut().enumerate().take(n) {
        *o = i;
    }
    let mut dmax = T::zero();
    for (i, row) in a.iter().enumerate().take(n) {
        if row[i] > dmax {
            dmax = row[i];
        }
    }
    if !(dmax > T::zero()) || !dmax.finite() {
        return Ok(0);
    }
    let limit = tol * dmax;
    let limit_other = tol_other.max(tol) * dmax;
    // Work on the permuted matrix explicitly: swap rows and columns.
    for k in 0..n {
        // Choose the largest remaining diagonal (the Schur complement's), among the preferred
        // columns first.
        let pref = |i: usize, order: &[usize]| preferred.get(order[i]).copied().unwrap_or(false);
        let mut best = None;
        for (class, limit) in [(true, limit), (false, limit_other)] {
            for i in k..n {
                if pref(i, order) == class
                    && a[i][i] > limit
                    && best.is_none_or(|b: usize| a[i][i] > a[b][b])
                {
                    best = Some(i);
                }
            }
            if best.is_some() {
                break;
            }
        }
        let Some(best) = best else {
            return Ok(k);
        };
        if best != k {
            a.swap(k, best);
            for row in a.iter_mut().take(n) {
                row.swap(k, best);
            }
            order.swap(k, best);
        }
        let d = a[k][k].sqrt();
        a[k][k] = d;
        for i in k + 1..n {
            a[i][k] /= d;
        }
        for i in k + 1..n {
            let lik = a[i][k];
            for j in k + 1..=i {
                a[i][j] -= lik * a[j][k];
            }
            // Keep the block symmetric so the next pivot search reads the diagonal only.
            for j in k + 1..i {
                a[j][i] = a[i][j];
            }
        }
    }
    Ok(n)
}

/// Eigenvalues (ascending, into `values`) and eigenvectors (columns of `vectors`) of the
/// symmetric leading `n × n` block of `a` (destroyed), by cyclic Jacobi rotations: slow for
/// large `n` but exact to rounding and robust for semidefinite information matrices.
pub fn symmetric_eigen<T: Real, const P: usize>(
    a: &mut Square<T, P>,
    n: usize,
    values: &mut [T],
    vectors: &mut Square<T, P>,
) -> Result<(), LinalgError> {
    if n > P || values.len() < n {
        return Err(LinalgError::Size);
    }
    for (i, row) in vectors.iter_mut().enumerate().take(n) {
        for (j, v) in row.iter_mut().enumerate().take(n) {
            *v = if i == j { T::one() } else { T::zero() };
        }
    }
    for _sweep in 0..64 {
        let mut off = T::zero();
        let mut diag = T::zero();
        for i in 0..n {
            diag += a[i][i] * a[i][i];
            for j in i + 1..n {
                off += a[i][j] * a[i][j];
            }
        }
        if !(off > T::EPS * T::EPS * diag) {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p][q];
                if apq == T::zero() {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (apq + apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + T::one()).sqrt());
                let t = if theta == T::zero() { T::one() } else { t };
                let c = T::one() / (t * t + T::one()).sqrt();
                let s = t * c;
                for k in 0..n {
                    let akp = a[k][p];
                    let akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let apk = a[p][k];
                    let aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for row in vectors.iter_mut().take(n) {
                    let vkp = row[p];
                    let vkq = row[q];
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
    }
    for (i, v) in values.iter_mut().enumerate().take(n) {
        *v = a[i][i];
    }
    // Sort ascending, carrying the vectors along (selection sort: n is small).
    for i in 0..n {
        let mut m = i;
        for j in i + 1..n {
            if values[j] < values[m] {
                m = j;
            }
        }
        if m != i {
            values.swap(i, m);
            for row in vectors.iter_mut().take(n) {
                row.swap(i, m);
            }
        }
    }
    Ok(())
}

/// `A = L·D·Lᵀ` of the leading `n × n` block in place: unit lower `L` below the diagonal, `D`
/// on it. No square roots, so it is the cheaper factorisation where `f32` `sqrt` is a software
/// routine (Cortex-M4F libm). Fails unless every pivot is positive (A positive definite).
pub fn ldlt<T: Real, const P: usize>(a: &mut Square<T, P>, n: usize) -> Result<(), LinalgError> {
    if n > P {
        return Err(LinalgError::Size);
    }
    // w[k] = L[j][k]·d[k], reused by every row below j: one multiply per inner step.
    let mut w = [T::zero(); P];
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            w[k] = a[j][k] * a[k][k];
            d -= a[j][k] * w[k];
        }
        if !(d > T::zero()) || !d.finite() {
            return Err(LinalgError::NotPositiveDefinite);
        }
        a[j][j] = d;
        let inv = T::one() / d;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * w[k];
            }
            a[i][j] = s * inv;
        }
    }
    Ok(())
}

/// Solves `L·D·Lᵀ·x = b` in place with the factor from [`ldlt`].
pub fn ldlt_solve<T: Real, const P: usize>(
    l: &Square<T, P>,
    n: usize,
    b: &mut [T],
) -> Result<(), LinalgError> {
    if n > P || b.len() < n {
        return Err(LinalgError::Size);
    }
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * b[k];
        }
        b[i] = s;
    }
    for i in 0..n {
        b[i] /= l[i][i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k][i] * b[k];
        }
        b[i] = s;
    }
    Ok(())
}

/// `trace(A⁻¹)` from the factor of [`ldlt`]: `Σ_i Σ_k (L⁻¹)_{ki}² / d_k`.
pub fn ldlt_trace_inverse<T: Real, const P: usize>(
    l: &Square<T, P>,
    n: usize,
) -> Result<T, LinalgError> {
    if n > P {
        return Err(LinalgError::Size);
    }
    let mut inv_d = [T::zero(); P];
    for (k, v) in inv_d.iter_mut().enumerate().take(n) {
        *v = T::one() / l[k][k];
    }
    let mut tr = T::zero();
    let mut y = [T::zero(); P];
    for i in 0..n {
        // y = L⁻¹ e_i: zero above i, one at i, forward substitution below.
        y[i] = T::one();
        tr += inv_d[i];
        for k in i + 1..n {
            let mut s = T::zero();
            for m in i..k {
                s -= l[k][m] * y[m];
            }
            y[k] = s;
            tr += s * s * inv_d[k];
        }
    }
    Ok(tr)
}
