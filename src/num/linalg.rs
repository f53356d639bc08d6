//! Dense symmetric linear algebra on fixed-capacity storage `[[T; P]; P]` with `n ≤ P` in use,
//! or (the factorisations the identification needs) on a caller's flat buffer ([`Flat`]).
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

/// Square matrix storage the factorisations work on: a fixed array ([`Square`]) or a view of a
/// caller's flat buffer ([`Flat`]), so that the solver of a 600-parameter model needs no
/// megabyte-sized value, while the 6 × 6 solves of compensation keep their fixed arrays.
pub trait SquareStorage<T: Real> {
    /// Rows (and columns) the storage holds.
    fn capacity(&self) -> usize;
    /// Element `(i, j)`; both below [`SquareStorage::capacity`].
    fn at(&self, i: usize, j: usize) -> T;
    /// Element `(i, j)` for writing.
    fn at_mut(&mut self, i: usize, j: usize) -> &mut T;
}

impl<T: Real, const P: usize> SquareStorage<T> for Square<T, P> {
    #[inline(always)]
    fn capacity(&self) -> usize {
        P
    }
    #[inline(always)]
    fn at(&self, i: usize, j: usize) -> T {
        self[i][j]
    }
    #[inline(always)]
    fn at_mut(&mut self, i: usize, j: usize) -> &mut T {
        &mut self[i][j]
    }
}

/// An `n × n` row-major matrix in a caller's buffer.
#[derive(Debug)]
pub struct Flat<'a, T> {
    data: &'a mut [T],
    n: usize,
}

impl<'a, T: Real> Flat<'a, T> {
    /// The leading `n²` values of `data` as an `n × n` matrix (fails when `data` is shorter).
    pub fn new(data: &'a mut [T], n: usize) -> Result<Self, LinalgError> {
        let len = n.checked_mul(n).ok_or(LinalgError::Size)?;
        let data = data.get_mut(..len).ok_or(LinalgError::Size)?;
        Ok(Self { data, n })
    }
    /// Row `i` (empty when out of range).
    pub fn row(&self, i: usize) -> &[T] {
        self.data.get(i * self.n..(i + 1) * self.n).unwrap_or(&[])
    }
}

impl<T: Real> SquareStorage<T> for Flat<'_, T> {
    #[inline(always)]
    fn capacity(&self) -> usize {
        self.n
    }
    #[inline(always)]
    fn at(&self, i: usize, j: usize) -> T {
        self.data[i * self.n + j]
    }
    #[inline(always)]
    fn at_mut(&mut self, i: usize, j: usize) -> &mut T {
        &mut self.data[i * self.n + j]
    }
}

/// Cholesky factorisation `A = L·Lᵀ` of the leading `n × n` block, in place (lower triangle
/// holds L; the upper triangle is left as it was).
pub fn cholesky<T: Real, M: SquareStorage<T> + ?Sized>(
    a: &mut M,
    n: usize,
) -> Result<(), LinalgError> {
    if n > a.capacity() {
        return Err(LinalgError::Size);
    }
    for j in 0..n {
        let mut d = a.at(j, j);
        for k in 0..j {
            d -= a.at(j, k) * a.at(j, k);
        }
        if !(d > T::zero()) || !d.finite() {
            return Err(LinalgError::NotPositiveDefinite);
        }
        let d = d.sqrt();
        *a.at_mut(j, j) = d;
        for i in j + 1..n {
            let mut s = a.at(i, j);
            for k in 0..j {
                s -= a.at(i, k) * a.at(j, k);
            }
            *a.at_mut(i, j) = s / d;
        }
    }
    Ok(())
}

/// Solves `L·Lᵀ·x = b` in place with the factor from [`cholesky`].
pub fn cholesky_solve<T: Real, M: SquareStorage<T> + ?Sized>(
    l: &M,
    n: usize,
    b: &mut [T],
) -> Result<(), LinalgError> {
    if n > l.capacity() || b.len() < n {
        return Err(LinalgError::Size);
    }
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l.at(i, k) * b[k];
        }
        b[i] = s / l.at(i, i);
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l.at(k, i) * b[k];
        }
        b[i] = s / l.at(i, i);
    }
    Ok(())
}

/// Rank-revealing Cholesky with diagonal pivoting of a positive semidefinite `A` (leading
/// `n × n` block, destroyed). `order` receives the pivot order: its first `rank` entries index
/// columns that are linearly independent to the relative tolerance `tol` (a pivot is accepted
/// while it exceeds `tol` times the largest original diagonal); the rest are the dependent
/// ones, the directions the data cannot determine. Returns the rank.
pub fn pivoted_cholesky<T: Real, M: SquareStorage<T> + ?Sized>(
    a: &mut M,
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
pub fn pivoted_cholesky_preferring<T: Real, M: SquareStorage<T> + ?Sized>(
    a: &mut M,
    n: usize,
    order: &mut [usize],
    tol: T,
    preferred: &[bool],
    tol_other: T,
) -> Result<usize, LinalgError> {
    if n > a.capacity() || order.len() < n {
        return Err(LinalgError::Size);
    }
    for (i, o) in order.iter_mut().enumerate().take(n) {
        *o = i;
    }
    let mut dmax = T::zero();
    for i in 0..n {
        if a.at(i, i) > dmax {
            dmax = a.at(i, i);
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
                    && a.at(i, i) > limit
                    && best.is_none_or(|b: usize| a.at(i, i) > a.at(b, b))
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
            for j in 0..n {
                let (x, y) = (a.at(k, j), a.at(best, j));
                *a.at_mut(k, j) = y;
                *a.at_mut(best, j) = x;
            }
            for i in 0..n {
                let (x, y) = (a.at(i, k), a.at(i, best));
                *a.at_mut(i, k) = y;
                *a.at_mut(i, best) = x;
            }
            order.swap(k, best);
        }
        let d = a.at(k, k).sqrt();
        *a.at_mut(k, k) = d;
        for i in k + 1..n {
            *a.at_mut(i, k) /= d;
        }
        for i in k + 1..n {
            let lik = a.at(i, k);
            for j in k + 1..=i {
                let v = a.at(i, j) - lik * a.at(j, k);
                *a.at_mut(i, j) = v;
            }
            // Keep the block symmetric so the next pivot search reads the diagonal only.
            for j in k + 1..i {
                *a.at_mut(j, i) = a.at(i, j);
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
