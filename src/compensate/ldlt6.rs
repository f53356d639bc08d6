//! Symmetric 6 × 6 systems as packed lower triangles: LDLᵀ, solve and trace of the inverse.

use super::finite::finite;
use crate::Real;

// The symmetric systems of the Newton steps and of the conditioning have order 1–3 or 6. All
// are solved as order 6, a smaller one padded with the identity (zero off-diagonal, one on the
// diagonal, zero right-hand side): the padding factors and solves exactly (pivots 1, zero
// multipliers), so the results are those of the unpadded system, while one straight-line 6 × 6
// routine serves every size: `L·D·Lᵀ` without square roots, the cheaper factorisation where
// `f32` `sqrt` is a software routine (Cortex-M4F libm).

/// Entries of a packed lower triangle of order 6.
pub(super) const TRI: usize = 21;
/// Symmetric 6 × 6 matrix as its packed lower triangle: `(i, k)`, `k ≤ i`, at [`ix`].
pub(super) type Tri<T> = [T; TRI];

#[inline(always)]
pub(super) const fn ix(i: usize, k: usize) -> usize {
    i * (i + 1) / 2 + k
}

/// `A = L·D·Lᵀ` in place (unit `L` below the diagonal, `D` on it); false unless every pivot
/// is positive and finite.
#[inline(never)]
pub(super) fn ldlt6<T: Real>(a: &mut Tri<T>) -> bool {
    // w[k] = L[j][k]·d[k], reused by every row below j.
    let mut w = [T::zero(); 6];
    for_0_to_5!(j => {
        let mut d = a[ix(j, j)];
        for k in 0..j {
            w[k] = a[ix(j, k)] * a[ix(k, k)];
            d -= a[ix(j, k)] * w[k];
        }
        if !(d > T::zero() && finite(d)) {
            return false;
        }
        a[ix(j, j)] = d;
        let inv = T::one() / d;
        for i in j + 1..6 {
            let mut s = a[ix(i, j)];
            for k in 0..j {
                s -= a[ix(i, k)] * w[k];
            }
            a[ix(i, j)] = s * inv;
        }
    });
    true
}

/// Solves `A·x = b` in place by LDLᵀ; false if `A` is not positive definite.
#[inline(never)]
pub(super) fn solve6<T: Real>(a: &mut Tri<T>, b: &mut [T; 6]) -> bool {
    if !ldlt6(a) {
        return false;
    }
    for_0_to_5!(i => {
        let mut s = b[i];
        for k in 0..i {
            s -= a[ix(i, k)] * b[k];
        }
        b[i] = s;
    });
    for i in 0..6 {
        b[i] /= a[ix(i, i)];
    }
    for_0_to_5!(r => {
        let i = 5 - r;
        let mut s = b[i];
        for k in i + 1..6 {
            s -= a[ix(k, i)] * b[k];
        }
        b[i] = s;
    });
    true
}

/// `trace(A⁻¹)` of the leading `n × n` block from the factor of [`ldlt6`]:
/// `Σ_i Σ_k (L⁻¹)_{ki}² / d_k` (the padding past `n` adds exact zeros).
pub(super) fn trace_inverse6<T: Real>(l: &Tri<T>, n: usize) -> T {
    let mut inv_d = [T::zero(); 6];
    for k in 0..6 {
        inv_d[k] = T::one() / l[ix(k, k)];
    }
    let mut tr = T::zero();
    let mut y = [T::zero(); 6];
    for_0_to_5!(i => {
        if i < n {
            // y = L⁻¹ e_i: zero above i, one at i, forward substitution below.
            y[i] = T::one();
            tr += inv_d[i];
            for k in i + 1..6 {
                let mut s = T::zero();
                for m in i..k {
                    s -= l[ix(k, m)] * y[m];
                }
                y[k] = s;
                tr += s * s * inv_d[k];
            }
        }
    });
    tr
}
