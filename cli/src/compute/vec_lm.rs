//! The host's storage for the library's Levenberg–Marquardt solver: the arrays sized from the
//! problem (the parameter count) on the heap, so that a model with per-joint tables (600+
//! parameters, a 3 MB normal matrix) needs neither a big stack nor a worst-case capacity.

use kinecal::identify::lm::{
    add_batch_rows, add_dense_rows, LmParts, LmPartsRef, LmPenalty, LmStorage, PenaltyParts,
    PenaltyPartsRef, PenaltyTerm, LM_FLAG_VECTORS, LM_INDEX_VECTORS, LM_VECTORS,
};
use kinecal::model::param::Param;
use kinecal::num::linalg::LinalgError;
use kinecal::Real;
use nalgebra::{DMatrix, DVector};

/// From this many active parameters on, [`VecLm`] solves with the blocked factorisation of
/// [`crate::compute::dense`] (matrix products) instead of the library's row-by-row one.
pub const BLOCKED_SOLVE_MIN: usize = 96;

/// [`LmStorage`] in `Vec`s sized for exactly the parameters of the run.
#[derive(Clone, Debug)]
pub struct VecLm<T: Real> {
    params: Vec<Param>,
    jtj: Vec<T>,
    work: Vec<T>,
    vectors: Vec<T>,
    indices: Vec<usize>,
    flags: Vec<bool>,
    /// Rows a pass collects ([`LmStorage::BATCH_ROWS`]); only a pass part has room.
    batch: Vec<T>,
}

impl<T: Real> VecLm<T> {
    /// Storage for estimating `params`.
    pub fn new(params: &[Param]) -> Self {
        let n = params.len();
        Self {
            params: params.to_vec(),
            jtj: vec![T::zero(); n * n],
            work: vec![T::zero(); n * n],
            vectors: vec![T::zero(); LM_VECTORS * n],
            indices: vec![0; LM_INDEX_VECTORS * n],
            flags: vec![false; LM_FLAG_VECTORS * n],
            batch: Vec::new(),
        }
    }
}

impl<T: Real> VecLm<T> {
    /// Storage for one part of a pass over `params` ([`kinecal::identify::lm::PassPart`]): only what a
    /// pass writes (no scratch matrix), half the memory of [`VecLm::new`], and room for the
    /// rows it collects.
    pub fn for_pass(params: &[Param]) -> Self {
        let mut s = Self::new(params);
        s.work = Vec::new();
        s.batch = vec![T::zero(); Self::BATCH_ROWS * (params.len() + 1)];
        s
    }
}

/// [`add_dense_rows`] with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn add_dense_rows_avx2<T: Real>(
    sums: (&mut [T], &mut [T]),
    stride: usize,
    columns: (&[T], &[T], &[T]),
    r: [T; 3],
    rows: &[usize],
) {
    add_dense_rows(sums, stride, columns, r, rows);
}

impl<T: Real> LmStorage<T> for VecLm<T> {
    fn parts(&mut self) -> LmParts<'_, T> {
        let n = self.params.len();
        let mut v = self.vectors.chunks_exact_mut(n.max(1));
        let mut next = || v.next().unwrap_or(&mut []);
        let (jtr, step, total, scale) = (next(), next(), next(), next());
        let (analysed_diag, g, x, delta) = (next(), next(), next(), next());
        let (cx, cy, cz) = (next(), next(), next());
        let mut ix = self.indices.chunks_exact_mut(n.max(1));
        let mut next_ix = || ix.next().unwrap_or(&mut []);
        let (nz, idx, order) = (next_ix(), next_ix(), next_ix());
        let (active, rest) = self.flags.split_at_mut(n);
        let (before, held) = rest.split_at_mut(n);
        LmParts {
            params: &self.params,
            stride: n,
            jtj: &mut self.jtj,
            work: &mut self.work,
            jtr,
            step,
            total,
            scale,
            analysed_diag,
            g,
            x,
            delta,
            cx,
            cy,
            cz,
            nz,
            idx,
            order,
            active,
            before,
            held,
            batch: &mut self.batch,
        }
    }

    fn parts_ref(&self) -> LmPartsRef<'_, T> {
        let n = self.params.len();
        let v = |k: usize| self.vectors.get(k * n..(k + 1) * n).unwrap_or(&[]);
        LmPartsRef {
            params: &self.params,
            stride: n,
            jtj: &self.jtj,
            jtr: v(0),
            step: v(1),
            total: v(2),
            scale: v(3),
            analysed_diag: v(4),
            active: &self.flags[..n],
            held: self.flags.get(2 * n..3 * n).unwrap_or(&[]),
        }
    }

    /// The library's [`add_dense_rows`], compiled for AVX2 when the processor has it (the
    /// same operations in the same order, twice as many per instruction: bit-identical sums;
    /// this loop is most of an identify's time).
    fn add_rows(
        sums: (&mut [T], &mut [T]),
        stride: usize,
        columns: (&[T], &[T], &[T]),
        r: [T; 3],
        rows: &[usize],
    ) {
        #[cfg(target_arch = "x86_64")]
        if let (Some(jtj), Some(jtr), Some(cx), Some(cy), Some(cz), Some(r64)) = (
            as_f64_mut(&mut *sums.0),
            as_f64_mut(&mut *sums.1),
            as_f64(columns.0),
            as_f64(columns.1),
            as_f64(columns.2),
            as_f64(&r),
        ) {
            if crate::compute::rows_avx2::add_rows_f64(
                (jtj, jtr),
                stride,
                (cx, cy, cz),
                [r64[0], r64[1], r64[2]],
                rows,
            ) {
                return;
            }
            // (No AVX2, or rows beyond the slices: the loops below.)
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2, checked just above.
            unsafe { add_dense_rows_avx2(sums, stride, columns, r, rows) };
            return;
        }
        add_dense_rows(sums, stride, columns, r, rows);
    }

    /// Sixteen poses' rows: with `JᵀJ` (33 parameters: 8.7 KB) they stay in the first-level
    /// cache, and `JᵀJ` is loaded and stored once per sixteen poses.
    const BATCH_ROWS: usize = 48;

    /// The library's [`add_batch_rows`] as a product of matrices with AVX2 and FMA for `f64`
    /// ([`crate::compute::batch_avx2`]), else the library's loop.
    fn add_batch(sums: (&mut [T], &mut [T]), stride: usize, n: usize, rows: &[T], residuals: &[T]) {
        #[cfg(target_arch = "x86_64")]
        if let (Some(jtj), Some(jtr), Some(rows), Some(residuals)) = (
            as_f64_mut(&mut *sums.0),
            as_f64_mut(&mut *sums.1),
            as_f64(rows),
            as_f64(residuals),
        ) {
            if crate::compute::batch_avx2::add_batch_f64((jtj, jtr), stride, n, rows, residuals) {
                return;
            }
        }
        add_batch_rows(sums, stride, n, rows, residuals);
    }

    /// Large systems (the hundreds of table knots of `diagnose`'s models) by blocks, in `f64`;
    /// small ones (and `f32`) by the library's kernel.
    fn solve_work(work: &mut [T], stride: usize, x: &mut [T], m: usize) -> Result<(), LinalgError> {
        if m < BLOCKED_SOLVE_MIN || m > stride || x.len() < m || core::mem::size_of::<T>() != 8 {
            return default_solve::<T>(work, stride, x, m);
        }
        // Row-major lower triangle → a column-major matrix whose lower triangle is read.
        let h = DMatrix::from_fn(m, m, |i, j| {
            if i >= j {
                work[i * stride + j].to_f64()
            } else {
                0.0
            }
        });
        let chol = crate::compute::dense::cholesky(h).ok_or(LinalgError::NotPositiveDefinite)?;
        let rhs = DVector::from_iterator(m, x[..m].iter().map(|v| v.to_f64()));
        let sol = chol.solve(&rhs);
        // The factor back into `work`, as the library's kernel leaves it (for resolves).
        let l = chol.l_dirty();
        for i in 0..m {
            for j in 0..=i {
                work[i * stride + j] = T::of(l[(i, j)]);
            }
        }
        for (v, s) in x.iter_mut().zip(sol.iter()) {
            *v = T::of(*s);
        }
        Ok(())
    }
}

