//! A quadratic penalty (a Gaussian prior) on the scaled parameters of a
//! [`crate::identify::lm::Levenberg`] run, in storage the caller owns.
//!
//! With a penalty the run minimises
//!
//! `Σ |r_i|² + uᵀ Π u`,   `u_k = (x_k − prior_k) · scale_k`,
//!
//! `x_k` being parameter `k`'s value ([`crate::model::param::value`]), `prior_k` the value the
//! caller pulls it towards and `scale_k` its [`Param::scale`] (1 mm at the tool per unit), so that
//! `Π` is in mm² whatever the parameter. `Π` is a sum of [`PenaltyTerm`]s, each on a run of
//! consecutive parameters of the solver's list: a ridge `ρ·I` and a smoothness term `σ·DᵀD` (`D`
//! the second differences of neighbours: the knots of a correction table), scaled by a weight
//! `w`. A *relative* term takes `w` from the data: the mean diagonal of `JᵀJ` over its run at
//! the start of the run (the first pass), so that `ρ = 1e-3` means "a thousandth of what an
//! average column of the run knows" whatever the number of poses; an absolute term has `w = 1`.
//!
//! The solver's own storage ([`super::LmStorage`]) is untouched: a penalty lives in
//! a second, caller-owned value implementing [`LmPenalty`]. [`NoPenalty`] (the default) has no
//! storage and compiles to nothing; [`FixedPenalty`] keeps a penalty in fixed arrays; a host
//! sizes one on the heap (the `kinecal` command line's `VecPenalty`).

use crate::model::param::Param;
use crate::Real;

/// Second-difference stencil `(1, −2, 1)`.
const STENCIL: [f64; 3] = [1.0, -2.0, 1.0];

/// One term of a penalty: `w · (ridge · I + smoothness · DᵀD)` on the parameters at positions
/// `first .. first + len` of the solver's parameter list.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PenaltyTerm<T> {
    /// Position of the run's first parameter in the solver's parameter list.
    pub first: usize,
    /// Number of parameters in the run (at least 1).
    pub len: usize,
    /// Weight of `Σ u_k²` over the run (≥ 0).
    pub ridge: T,
    /// Weight of the squared second differences `Σ (u_k − 2 u_{k+1} + u_{k+2})²` (≥ 0; needs
    /// at least 3 parameters to act).
    pub smoothness: T,
    /// `true`: both weights are relative to the mean diagonal of `JᵀJ` over the run at the
    /// start; `false`: absolute (mm² per scaled unit²).
    pub relative: bool,
}

/// Why a penalty was refused (by [`crate::identify::lm::Levenberg::with_penalty`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PenaltyError {
    /// A term is empty or reaches past the parameter list, or an array is shorter than the
    /// parameter list (priors, scratch) or the term list (weights).
    Size,
    /// A weight is negative or not finite, or a prior is not finite.
    NonFinite,
}

impl<T: Real> PenaltyTerm<T> {
    /// A relative ridge (and smoothness) term on `len` parameters from position `first`.
    pub fn relative(first: usize, len: usize, ridge: T, smoothness: T) -> Self {
        Self {
            first,
            len,
            ridge,
            smoothness,
            relative: true,
        }
    }

    /// Entry `(i, j)` (positions within the run, `0..len`) of `ridge · I + smoothness · DᵀD`,
    /// before the weight: non-zero only for `|i − j| ≤ 2`.
    pub fn entry(&self, i: usize, j: usize) -> T {
        if i >= self.len || j >= self.len || i.abs_diff(j) > 2 {
            return T::zero();
        }
        let mut v = if i == j { self.ridge } else { T::zero() };
        if self.len >= 3 && self.smoothness != T::zero() {
            // Rows m of D (m = 0..len−2) with D[m, m + s] = STENCIL[s] touching both i and j.
            let lo = i.max(j).saturating_sub(2);
            let hi = i.min(j).min(self.len - 3);
            let mut s = 0.0;
            let mut m = lo;
            while m <= hi {
                s += STENCIL[i - m] * STENCIL[j - m];
                m += 1;
            }
            v += self.smoothness * T::of(s);
        }
        v
    }

    /// The term's weight `w` for a normal matrix whose diagonal is `diag(k)` (solver
    /// positions): the mean over the run when relative (1 when that is not positive and finite,
    /// e.g. a run no pose excites), else 1.
    pub fn weight(&self, diag: impl Fn(usize) -> T) -> T {
        if !self.relative || self.len == 0 {
            return T::one();
        }
        let mut s = T::zero();
        for k in self.first..self.first + self.len {
            s += diag(k);
        }
        let w = s / T::of(self.len as f64);
        if w > T::zero() && w.finite() {
            w
        } else {
            T::one()
        }
    }

    /// `uᵀ (ridge · I + smoothness · DᵀD) u` over the run (`u(k)`: solver positions), before
    /// the weight.
    pub fn quadratic(&self, u: impl Fn(usize) -> T) -> T {
        let f = self.first;
        let mut ridge = T::zero();
        for k in f..f + self.len {
            ridge += u(k) * u(k);
        }
        let mut smooth = T::zero();
        if self.len >= 3 && self.smoothness != T::zero() {
            for m in 0..self.len - 2 {
                let d = u(f + m) - T::of(2.0) * u(f + m + 1) + u(f + m + 2);
                smooth += d * d;
            }
        }
        self.ridge * ridge + self.smoothness * smooth
    }

