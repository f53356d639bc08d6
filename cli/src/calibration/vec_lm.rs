//! The host's storage for the library's Levenberg–Marquardt solver: the arrays sized from the
//! problem (the parameter count) on the heap, so that a model with per-joint tables (600+
//! parameters, a 3 MB normal matrix) needs neither a big stack nor a worst-case capacity.

use kinecal::identify::lm::{LmParts, LmPartsRef, LmStorage};
use kinecal::identify::lm_storage::{LM_INDEX_VECTORS, LM_VECTORS};
use kinecal::model::param::Param;
use kinecal::Real;

/// [`LmStorage`] in `Vec`s sized for exactly the parameters of the run.
#[derive(Clone, Debug)]
pub struct VecLm<T: Real> {
    params: Vec<Param>,
    jtj: Vec<T>,
    work: Vec<T>,
    vectors: Vec<T>,
    indices: Vec<usize>,
    flags: Vec<bool>,
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
            flags: vec![false; 2 * n],
        }
    }
}

impl<T: Real> VecLm<T> {
    /// Storage for one part of a pass over `params` ([`kinecal::identify::lm::PassPart`]): only what a
    /// pass writes (no scratch matrix), half the memory of [`VecLm::new`].
    pub fn for_pass(params: &[Param]) -> Self {
        let mut s = Self::new(params);
        s.work = Vec::new();
        s
    }
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
        let (active, before) = self.flags.split_at_mut(n);
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
        }
    }
}