/// `v` as the `f64`s it is when `T` is `f64` (the type of the AVX2 kernels), else `None`.
#[cfg(target_arch = "x86_64")]
fn as_f64<T: Real>(v: &[T]) -> Option<&[f64]> {
    (std::any::TypeId::of::<T>() == std::any::TypeId::of::<f64>()).then(|| {
        // SAFETY: `T` is `f64` (checked just above): the same type, length and layout.
        unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<f64>(), v.len()) }
    })
}

/// [`as_f64`] for writing.
#[cfg(target_arch = "x86_64")]
fn as_f64_mut<T: Real>(v: &mut [T]) -> Option<&mut [f64]> {
    (std::any::TypeId::of::<T>() == std::any::TypeId::of::<f64>()).then(|| {
        // SAFETY: as in `as_f64`; a reborrow of the caller's exclusive borrow.
        unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast::<f64>(), v.len()) }
    })
}

/// The library's default [`LmStorage::solve_work`] (the trait's provided method, reached
/// through a storage that does not override it).
fn default_solve<T: Real>(
    work: &mut [T],
    stride: usize,
    x: &mut [T],
    m: usize,
) -> Result<(), LinalgError> {
    <kinecal::identify::lm::FixedLm<T, 0> as LmStorage<T>>::solve_work(work, stride, x, m)
}

/// [`LmPenalty`] on the heap: the terms, a prior per parameter (zero unless set) and the
/// solver's arrays, sized for `n` parameters.
#[derive(Clone, Debug)]
pub struct VecPenalty<T: Real> {
    terms: Vec<PenaltyTerm<T>>,
    prior: Vec<T>,
    weights: Vec<T>,
    offset: Vec<T>,
    scratch: Vec<T>,
    diagonal: Vec<T>,
}

impl<T: Real> VecPenalty<T> {
    /// `terms` on a solver with `n` parameters, every prior zero (pull towards zero).
    pub fn new(n: usize, terms: Vec<PenaltyTerm<T>>) -> Self {
        let k = terms.len();
        Self {
            terms,
            prior: vec![T::zero(); n],
            weights: vec![T::one(); k],
            offset: vec![T::zero(); n],
            scratch: vec![T::zero(); n],
            diagonal: vec![T::zero(); n],
        }
    }

    /// The prior of every parameter (parameter units), for writing.
    pub fn prior_mut(&mut self) -> &mut [T] {
        &mut self.prior
    }

    /// The terms.
    pub fn terms(&self) -> &[PenaltyTerm<T>] {
        &self.terms
    }
}

impl<T: Real> LmPenalty<T> for VecPenalty<T> {
    fn parts(&mut self) -> Option<PenaltyParts<'_, T>> {
        Some(PenaltyParts {
            terms: &self.terms,
            prior: &self.prior,
            weights: &mut self.weights,
            offset: &mut self.offset,
            scratch: &mut self.scratch,
            diagonal: &mut self.diagonal,
        })
    }
    fn parts_ref(&self) -> Option<PenaltyPartsRef<'_, T>> {
        Some(PenaltyPartsRef {
            terms: &self.terms,
            prior: &self.prior,
            weights: &self.weights,
            offset: &self.offset,
        })
    }
}