    /// Component `i` (position within the run) of `(ridge · I + smoothness · DᵀD) u`, before
    /// the weight.
    pub fn product(&self, i: usize, u: impl Fn(usize) -> T) -> T {
        if i >= self.len {
            return T::zero();
        }
        let mut v = T::zero();
        let lo = i.saturating_sub(2);
        let hi = (i + 2).min(self.len - 1);
        for j in lo..=hi {
            let e = self.entry(i, j);
            if e != T::zero() {
                v += e * u(self.first + j);
            }
        }
        v
    }

    /// Checks the term against a list of `n` parameters.
    pub fn check(&self, n: usize) -> Result<(), PenaltyError> {
        if self.len == 0 || self.first.checked_add(self.len).is_none_or(|end| end > n) {
            return Err(PenaltyError::Size);
        }
        let ok = |x: T| x.finite() && !(x < T::zero());
        if !ok(self.ridge) || !ok(self.smoothness) {
            return Err(PenaltyError::NonFinite);
        }
        Ok(())
    }
}

/// A penalty's arrays, as the solver writes them.
#[derive(Debug)]
pub struct PenaltyParts<'a, T> {
    /// The terms (set by the caller).
    pub terms: &'a [PenaltyTerm<T>],
    /// The value each parameter is pulled towards, in parameter units (rad, mm; the base
    /// rotation as roll/pitch/yaw), one per parameter of the solver (set by the caller; only
    /// the penalised ones matter).
    pub prior: &'a [T],
    /// The weight `w` of each term, resolved by the solver at the end of its first pass.
    pub weights: &'a mut [T],
    /// `u` at the starting model (scaled units), written by the solver at construction: the
    /// penalty acts on `offset + ` the accumulated update.
    pub offset: &'a mut [T],
    /// Scratch of a solve (one per parameter): `Π u`.
    pub scratch: &'a mut [T],
    /// Scratch of a solve (one per parameter): `Π`'s diagonal.
    pub diagonal: &'a mut [T],
}

/// A penalty's arrays for reading.
#[derive(Debug, Clone, Copy)]
pub struct PenaltyPartsRef<'a, T> {
    /// The terms.
    pub terms: &'a [PenaltyTerm<T>],
    /// The prior value of each parameter (parameter units).
    pub prior: &'a [T],
    /// The resolved weight of each term.
    pub weights: &'a [T],
    /// `u` at the starting model (scaled units).
    pub offset: &'a [T],
}

impl<T: Real> PenaltyPartsRef<'_, T> {
    /// `uᵀ Π u` for `u(k)` (solver positions), the weights applied.
    pub fn value(&self, u: impl Fn(usize) -> T + Copy) -> T {
        let mut v = T::zero();
        for (t, w) in self.terms.iter().zip(self.weights) {
            v += *w * t.quadratic(u);
        }
        v
    }
}

/// Caller-owned storage of a penalty (see the [module](crate::identify::lm)); `None` from both methods means
/// no penalty at all.
pub trait LmPenalty<T: Real> {
    /// The arrays for writing, or `None` without a penalty.
    fn parts(&mut self) -> Option<PenaltyParts<'_, T>>;
    /// The arrays for reading, or `None` without a penalty.
    fn parts_ref(&self) -> Option<PenaltyPartsRef<'_, T>>;
}

/// No penalty: the plain least-squares run (no storage, no code).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoPenalty;

impl<T: Real> LmPenalty<T> for NoPenalty {
    #[inline(always)]
    fn parts(&mut self) -> Option<PenaltyParts<'_, T>> {
        None
    }
    #[inline(always)]
    fn parts_ref(&self) -> Option<PenaltyPartsRef<'_, T>> {
        None
    }
}

/// A penalty in fixed arrays: up to `K` terms on a solver with up to `P` parameters.
#[derive(Clone, Debug)]
pub struct FixedPenalty<T: Real, const P: usize, const K: usize> {
    terms: heapless::Vec<PenaltyTerm<T>, K>,
    prior: [T; P],
    weights: [T; K],
    offset: [T; P],
    scratch: [T; P],
    diagonal: [T; P],
}

impl<T: Real, const P: usize, const K: usize> FixedPenalty<T, P, K> {
    /// `terms` with every prior zero (pull towards zero); fails when more than `K` terms.
    pub fn new(terms: &[PenaltyTerm<T>]) -> Result<Self, PenaltyError> {
        let mut list = heapless::Vec::new();
        for t in terms {
            list.push(*t).map_err(|_| PenaltyError::Size)?;
        }
        Ok(Self {
            terms: list,
            prior: [T::zero(); P],
            weights: [T::one(); K],
            offset: [T::zero(); P],
            scratch: [T::zero(); P],
            diagonal: [T::zero(); P],
        })
    }

    /// The prior of every parameter (parameter units), for writing (default: zero).
    pub fn prior_mut(&mut self) -> &mut [T; P] {
        &mut self.prior
    }
}

impl<T: Real, const P: usize, const K: usize> LmPenalty<T> for FixedPenalty<T, P, K> {
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

/// Checks a penalty against the solver's `params` (sizes, finiteness).
pub(super) fn check_penalty<T: Real>(
    p: &PenaltyParts<'_, T>,
    params: &[Param],
) -> Result<(), PenaltyError> {
    let n = params.len();
    if p.prior.len() < n
        || p.offset.len() < n
        || p.scratch.len() < n
        || p.diagonal.len() < n
        || p.weights.len() < p.terms.len()
    {
        return Err(PenaltyError::Size);
    }
    for t in p.terms {
        t.check(n)?;
    }
    if p.prior[..n].iter().any(|x| !x.finite()) {
        return Err(PenaltyError::NonFinite);
    }
    Ok(())
}
