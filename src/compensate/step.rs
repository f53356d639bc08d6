//! One damped least-squares step inside the box, the systems it solves, and the conditioning
//! and limit tests that classify a failure.

use super::evaluate::{dot, Eval};
use super::finite::{all_finite, finite};
use super::ldlt6::{ix, ldlt6, solve6, trace_inverse6, Tri, TRI};
use crate::Real;

/// One damped step from `e.q`, with the joints whose step would leave the box at a bound
/// frozen (a small active-set loop), so a limited joint does not spoil the others' step.
pub(super) fn constrained_step<T: Real, const N: usize>(
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    seed: &[T; N],
    lo: &[T; N],
    hi: &[T; N],
) -> Option<[T; N]> {
    let mut free = [true; N];
    let mut dq = [T::zero(); N];
    for _pass in 0..=N {
        dq = damped_step(e, m, lambda2, seed, &free)?;
        let mut changed = false;
        for j in 0..N {
            let x = e.q[j] + dq[j];
            if free[j] && ((x > hi[j] && e.q[j] >= hi[j]) || (x < lo[j] && e.q[j] <= lo[j])) {
                free[j] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    Some(dq)
}

/// The damped least-squares step over the free joints. With at most as many joints as
/// equations: `(JᵀJ + λ²I)·dq = Jᵀr`. With more joints: the minimum-norm change from the seed,
/// `dq = d + Jᵀ(JJᵀ + λ²I)⁻¹(r − J·d)` with `d = seed − q`. `None` if the solve failed.
pub(super) fn damped_step<T: Real, const N: usize>(
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    seed: &[T; N],
    free: &[bool; N],
) -> Option<[T; N]> {
    let mut dq = [T::zero(); N];
    if N <= m {
        let (mut a, mut b) = ([T::zero(); TRI], [T::zero(); 6]);
        joint_system(&mut a, &mut b, e, m, lambda2, Some(free));
        if !solve6(&mut a, &mut b) {
            return None;
        }
        dq.copy_from_slice(&b[..N]);
    } else {
        let mut d = [T::zero(); N];
        for j in 0..N {
            if free[j] {
                d[j] = seed[j] - e.q[j];
            }
        }
        let (mut a, mut b) = ([T::zero(); TRI], e.r);
        task_system(&mut a, &mut b, e, m, lambda2, &d, free);
        if !solve6(&mut a, &mut b) {
            return None;
        }
        for j in (0..N).filter(|j| free[*j]) {
            dq[j] = d[j] + dot(&e.cols[j], &b, m);
        }
    }
    if all_finite(&dq) {
        Some(dq)
    } else {
        None
    }
}

/// Rows of the Jacobian when the joints are at most as many (`N ≤ m`): more than three joints
/// there means a pose target, so the servo loop's six joints fold `m` to the constant 6.
#[inline(always)]
pub(super) fn rows_square<const N: usize>(m: usize) -> usize {
    if N > 3 {
        6
    } else {
        m
    }
}

/// `JᵀJ + λ²I` over the joints (`N ≤ m`) and, when `free` is given, `Jᵀr`, with the frozen
/// joints' rows and columns replaced by the identity's: order `N`, padded to 6 (see [`Tri`]).
pub(super) fn joint_system<T: Real, const N: usize>(
    a: &mut Tri<T>,
    b: &mut [T; 6],
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    free: Option<&[bool; N]>,
) {
    let m = rows_square::<N>(m);
    for_0_to_5!(i => {
        if i < N {
            let c = &e.cols[i];
            for k in 0..i {
                a[ix(i, k)] = dot(c, &e.cols[k], m);
            }
            a[ix(i, i)] = dot(c, c, m) + lambda2;
            if free.is_some() {
                b[i] = dot(c, &e.r, m);
            }
        }
    });
    for i in N..6 {
        a[ix(i, i)] = T::one();
    }
    if let Some(free) = free {
        if free.iter().any(|f| !f) {
            freeze(a, b, free);
        }
    }
}

/// Replaces the rows and columns of the joints not `free` by the identity's (rare: a joint
/// at a bound of the step box).
#[inline(never)]
pub(super) fn freeze<T: Real>(a: &mut Tri<T>, b: &mut [T; 6], free: &[bool]) {
    for (i, f) in free.iter().enumerate() {
        if !f {
            for k in 0..6 {
                a[if k < i { ix(i, k) } else { ix(k, i) }] = T::zero();
            }
            a[ix(i, i)] = T::one();
            b[i] = T::zero();
        }
    }
}

/// `JJᵀ + λ²I` over the free joints (`N > m`) into `a` (zero on entry) and `b −= J·d` (`b`
/// holds `r` on entry): order `m`, padded to 6.
#[inline(never)]
pub(super) fn task_system<T: Real, const N: usize>(
    a: &mut Tri<T>,
    b: &mut [T; 6],
    e: &Eval<T, N>,
    m: usize,
    lambda2: T,
    d: &[T; N],
    free: &[bool; N],
) {
    for j in (0..N).filter(|j| free[*j]) {
        let c = &e.cols[j];
        for i in 0..m {
            b[i] -= c[i] * d[j];
            for k in 0..=i {
                a[ix(i, k)] += c[i] * c[k];
            }
        }
    }
    for i in 0..6 {
        a[ix(i, i)] += if i < m { lambda2 } else { T::one() };
    }
}

/// σ_h = (trace((Gram)⁻¹))^(-1/2) of the scaled Jacobian (0 when the Gram matrix is singular):
/// within a factor √m of the smallest singular value, from one small LDLᵀ.
pub(super) fn conditioning<T: Real, const N: usize>(e: &Eval<T, N>, m: usize) -> T {
    let (mut a, mut b) = ([T::zero(); TRI], [T::zero(); 6]);
    let n = if N <= m {
        joint_system(&mut a, &mut b, e, m, T::zero(), None);
        N
    } else {
        task_system(&mut a, &mut b, e, m, T::zero(), &[T::zero(); N], &[true; N]);
        m
    };
    harmonic(&mut a, n)
}

/// `trace(A⁻¹)^(-1/2)` of a symmetric positive definite `A` of order `n` (see [`Tri`]), 0 if
/// not definite. LDLᵀ, not Cholesky: no square roots but the last one (`f32` `sqrt` is a
/// software routine on a Cortex-M4F).
pub(super) fn harmonic<T: Real>(a: &mut Tri<T>, n: usize) -> T {
    if n == 0 || !ldlt6(a) {
        return T::zero();
    }
    let tr = trace_inverse6(a, n);
    let s = T::one() / tr.sqrt();
    if finite(s) {
        s
    } else {
        T::zero()
    }
}

/// True when some joint sits at a bound of the box and the residual's descent direction `Jᵀr`
/// pushes it outward: the bound, not the model, stops the residual from shrinking.
pub(super) fn blocked<T: Real, const N: usize>(
    e: &Eval<T, N>,
    m: usize,
    lo: &[T; N],
    hi: &[T; N],
) -> bool {
    let mut g = [T::zero(); N];
    let mut gmax = T::zero();
    for (gj, c) in g.iter_mut().zip(e.cols.iter()) {
        *gj = dot(c, &e.r, m);
        if gj.abs() > gmax {
            gmax = gj.abs();
        }
    }
    let tiny = gmax * T::of(1e-3);
    (0..N).any(|j| (e.q[j] >= hi[j] && g[j] > tiny) || (e.q[j] <= lo[j] && g[j] < -tiny))
}
