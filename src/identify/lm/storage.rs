//! Storage of a [`crate::identify::lm::Levenberg`] run, owned by the caller (as smoltcp's sockets take
//! their buffers): the parameter list, the normal equations and the solver's scratch.
//!
//! The solver itself holds only the robot, a workspace and a few scalars. Its `O(P²)` arrays
//! live in a type the caller chooses through [`LmStorage`]: [`FixedLm`] keeps them in fixed
//! arrays of capacity `P` (firmware: a static or stack value sized for its robot), and a host
//! sizes them from the problem on the heap (the `kinecal` command line's `VecLm`). A
//! 600-parameter model then needs no megabyte-sized value on any stack.

use crate::model::param::{Param, ParamError, ParamSet};
use crate::num::linalg::{cholesky, cholesky_solve, Flat, LinalgError, Square};
use crate::Real;

/// Number of length-`n` real vectors in [`LmParts`].
pub const LM_VECTORS: usize = 11;
/// Number of length-`n` index vectors in [`LmParts`].
pub const LM_INDEX_VECTORS: usize = 3;
/// Number of length-`n` flag vectors in [`LmParts`] (`active`, `before`, `held`).
pub const LM_FLAG_VECTORS: usize = 3;

/// The solver's arrays, each with room for the `n` parameters of the run; the two matrices are
/// row-major with row stride `stride ≥ n` (element `(i, j)` at `i * stride + j`).
#[derive(Debug)]
pub struct LmParts<'a, T> {
    /// The parameters being estimated (`n = params.len()`).
    pub params: &'a [Param],
    /// Row stride of the two matrices (`≥ n`).
    pub stride: usize,
    /// Normal matrix `JᵀJ` of the scaled columns (lower triangle kept).
    pub jtj: &'a mut [T],
    /// Scratch matrix (factorisations; restore staging).
    pub work: &'a mut [T],
    /// `Jᵀr`.
    pub jtr: &'a mut [T],
    /// The last candidate step (scaled).
    pub step: &'a mut [T],
    /// Accumulated scaled update since the start (for the ridge).
    pub total: &'a mut [T],
    /// Column scale of each parameter.
    pub scale: &'a mut [T],
    /// Diagonal of `JᵀJ` at the last identifiability analysis.
    pub analysed_diag: &'a mut [T],
    /// Right-hand side of a solve (scratch).
    pub g: &'a mut [T],
    /// Solution of a solve (scratch; [`LmStorage::solve_work`] solves in place here).
    pub x: &'a mut [T],
    /// The step in parameter units (scratch).
    pub delta: &'a mut [T],
    /// One pose's scaled columns by coordinate (column `k` is `(cx[k], cy[k], cz[k])`): rows
    /// of `JᵀJ` are then updated from contiguous arrays, which vectorises. `x` parts.
    pub cx: &'a mut [T],
    /// `y` parts of one pose's scaled columns.
    pub cy: &'a mut [T],
    /// `z` parts of one pose's scaled columns.
    pub cz: &'a mut [T],
    /// Indices of one pose's non-zero columns.
    pub nz: &'a mut [usize],
    /// Indices of the active parameters (a solve's compacted order).
    pub idx: &'a mut [usize],
    /// The pivot order of an analysis (scratch; a solve's position of each parameter).
    pub order: &'a mut [usize],
    /// `active[k]`: parameter k is estimated (false: held, by the caller or the analysis).
    pub active: &'a mut [bool],
    /// Scratch of the analysis.
    pub before: &'a mut [bool],
    /// `held[k]`: the caller holds parameter k at its start value
    /// ([`crate::identify::lm::Levenberg::hold`]).
    pub held: &'a mut [bool],
    /// Room for the rows a pass collects before adding them in one block
    /// ([`LmStorage::BATCH_ROWS`] rows of `stride` entries, then their `BATCH_ROWS` residuals);
    /// empty when the storage adds every pose's rows at once (the default, firmware).
    pub batch: &'a mut [T],
}

/// Read-only view of the parts a report or a snapshot needs (fields as in [`LmParts`]).
#[derive(Debug, Clone, Copy)]
pub struct LmPartsRef<'a, T> {
    /// The parameters being estimated.
    pub params: &'a [Param],
    /// Row stride of `jtj`.
    pub stride: usize,
    /// Normal matrix `JᵀJ` of the scaled columns (lower triangle).
    pub jtj: &'a [T],
    /// `Jᵀr`.
    pub jtr: &'a [T],
    /// The last candidate step (scaled).
    pub step: &'a [T],
    /// Accumulated scaled update since the start.
    pub total: &'a [T],
    /// Column scale of each parameter.
    pub scale: &'a [T],
    /// Diagonal of `JᵀJ` at the last identifiability analysis.
    pub analysed_diag: &'a [T],
    /// Which parameters are estimated.
    pub active: &'a [bool],
    /// Which parameters the caller holds.
    pub held: &'a [bool],
}

