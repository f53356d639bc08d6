//! Storage of a [`crate::identify::lm::Levenberg`] run, owned by the caller (as smoltcp's sockets take
//! their buffers): the parameter list, the normal equations and the solver's scratch.
//!
//! The solver itself holds only the robot, a workspace and a few scalars. Its `O(P²)` arrays
//! live in a type the caller chooses through [`LmStorage`]: [`FixedLm`] keeps them in fixed
//! arrays of capacity `P` (firmware: a static or stack value sized for its robot), and a host
//! sizes them from the problem on the heap (the `kinecal` command line's `VecLm`). A
//! 600-parameter model then needs no megabyte-sized value on any stack.

use crate::model::param::{Param, ParamError, ParamSet};
use crate::num::linalg::Square;
use crate::Real;

/// Number of length-`n` real vectors in [`LmParts`].
pub const LM_VECTORS: usize = 11;
/// Number of length-`n` index vectors in [`LmParts`].
pub const LM_INDEX_VECTORS: usize = 3;

/// The solver's arrays, each with room for the `n` parameters of the run; the two matrices are
/// row-major with row stride `stride ≥ n` (element `(i, j)` at `i * stride + j`).
#[derive(Debug)]
pub struct LmParts<'a, T> {
    /// The parameters being estimated (`n = params.len()`).
    pub params: &'a [Param],
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
    /// Scratch vectors of a solve.
    pub g: &'a mut [T],
    pub x: &'a mut [T],
    pub delta: &'a mut [T],
    /// One pose's scaled columns by coordinate (column `k` is `(cx[k], cy[k], cz[k])`): rows
    /// of `JᵀJ` are then updated from contiguous arrays, which vectorises.
    pub cx: &'a mut [T],
    pub cy: &'a mut [T],
    pub cz: &'a mut [T],
    /// Indices of those columns; of the active parameters; the pivot order.
    pub nz: &'a mut [usize],
    pub idx: &'a mut [usize],
    pub order: &'a mut [usize],
    /// `active[k]`: parameter k is estimated (false: held); `before`: scratch of the analysis.
    pub active: &'a mut [bool],
    pub before: &'a mut [bool],
}

/// Read-only view of the parts a report or a snapshot needs.
#[derive(Debug, Clone, Copy)]
pub struct LmPartsRef<'a, T> {
    pub params: &'a [Param],
    pub stride: usize,
    pub jtj: &'a [T],
    pub jtr: &'a [T],
    pub step: &'a [T],
    pub total: &'a [T],
    pub scale: &'a [T],
    pub analysed_diag: &'a [T],
    pub active: &'a [bool],
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
}

/// [`LmStorage`] in fixed arrays with room for `P` parameters (firmware, small host problems).
#[derive(Clone, Debug)]
pub struct FixedLm<T: Real, const P: usize> {
    params: ParamSet<P>,
    jtj: Square<T, P>,
    work: Square<T, P>,
    vectors: [[T; P]; LM_VECTORS],
    indices: [[usize; P]; LM_INDEX_VECTORS],
    flags: [[bool; P]; 2],
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
            flags: [[false; P]; 2],
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
        let [active, before] = &mut self.flags;
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
        }
    }
}

/// Checks that the storage has room for its parameters.
pub(crate) fn storage_fits<T: Real, S: LmStorage<T>>(st: &mut S) -> bool {
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
    ];
    let matrix = p.stride.checked_mul(p.stride);
    p.stride >= n
        && vectors.iter().all(|&l| l >= n)
        && matrix.is_some_and(|m| p.jtj.len() >= m && p.work.len() >= m)
}