/// Caller-owned storage of one identification run: the parameters it estimates and room for
/// the arrays of [`LmParts`] (each at least `params().len()` long, matrices `stride²`).
pub trait LmStorage<T: Real> {
    /// The parameters being estimated, fixed for the storage's life.
    fn params(&self) -> &[Param] {
        self.parts_ref().params
    }
    /// The arrays (and the parameters) for writing.
    fn parts(&mut self) -> LmParts<'_, T>;
    /// The arrays for reading.
    fn parts_ref(&self) -> LmPartsRef<'_, T>;
    /// Factors the leading `m × m` block of `work` (row-major with row stride `stride`, lower
    /// triangle read; symmetric positive definite) by Cholesky and solves for `x[..m]` in
    /// place (`x` holds the right-hand side on entry). The default is the library's
    /// [`cholesky`]; a host may override it with a faster kernel for large `m`, as long as it
    /// solves the same system (the solver checks that `x` is finite).
    fn solve_work(work: &mut [T], stride: usize, x: &mut [T], m: usize) -> Result<(), LinalgError> {
        let x = x.get_mut(..m).ok_or(LinalgError::Size)?;
        Flat::new(work, stride).and_then(|mut w| {
            cholesky(&mut w, m)?;
            cholesky_solve(&w, m, x)
        })
    }

    /// Rows (three per point, three per orientation) a pass over a slice of poses
    /// ([`crate::identify::lm::Pass::accumulate`]) collects in [`LmParts::batch`] before adding
    /// them to the normal equations in one block by [`LmStorage::add_batch`]: one load and store
    /// of `JᵀJ` per block instead of per pose, a matrix product a host can run at its
    /// processor's speed. 0 (the default): every pose's rows are added at once by
    /// [`LmStorage::add_rows`], as the solver's own passes always do. The sums are the same up
    /// to rounding (their order differs).
    const BATCH_ROWS: usize = 0;

    /// Adds `residuals.len()` collected rows (row `b` at `rows[b·stride..b·stride + n]`, its
    /// residual `residuals[b]`) to `JᵀJ` (lower triangle, first `n` rows) and `Jᵀr`:
    /// [`add_batch_rows`] (the default). A host may override it with a faster kernel that
    /// forms the same sums.
    fn add_batch(sums: (&mut [T], &mut [T]), stride: usize, n: usize, rows: &[T], residuals: &[T]) {
        add_batch_rows(sums, stride, n, rows, residuals);
    }

    /// Adds one pose's rows to `JᵀJ` (lower triangle) and `Jᵀr` as [`add_dense_rows`] does
    /// (the default). A host may override it with that same function compiled for wider vector
    /// instructions: the same products and sums in the same order, so bit-identical sums.
    #[inline(always)]
    fn add_rows(
        sums: (&mut [T], &mut [T]),
        stride: usize,
        columns: (&[T], &[T], &[T]),
        r: [T; 3],
        rows: &[usize],
    ) {
        add_dense_rows(sums, stride, columns, r, rows);
    }

    /// Solves for `x[..m]` in place with the factor [`LmStorage::solve_work`] left in `work`
    /// (its lower triangle must hold `L` of `L·Lᵀ`, as the library's [`cholesky`] leaves it).
    fn resolve_work(
        work: &mut [T],
        stride: usize,
        x: &mut [T],
        m: usize,
    ) -> Result<(), LinalgError> {
        let x = x.get_mut(..m).ok_or(LinalgError::Size)?;
        Flat::new(work, stride).and_then(|w| cholesky_solve(&w, m, x))
    }
}

/// Adds one pose's three rows to the normal equations: the columns `(cx, cy, cz)` (zero
/// where a column does not enter) to the lower triangle of `jtj` (row stride `stride`) and,
/// with the residual `r`, to `jtr`: for each `i` of `rows` (increasing, every other column
/// zero) `jtr[i] += (cx[i], cy[i], cz[i])·r` and for every `j ≤ i`
/// `jtj[i·stride + j] += cx[i]·cx[j] + cy[i]·cy[j] + cz[i]·cz[j]`. Whole contiguous rows: the
/// loop vectorises.
#[inline(always)]
pub fn add_dense_rows<T: Real>(
    (jtj, jtr): (&mut [T], &mut [T]),
    stride: usize,
    (cx, cy, cz): (&[T], &[T], &[T]),
    r: [T; 3],
    rows: &[usize],
) {
    for &i in rows {
        let (xi, yi, zi) = (cx[i], cy[i], cz[i]);
        jtr[i] += xi * r[0] + yi * r[1] + zi * r[2];
        let row = &mut jtj[i * stride..i * stride + i + 1];
        let cols = cx[..=i].iter().zip(&cy[..=i]).zip(&cz[..=i]);
        for (v, ((x, y), z)) in row.iter_mut().zip(cols) {
            *v += xi * *x + yi * *y + zi * *z;
        }
    }
}

/// Adds collected rows to the normal equations ([`LmStorage::add_batch`]): for each row `b`
/// (`rows[b·stride..b·stride + n]`, residual `residuals[b]`), `jtr[i] += row[i]·residuals[b]`
/// and, for every `j ≤ i < n`, `jtj[i·stride + j] += row[i]·row[j]`. Rows or sums shorter than
/// that leave the rest alone.
pub fn add_batch_rows<T: Real>(
    (jtj, jtr): (&mut [T], &mut [T]),
    stride: usize,
    n: usize,
    rows: &[T],
    residuals: &[T],
) {
    for (b, &r) in residuals.iter().enumerate() {
        let Some(row) = rows.get(b * stride..b * stride + n) else {
            return;
        };
        for (i, &xi) in row.iter().enumerate() {
            if let Some(v) = jtr.get_mut(i) {
                *v += xi * r;
            }
            if let Some(out) = jtj.get_mut(i * stride..i * stride + i + 1) {
                for (v, &xj) in out.iter_mut().zip(row) {
                    *v += xi * xj;
                }
            }
        }
    }
}

/// [`LmStorage`] in fixed arrays with room for `P` parameters (firmware, small host problems).
#[derive(Clone, Debug)]
pub struct FixedLm<T: Real, const P: usize> {
    params: ParamSet<P>,
    jtj: Square<T, P>,
    work: Square<T, P>,
    vectors: [[T; P]; LM_VECTORS],
    indices: [[usize; P]; LM_INDEX_VECTORS],
    flags: [[bool; P]; LM_FLAG_VECTORS],
}

impl<T: Real, const P: usize> FixedLm<T, P> {
    /// Storage for estimating `params`.
    pub fn new(params: ParamSet<P>) -> Self {
        Self {
            params,
            jtj: [[T::zero(); P]; P],
            work: [[T::zero(); P]; P],
            vectors: [[T::zero(); P]; LM_VECTORS],
            indices: [[0; P]; LM_INDEX_VECTORS],
            flags: [[false; P]; LM_FLAG_VECTORS],
        }
    }

    /// Storage for a parameter slice (fails when it holds more than `P`).
    pub fn from_slice(params: &[Param]) -> Result<Self, ParamError> {
        let mut set = ParamSet::new();
        for p in params {
            set.push(*p)?;
        }
        Ok(Self::new(set))
    }
}

impl<T: Real, const P: usize> LmStorage<T> for FixedLm<T, P> {
    fn parts(&mut self) -> LmParts<'_, T> {
        let [jtr, step, total, scale, analysed_diag, g, x, delta, cx, cy, cz] = &mut self.vectors;
        let [nz, idx, order] = &mut self.indices;
        let [active, before, held] = &mut self.flags;
        LmParts {
            params: self.params.as_slice(),
            stride: P,
            jtj: self.jtj.as_flattened_mut(),
            work: self.work.as_flattened_mut(),
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
            batch: &mut [],
        }
    }

    fn parts_ref(&self) -> LmPartsRef<'_, T> {
        let [jtr, step, total, scale, analysed_diag, ..] = &self.vectors;
        LmPartsRef {
            params: self.params.as_slice(),
            stride: P,
            jtj: self.jtj.as_flattened(),
            jtr,
            step,
            total,
            scale,
            analysed_diag,
            active: &self.flags[0],
            held: &self.flags[2],
        }
    }
}

/// Checks that the storage has room for its parameters.
pub(super) fn storage_fits<T: Real, Storage: LmStorage<T>>(st: &mut Storage) -> bool {
    let n = st.params().len();
    let p = st.parts();
    let vectors = [
        p.jtr.len(),
        p.step.len(),
        p.total.len(),
        p.scale.len(),
        p.analysed_diag.len(),
        p.g.len(),
        p.x.len(),
        p.delta.len(),
        p.cx.len(),
        p.cy.len(),
        p.cz.len(),
        p.nz.len(),
        p.idx.len(),
        p.order.len(),
        p.active.len(),
        p.before.len(),
        p.held.len(),
    ];
    let matrix = p.stride.checked_mul(p.stride);
    p.stride >= n
        && vectors.iter().all(|&l| l >= n)
        && matrix.is_some_and(|m| p.jtj.len() >= m && p.work.len() >= m)
}
