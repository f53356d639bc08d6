//! Streaming Levenberg–Marquardt identification with identifiability analysis.
//!
//! The normal equations `JᵀJ`, `Jᵀr` are accumulated one measurement at a time, so memory is
//! `O(P²)` whatever the number of poses, and one [`Levenberg::step`] call processes at most a
//! caller-chosen number of poses: firmware runs it in idle cycles, the desktop in one call.
//!
//! A candidate step is tried with a full pass at the candidate, which accumulates its normal
//! equations while summing its cost: accepted (the usual case), they are the next iteration's,
//! so an iteration costs one pass over the data; rejected, the estimate's are accumulated
//! again. Passes can be spread over workers ([`crate::identify::lm_pass`]).
//!
//! Parameters are scaled by [`Param::scale`] (angles × reach) so that a unit step moves the
//! tool by about a millimetre whatever the parameter; Marquardt's diagonal damping with
//! Nielsen's update of λ makes convergence from the nominal model reliable.
//!
//! **Identifiability follows the model.** On the first pass the scaled normal matrix is
//! normalised to unit diagonal (a correlation matrix) and factored by rank-revealing Cholesky.
//! Columns whose pivot falls below `rank_tolerance` are directions the data cannot determine
//! (base z vs d1, theta of the last joint vs the tool, d of parallel axes, effect values no
//! pose excites): they are held at their current value instead of running off. What the data
//! determine depends on where the model is, though: a tool point started on the flange axis
//! makes theta6 and the last rows' angles invisible until the fit moves the point off the axis.
//! So the decision is taken again whenever a held parameter's column has grown since it was
//! taken (checked at every accepted step, `O(P)`), and once more at the converged model; the
//! run only ends when a re-analysis at the final model confirms the held set. Re-analysis
//! prefers the parameters already estimated, so a confounded pair does not swap back and
//! forth. A tiny ridge on the accumulated update keeps nearly dependent directions bounded.
//!
//! **Penalties and subsets.** A run may minimise `Σ|r_i|² + uᵀΠu` instead, `Π` a caller-given
//! quadratic penalty (a prior) on the scaled parameters ([`crate::identify::lm_penalty`]:
//! ridges and smoothness terms, e.g. on the knots of correction tables) in a second
//! caller-owned value ([`Levenberg::with_penalty`]); the penalty enters the normal equations,
//! the identifiability analysis (a direction the penalty determines is determined) and the
//! cost that accepts steps. The caller chooses the parameters (the storage's list), may hold
//! some of them at their start values ([`Levenberg::hold`]), and may turn the analysis off
//! (`max_analyses = 0`: every parameter not held is estimated, as a refit of a known parameter
//! set wants). A run starts from any model: the nominal one, or a previous fit.

use crate::identify::lm_pass::{
    accumulate_pose, check_observations, clear_normal_equations, split_parts, Columns,
};
pub use crate::identify::lm_pass::{Pass, PassKind, PassPart};
use crate::identify::lm_penalty::check_penalty;
pub use crate::identify::lm_penalty::{
    FixedPenalty, LmPenalty, NoPenalty, PenaltyError, PenaltyParts, PenaltyPartsRef, PenaltyTerm,
};
pub use crate::identify::lm_status::{LmError, LmProgress, LmStop};
use crate::identify::lm_storage::storage_fits;
pub use crate::identify::lm_storage::{FixedLm, LmParts, LmPartsRef, LmStorage};
use crate::io::measurement::Observation;
use crate::model::param::{apply_delta, check_params, value, Param, ParamError};
use crate::num::linalg::{pivoted_cholesky_preferring, Flat, LinalgError};
use crate::{ForwardKinematics, Real, Robot};
use nalgebra::Vector3;

/// Settings of the solver; [`LmConfig::default`] suits laser-tracker data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmConfig<T: Real> {
    /// Stop after this many accepted or rejected steps.
    pub max_iterations: u32,
    /// Stop when a step lowers the cost by less than this fraction.
    pub cost_tolerance: T,
    /// Stop when the scaled step is shorter than this (mm-equivalent).
    pub step_tolerance: T,
    /// Relative pivot below which a parameter direction counts as unidentifiable.
    pub rank_tolerance: T,
    /// Ridge on the accumulated scaled update, relative to the mean diagonal of `JᵀJ`.
    pub ridge: T,
    /// Initial damping relative to the diagonal.
    pub initial_damping: T,
    /// Most identifiability analyses in one run (the first one included); 1 decides once, at
    /// the starting model; 0 makes none: every parameter the caller does not hold is
    /// estimated (a refit of a parameter set known to be determined, or made so by a penalty).
    pub max_analyses: u8,
    /// Relative pivot a held parameter needs to join on a re-analysis (stricter than
    /// `rank_tolerance`): moving off the nominal geometry turns exact dependencies (d of
    /// parallel axes) into near ones, which the data still cannot determine.
    pub activation_tolerance: T,
    /// Keep the curvature `JᵀJ` while steps succeed: a candidate's pass then sums only `Jᵀr`
    /// and the cost (about half the work of a pass with many parameters), and the next step
    /// is solved with the `JᵀJ` of an earlier point. It is formed afresh (a full pass at the
    /// estimate) after a rejected step and after a step that gained less than half of what it
    /// promised. The fixed point is the same; for refits that start next to their solution
    /// (nearly linear) it saves most of the work. Re-analyses of identifiability are only
    /// triggered by full passes. Default off.
    pub keep_curvature: bool,
}

impl<T: Real> LmConfig<T> {
    /// Whether the settings can run: every number finite, the initial damping above zero (a
    /// zero or negative damping never grows, so a failed step would be retried forever), the
    /// rank tolerance in (0, 1), the other tolerances and the ridge at least zero.
    pub fn is_valid(&self) -> bool {
        let finite_non_negative = |x: T| x.finite() && x >= T::zero();
        self.initial_damping.finite()
            && self.initial_damping > T::zero()
            && self.rank_tolerance > T::zero()
            && self.rank_tolerance < T::one()
            && finite_non_negative(self.cost_tolerance)
            && finite_non_negative(self.step_tolerance)
            && finite_non_negative(self.ridge)
            && finite_non_negative(self.activation_tolerance)
    }
}

impl<T: Real> Default for LmConfig<T> {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            cost_tolerance: T::of(1e-10).max(T::EPS * T::of(16.0)),
            step_tolerance: T::of(1e-9).max(T::EPS * T::of(16.0)),
            rank_tolerance: T::EPS.sqrt(),
            ridge: T::of(1e-9).max(T::EPS),
            initial_damping: T::of(1e-3),
            max_analyses: 8,
            activation_tolerance: T::of(1e-4),
            keep_curvature: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Accumulating the normal equations at the current estimate.
    Accumulate,
    /// Solving the damped equations for a candidate.
    Solve,
    /// Evaluating the candidate's cost.
    Evaluate,
    /// Accumulating at the model the run would stop at, to confirm the held set (stop reason
    /// kept for when it is confirmed).
    Confirm(LmStop),
    /// Accumulating every column again at the current model, to re-decide identifiability.
    Reanalyse,
    /// Finished, for this reason.
    Done(LmStop),
}

/// The Levenberg–Marquardt stepper for a robot with `N` joints and `V` effect values, over the
/// caller's storage `S` (the parameters and the normal equations: see
/// [`crate::identify::lm_storage`]) and penalty `Q` (none by default: see
/// [`crate::identify::lm_penalty`]).
#[derive(Clone, Debug)]
pub struct Levenberg<
    T: Real,
    const N: usize,
    const V: usize,
    S: LmStorage<T>,
    Q: LmPenalty<T> = NoPenalty,
> {
    cfg: LmConfig<T>,
    robot: Robot<T, N, V>,
    candidate: Robot<T, N, V>,
    st: S,
    pen: Q,
    analysed: bool,
    /// Identifiability analyses done so far.
    analyses: u8,
    cost: T,
    acc_cost: T,
    cand_cost: T,
    lambda: T,
    nu: T,
    /// `work` holds the factor of the damped system of the current `JᵀJ`, damping and active
    /// set (kept curvature only; not in snapshots: a restored run factors again, to the same
    /// numbers).
    factored: bool,
    predicted: T,
    next: usize,
    n_poses: usize,
    phase: Phase,
    iteration: u32,
    evaluations: u32,
    fk: ForwardKinematics<T, N>,
}

/// A solver in fixed arrays with room for `P` parameters (firmware; small host problems).
pub type FixedLevenberg<T, const N: usize, const V: usize, const P: usize> =
    Levenberg<T, N, V, FixedLm<T, P>>;

impl<T: Real, const N: usize, const V: usize, const P: usize> Levenberg<T, N, V, FixedLm<T, P>> {
    /// A solver in fixed arrays with room for the `P` parameters of `params`.
    pub fn fixed(
        start: Robot<T, N, V>,
        params: crate::model::param::ParamSet<P>,
        cfg: LmConfig<T>,
    ) -> Result<Self, LmError> {
        Self::new(start, FixedLm::new(params), cfg)
    }
}

impl<T: Real, const N: usize, const V: usize, S: LmStorage<T>> Levenberg<T, N, V, S> {
    /// A solver starting from `start` (the nominal model or any other, e.g. a previous fit),
    /// estimating the parameters of `storage` (all must exist in the robot, and the storage
    /// must have room for them).
    pub fn new(start: Robot<T, N, V>, storage: S, cfg: LmConfig<T>) -> Result<Self, LmError> {
        Self::with_penalty(start, storage, NoPenalty, cfg)
    }
}

impl<T: Real, const N: usize, const V: usize, S: LmStorage<T>, Q: LmPenalty<T>>
    Levenberg<T, N, V, S, Q>
{
    /// [`Levenberg::new`] minimising `Σ|r_i|² + uᵀΠu` with the caller's `penalty` (see
    /// [`crate::identify::lm_penalty`]); its terms must lie within the parameter list, its
    /// arrays have room for it, its weights and priors be finite (weights ≥ 0).
    pub fn with_penalty(
        start: Robot<T, N, V>,
        mut storage: S,
        mut penalty: Q,
        cfg: LmConfig<T>,
    ) -> Result<Self, LmError> {
        if !cfg.is_valid() {
            return Err(LmError::Config);
        }
        check_params(storage.params(), &start).map_err(LmError::Params)?;
        if !storage_fits(&mut storage) {
            return Err(LmError::Params(ParamError::Shape));
        }
        let reach = start.reach();
        let p = storage.parts();
        for (k, param) in p.params.iter().enumerate() {
            p.scale[k] = param.scale(reach);
            p.total[k] = T::zero();
            p.step[k] = T::zero();
            p.jtr[k] = T::zero();
            p.analysed_diag[k] = T::zero();
            p.active[k] = true;
            p.held[k] = false;
        }
        if let Some(q) = penalty.parts() {
            check_penalty(&q, p.params).map_err(LmError::Penalty)?;
            for (k, param) in p.params.iter().enumerate() {
                let x = value(&start, *param).unwrap_or(T::zero());
                q.offset[k] = (x - q.prior[k]) * p.scale[k];
                if !q.offset[k].finite() {
                    return Err(LmError::Penalty(PenaltyError::NonFinite));
                }
            }
            q.weights[..q.terms.len()].fill(T::one());
        }
        Ok(Self {
            cfg,
            candidate: start.clone(),
            robot: start,
            st: storage,
            pen: penalty,
            analysed: false,
            analyses: 0,
            cost: T::zero(),
            acc_cost: T::zero(),
            cand_cost: T::zero(),
            lambda: cfg.initial_damping,
            nu: T::of(2.0),
            factored: false,
            predicted: T::zero(),
            next: 0,
            n_poses: 0,
            phase: Phase::Accumulate,
            iteration: 0,
            evaluations: 0,
            fk: ForwardKinematics::new(),
        })
    }

    /// Holds parameter `p` (one of [`Levenberg::params`]) at its start value: it is never
    /// estimated, whatever the identifiability analysis finds. Only before the first pass
    /// ([`LmError::Started`] after it); a parameter not in the list is refused.
    pub fn hold(&mut self, p: Param) -> Result<(), LmError> {
        if self.evaluations != 0 || self.next != 0 {
            return Err(LmError::Started);
        }
        let k = self
            .st
            .params()
            .iter()
            .position(|q| *q == p)
            .ok_or(LmError::Params(ParamError::OutOfRange))?;
        let parts = self.st.parts();
        parts.held[k] = true;
        parts.active[k] = false;
        Ok(())
    }

    /// True when the caller holds parameter `k` (position in [`Levenberg::params`]).
    pub fn is_held(&self, k: usize) -> bool {
        self.st.parts_ref().held.get(k).copied().unwrap_or(false)
    }

    /// The penalty `uᵀΠu` (mm²) at the current estimate (0 without a penalty; its weights are
    /// resolved at the end of the first pass).
    pub fn penalty(&self) -> T {
        let Some(q) = self.pen.parts_ref() else {
            return T::zero();
        };
        let total = self.st.parts_ref().total;
        q.value(|k| q.offset[k] + total[k])
    }

    /// The penalty's arrays (`None` without a penalty): its terms and their resolved weights.
    pub fn penalty_parts(&self) -> Option<PenaltyPartsRef<'_, T>> {
        self.pen.parts_ref()
    }

    /// The current estimate.
    pub fn robot(&self) -> &Robot<T, N, V> {
        &self.robot
    }
    /// The parameters being estimated.
    pub fn params(&self) -> &[Param] {
        self.st.params()
    }
    /// Parameters found unidentifiable (held at their start values; not those the caller
    /// holds); empty before the first pass.
    pub fn unidentifiable(&self) -> impl Iterator<Item = Param> + '_ {
        let p = self.st.parts_ref();
        self.st
            .params()
            .iter()
            .zip(p.active.iter().zip(p.held.iter()))
            .filter(|(_, (a, h))| !**a && !**h)
            .map(|(p, _)| *p)
    }
    /// True once identifiability has been analysed (after the first full pass).
    pub fn analysed(&self) -> bool {
        self.analysed
    }
    /// How many identifiability analyses the run has made (the first, re-analyses as the model
    /// moved, and the confirmation at the end).
    pub fn analyses(&self) -> u8 {
        self.analyses
    }
    /// True when parameter `k` (position in [`Levenberg::params`]) is being estimated.
    pub fn is_active(&self, k: usize) -> bool {
        self.st.parts_ref().active.get(k).copied().unwrap_or(false)
    }
    /// Element `(i, j)` of the scaled normal matrix `JᵀJ` of the last full pass (symmetric;
    /// `0` outside the parameter count). After a run that converged it belongs to the final
    /// model: covariance and confounding read it.
    pub fn normal_matrix(&self, i: usize, j: usize) -> T {
        let p = self.st.parts_ref();
        let n = self.st.params().len();
        if i >= n || j >= n {
            return T::zero();
        }
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        p.jtj[i * p.stride + j]
    }
    /// The column scale of parameter `k` (parameter = scaled value / scale).
    pub fn scale(&self, k: usize) -> T {
        self.st
            .parts_ref()
            .scale
            .get(k)
            .copied()
            .unwrap_or(T::one())
    }
    /// Where the run stands.
    pub fn progress(&self) -> LmProgress<T> {
        LmProgress {
            iteration: self.iteration,
            evaluations: self.evaluations,
            cost: self.cost,
            stopped: match self.phase {
                Phase::Done(s) => Some(s),
                _ => None,
            },
        }
    }

    /// Does at most `budget` poses of work (a solve counts as one unit and ends the call) and
    /// returns the progress. `data` must be the same slice on every call of a run.
    pub fn step<M: Observation<T, N>>(
        &mut self,
        data: &[M],
        budget: usize,
    ) -> Result<LmProgress<T>, LmError> {
        if self.n_poses == 0 {
            if data.is_empty() || 3 * data.len() < self.st.params().len() {
                return Err(LmError::TooFewMeasurements);
            }
            check_observations(&self.robot, data)?;
            self.n_poses = data.len();
        } else if data.len() != self.n_poses {
            return Err(LmError::DataChanged);
        }
        let mut left = budget;
        while left > 0 {
            match self.phase {
                Phase::Done(_) => break,
                Phase::Accumulate | Phase::Confirm(_) | Phase::Reanalyse | Phase::Evaluate => {
                    if self.next == 0 {
                        self.clear_normal_equations();
                    }
                    while left > 0 && self.next < self.n_poses {
                        self.accumulate(&data[self.next]);
                        self.next += 1;
                        left -= 1;
                    }
                    if self.next == self.n_poses {
                        self.end_pass();
                    }
                }
                Phase::Solve => {
                    self.solve();
                    break;
                }
            }
        }
        Ok(self.progress())
    }

    /// Runs to the end in one call (desktop use).
    pub fn run<M: Observation<T, N>>(&mut self, data: &[M]) -> Result<LmProgress<T>, LmError> {
        loop {
            let p = self.step(data, usize::MAX)?;
            if p.stopped.is_some() {
                return Ok(p);
            }
        }
    }

    /// The pass over the measurements the run needs next, for a caller who spreads it over
    /// workers ([`crate::identify::lm_pass`]); `None` while the next work is a solve, after the end, or
    /// when a [`Self::step`] call left a pass half done.
    pub fn pass(&self) -> Option<Pass<'_, T, N, V>> {
        let kind = match self.phase {
            Phase::Accumulate | Phase::Confirm(_) | Phase::Reanalyse => PassKind::Estimate,
            Phase::Evaluate => PassKind::Candidate,
            Phase::Solve | Phase::Done(_) => return None,
        };
        if self.next != 0 {
            return None;
        }
        let p = self.st.parts_ref();
        Some(Pass {
            kind,
            id: self.evaluations,
            robot: if kind == PassKind::Candidate {
                &self.candidate
            } else {
                &self.robot
            },
            columns: Columns {
                params: p.params,
                scale: p.scale,
                active: p.active,
                full: self.full_columns(),
                gradient_only: self.gradient_only(),
            },
        })
    }

    /// Ends the pending pass with the workers' `parts` (every measurement in exactly one part,
    /// each part filled by [`Pass::accumulate`] in this pass), summed in their order, and
    /// moves the run on as [`Self::step`] would at the end of the pass.
    ///
    /// The parts may come from another solver in the same state (same start, parameters and
    /// pass): the first passes of cross-validation fits from one model are sums of the folds'
    /// own parts, accumulated once.
    pub fn complete_pass<'p, P, I>(&mut self, parts: I) -> Result<LmProgress<T>, LmError>
    where
        P: LmStorage<T> + 'p,
        T: 'p,
        I: IntoIterator<Item = &'p PassPart<T, P>>,
        I::IntoIter: Clone,
    {
        if self.pass().is_none() {
            return Err(LmError::PassMismatch);
        }
        let parts = parts.into_iter();
        let n = self.st.params().len();
        let mut poses = 0usize;
        for part in parts.clone() {
            if part.id != Some(self.evaluations) || part.storage.params() != self.st.params() {
                return Err(LmError::PassMismatch);
            }
            poses = poses.saturating_add(part.poses);
        }
        if self.n_poses == 0 {
            if poses == 0 || 3 * poses < n {
                return Err(LmError::TooFewMeasurements);
            }
            self.n_poses = poses;
        } else if poses != self.n_poses {
            return Err(LmError::DataChanged);
        }
        let cost = parts.clone().fold(T::zero(), |c, part| c + part.cost);
        self.clear_normal_equations();
        let gradient_only = self.gradient_only();
        let p = self.st.parts();
        for part in parts {
            let q = part.storage.parts_ref();
            for i in 0..n {
                if !gradient_only {
                    let row = &mut p.jtj[i * p.stride..i * p.stride + i + 1];
                    for (v, w) in row.iter_mut().zip(&q.jtj[i * q.stride..]) {
                        *v += *w;
                    }
                }
                p.jtr[i] += q.jtr[i];
            }
        }
        self.acc_cost = cost;
        self.end_pass();
        Ok(self.progress())
    }

    fn clear_normal_equations(&mut self) {
        let n = self.st.params().len();
        let gradient_only = self.gradient_only();
        let p = self.st.parts();
        if gradient_only {
            p.jtr[..n].fill(T::zero());
        } else {
            clear_normal_equations(p.jtj, p.jtr, p.stride, n);
        }
        self.acc_cost = T::zero();
    }

    /// A pass that sums only `Jᵀr` and the cost: a candidate's, when the curvature is kept.
    fn gradient_only(&self) -> bool {
        self.cfg.keep_curvature && self.phase == Phase::Evaluate
    }

    /// Held columns enter the normal equations in full on the passes that decide
    /// identifiability (the first, a confirmation, a re-analysis); otherwise just their
    /// diagonal.
    fn full_columns(&self) -> bool {
        !self.analysed || matches!(self.phase, Phase::Confirm(_) | Phase::Reanalyse)
    }

    /// Adds one pose's residual and scaled Jacobian to the normal equations.
    fn accumulate<M: Observation<T, N>>(&mut self, m: &M) {
        let full = self.full_columns();
        let gradient_only = self.gradient_only();
        let (columns, mut sums) = split_parts(self.st.parts(), full, gradient_only);
        let robot = if self.phase == Phase::Evaluate {
            &self.candidate
        } else {
            &self.robot
        };
        self.acc_cost += accumulate_pose(&mut self.fk, robot, m, &columns, &mut sums);
    }

    /// The end of a pass: of a candidate's, accept or reject it; of the estimate's, decide what
    /// comes next.
    fn end_pass(&mut self) {
        if self.phase == Phase::Evaluate {
            self.cand_cost = self.acc_cost;
            self.end_evaluate();
        } else {
            self.end_accumulate();
        }
    }

    /// The end of a pass that accumulated the normal equations at the estimate.
    fn end_accumulate(&mut self) {
        self.factored = false;
        if self.evaluations == 0 {
            self.resolve_penalty();
        }
        self.next = 0;
        self.evaluations = self.evaluations.saturating_add(1);
        self.cost = self.acc_cost;
        if self.cfg.max_analyses == 0 {
            // No analysis: every parameter the caller does not hold is estimated.
            if !self.analysed {
                let p = self.st.parts();
                let n = p.params.len();
                for k in 0..n {
                    p.active[k] = !p.held[k];
                    p.analysed_diag[k] = p.jtj[k * p.stride + k];
                }
                self.analysed = true;
            }
            self.phase = match self.phase {
                Phase::Confirm(stop) => Phase::Done(stop),
                _ => Phase::Solve,
            };
            return;
        }
        self.phase = match self.phase {
            Phase::Confirm(stop) => {
                if self.analyse() {
                    Phase::Solve
                } else {
                    Phase::Done(stop)
                }
            }
            Phase::Reanalyse => {
                self.analyse();
                Phase::Solve
            }
            _ if !self.analysed => {
                self.analyse();
                Phase::Solve
            }
            // The held columns' off-diagonal terms are missing: one full pass.
            _ if self.held_column_grew() => Phase::Reanalyse,
            _ => Phase::Solve,
        };
    }

    /// The end of a pass at the candidate (its cost, and its normal equations in place of the
    /// estimate's): accept or reject it.
    fn end_evaluate(&mut self) {
        if !self.cfg.keep_curvature {
            self.factored = false;
        }
        self.next = 0;
        self.evaluations = self.evaluations.saturating_add(1);
        self.decide();
    }

    /// Resolves the penalty's relative weights from the first pass's normal matrix.
    fn resolve_penalty(&mut self) {
        let Some(q) = self.pen.parts() else {
            return;
        };
        let p = self.st.parts_ref();
        for (t, w) in q.terms.iter().zip(q.weights.iter_mut()) {
            *w = t.weight(|k| p.jtj[k * p.stride + k]);
        }
    }

    /// The penalty's `Π` entry `(i, j)` (solver positions, weights applied).
    fn penalty_entry(q: &PenaltyPartsRef<'_, T>, i: usize, j: usize) -> T {
        let mut v = T::zero();
        for (t, w) in q.terms.iter().zip(q.weights) {
            if i >= t.first && j >= t.first {
                let (a, b) = (i - t.first, j - t.first);
                if a < t.len && b < t.len {
                    v += *w * t.entry(a, b);
                }
            }
        }
        v
    }

    /// True when a held parameter's column has grown well beyond its size at the last
    /// analysis (the model moved to where the data may see it), and another analysis is allowed.
    fn held_column_grew(&self) -> bool {
        // One analysis stays in reserve for the confirmation at the end.
        if self.analyses.saturating_add(1) >= self.cfg.max_analyses {
            return false;
        }
        let n = self.st.params().len();
        let p = self.st.parts_ref();
        let diag = |k: usize| p.jtj[k * p.stride + k];
        let dmax = (0..n).fold(T::zero(), |a, k| a.max(diag(k)));
        (0..n).any(|k| {
            let d = diag(k);
            !p.active[k]
                && !p.held[k]
                && d > dmax * self.cfg.rank_tolerance * self.cfg.rank_tolerance
                && d > T::of(4.0) * p.analysed_diag[k]
        })
    }

    /// Once the run would stop at `stop`: confirm the held set with a full pass at the final
    /// model (its normal matrix is then complete for covariance and confounding reports), or
    /// stop when nothing is held or no analysis is left.
    fn finish(&mut self, stop: LmStop) {
        let n = self.st.params().len();
        let p = self.st.parts_ref();
        let held = (0..n).any(|k| !p.active[k] && !p.held[k]);
        if !held || self.analyses >= self.cfg.max_analyses {
            self.phase = Phase::Done(stop);
        } else {
            self.next = 0;
            self.phase = Phase::Confirm(stop);
        }
    }

    /// Decides which parameters the data determine at the current model (normal matrix of the
    /// last pass), preferring those estimated so far; true when the set changed.
    fn analyse(&mut self) -> bool {
        let n = self.st.params().len();
        let first = !self.analysed;
        let cfg = self.cfg;
        let pen = self.pen.parts_ref();
        let p = self.st.parts();
        let s = p.stride;
        // The diagonal goes to analysed_diag (kept for the growth test).
        for i in 0..n {
            p.analysed_diag[i] = p.jtj[i * s + i];
        }
        // With a penalty, the penalised normal matrix decides (a direction the penalty
        // determines is determined); its diagonal goes to `delta` (scratch).
        let d: &[T] = match &pen {
            Some(q) => {
                for i in 0..n {
                    p.delta[i] = p.jtj[i * s + i] + Self::penalty_entry(q, i, i);
                }
                p.delta
            }
            None => p.analysed_diag,
        };
        let dmax = d[..n].iter().fold(T::zero(), |a, b| a.max(*b));
        for i in 0..n {
            for j in 0..=i {
                let mut h = p.jtj[i * s + j];
                if let Some(q) = &pen {
                    if i.abs_diff(j) <= 2 {
                        h += Self::penalty_entry(q, i, j);
                    }
                }
                let v = if d[i] > T::zero() && d[j] > T::zero() {
                    h / (d[i] * d[j]).sqrt()
                } else {
                    T::zero()
                };
                p.work[i * s + j] = v;
                p.work[j * s + i] = v;
            }
        }
        p.before[..n].copy_from_slice(&p.active[..n]);
        // The first analysis has no estimate to prefer.
        let preferred: &[bool] = if first { &[] } else { &p.before[..n] };
        let rank = Flat::new(p.work, s)
            .and_then(|mut w| {
                pivoted_cholesky_preferring(
                    &mut w,
                    n,
                    p.order,
                    cfg.rank_tolerance,
                    preferred,
                    if first {
                        cfg.rank_tolerance
                    } else {
                        cfg.activation_tolerance
                    },
                )
            })
            .unwrap_or(0);
        p.active[..n].fill(false);
        for &k in p.order[..rank].iter() {
            // A column with no information at all (relative to the strongest) is dropped too,
            // and the caller's held ones stay held.
            if d[k] > dmax * T::EPS && !p.held[k] {
                p.active[k] = true;
            }
        }
        let changed = p.before[..n] != p.active[..n];
        self.analysed = true;
        self.analyses = self.analyses.saturating_add(1);
        changed
    }

    /// Solves the damped normal equations for a candidate step.
    fn solve(&mut self) {
        let n = self.st.params().len();
        let cfg = self.cfg;
        let lambda = self.lambda;
        let mut pen = self.pen.parts();
        let p = self.st.parts();
        let s = p.stride;
        // Compact the active parameters into the leading block of `work`.
        let mut m = 0;
        for k in 0..n {
            if p.active[k] {
                p.idx[m] = k;
                m += 1;
            }
        }
        if m == 0 {
            self.finish(LmStop::Converged);
            return;
        }
        let idx = &p.idx[..m];
        let mut mean_diag = T::zero();
        for &k in idx {
            mean_diag += p.jtj[k * s + k];
        }
        mean_diag /= T::of(m as f64);
        let mu = cfg.ridge * mean_diag;
        // With a penalty: `Π u` at the estimate, `Π`'s diagonal (the penalty's scratch), `uᵀΠu`,
        // and the position of every active parameter in the compacted block (`order`).
        let mut pen_cost = T::zero();
        if let Some(q) = &mut pen {
            let (offset, total) = (&*q.offset, &*p.total);
            let u = |k: usize| offset[k] + total[k];
            q.scratch[..n].fill(T::zero());
            q.diagonal[..n].fill(T::zero());
            for (t, w) in q.terms.iter().zip(q.weights.iter()) {
                for i in 0..t.len {
                    let k = t.first + i;
                    q.scratch[k] += *w * t.product(i, u);
                    q.diagonal[k] += *w * t.entry(i, i);
                }
            }
            for k in 0..n {
                pen_cost += u(k) * q.scratch[k];
            }
            for (a, &k) in idx.iter().enumerate() {
                p.order[k] = a;
            }
        }
        // The damping's diagonal: `JᵀJ`'s, plus `Π`'s with a penalty.
        let damping_diag = |k: usize| match &pen {
            Some(q) => p.jtj[k * s + k] + q.diagonal[k],
            None => p.jtj[k * s + k],
        };
        let mut lambda = lambda;
        // With the curvature kept and already factored, a step costs two triangular solves.
        let reused = self.factored && {
            for a in 0..m {
                p.g[a] = p.jtr[idx[a]] - mu * p.total[idx[a]];
                if let Some(q) = &pen {
                    p.g[a] -= q.scratch[idx[a]];
                }
            }
            p.x[..m].copy_from_slice(&p.g[..m]);
            S::resolve_work(p.work, s, p.x, m).is_ok() && p.x[..m].iter().all(|v| v.finite())
        };
        let outcome = if reused {
            Some(())
        } else {
            loop {
                for a in 0..m {
                    let ka = idx[a];
                    for b in 0..=a {
                        p.work[a * s + b] = p.jtj[ka * s + idx[b]];
                    }
                    let diag = damping_diag(ka);
                    p.work[a * s + a] = diag + lambda * diag.max(mean_diag * T::EPS) + mu;
                    p.g[a] = p.jtr[ka] - mu * p.total[ka];
                }
                if let Some(q) = &pen {
                    for a in 0..m {
                        p.g[a] -= q.scratch[idx[a]];
                    }
                    // Off-diagonal penalty entries between active parameters (a band of width 2
                    // within each term).
                    for (t, w) in q.terms.iter().zip(q.weights.iter()) {
                        for i in 1..t.len {
                            let ki = t.first + i;
                            if !p.active[ki] {
                                continue;
                            }
                            for j in i.saturating_sub(2)..i {
                                let kj = t.first + j;
                                if p.active[kj] {
                                    p.work[p.order[ki] * s + p.order[kj]] += *w * t.entry(i, j);
                                }
                            }
                        }
                    }
                }
                p.x[..m].copy_from_slice(&p.g[..m]);
                match S::solve_work(p.work, s, p.x, m) {
                    Ok(()) if p.x[..m].iter().all(|v| v.finite()) => break Some(()),
                    Ok(()) | Err(LinalgError::NotPositiveDefinite) | Err(LinalgError::Size) => {
                        // Not solvable at this damping: damp harder and retry, up to a limit.
                        lambda *= T::of(10.0);
                        if !(lambda < T::of(1e16)) {
                            break None;
                        }
                    }
                }
            }
        };
        self.factored = cfg.keep_curvature && outcome.is_some();
        self.lambda = lambda;
        if outcome.is_none() {
            self.phase = Phase::Done(LmStop::NoProgress);
            return;
        }
        // Predicted reduction of the (ridged, penalised) cost: xᵀ(2g − A x) = xᵀ(g + λ D x).
        let mut pred = T::zero();
        for a in 0..m {
            let diag = damping_diag(idx[a]);
            pred += p.x[a] * (p.g[a] + (lambda * diag.max(mean_diag * T::EPS)) * p.x[a]);
        }
        self.predicted = pred;
        p.step[..n].fill(T::zero());
        let mut norm2 = T::zero();
        for a in 0..m {
            p.step[idx[a]] = p.x[a];
            norm2 += p.x[a] * p.x[a];
        }
        if norm2.sqrt() < cfg.step_tolerance {
            self.finish(LmStop::SmallStep);
            return;
        }
        // Lightly damped (λ ≤ 1: at least about half the Gauss–Newton reduction), a step that
        // promises less than the cost tolerance is not worth a pass over the data: converged.
        // (Without this a run spends its last passes on steps that change the 13th digit.)
        if lambda <= T::one() && pred <= cfg.cost_tolerance * (self.cost + pen_cost) {
            self.finish(LmStop::Converged);
            return;
        }
        // Unscale into parameter units and build the candidate.
        for k in 0..n {
            p.delta[k] = p.step[k] / p.scale[k];
        }
        self.candidate.clone_from(&self.robot);
        if apply_delta(&mut self.candidate, p.params, &p.delta[..n]).is_err() {
            self.reject(Phase::Solve);
            return;
        }
        self.cand_cost = T::zero();
        self.next = 0;
        self.phase = Phase::Evaluate;
    }

    /// Rejects the step: damp harder and solve again, from the estimate's normal equations
    /// (`then`: `Solve` when they are still in place, `Accumulate` after a candidate's pass
    /// replaced them).
    fn reject(&mut self, then: Phase) {
        self.factored = false;
        self.lambda *= self.nu;
        self.nu *= T::of(2.0);
        self.iteration = self.iteration.saturating_add(1);
        if !(self.lambda < T::of(1e16)) {
            self.phase = Phase::Done(LmStop::NoProgress);
        } else if self.iteration >= self.cfg.max_iterations {
            self.phase = Phase::Done(LmStop::MaxIterations);
        } else {
            self.phase = then;
        }
    }

    /// Accepts or rejects the evaluated candidate (Nielsen's damping update). The ridge weight
    /// is taken from the candidate's normal matrix (now in place), the same for the old and the
    /// new cost.
    fn decide(&mut self) {
        let n = self.st.params().len();
        let p = self.st.parts();
        let s = p.stride;
        let mu = {
            let mut sum = T::zero();
            let mut m = 0;
            for k in 0..n {
                if p.active[k] {
                    sum += p.jtj[k * s + k];
                    m += 1;
                }
            }
            if m > 0 {
                self.cfg.ridge * sum / T::of(m as f64)
            } else {
                T::zero()
            }
        };
        // Ridge terms of old and new cost.
        let mut ridge_old = T::zero();
        let mut ridge_new = T::zero();
        for k in 0..n {
            ridge_old += p.total[k] * p.total[k];
            let t = p.total[k] + p.step[k];
            ridge_new += t * t;
        }
        let mut old = self.cost + mu * ridge_old;
        let mut new = self.cand_cost + mu * ridge_new;
        if let Some(q) = self.pen.parts_ref() {
            let (total, step) = (&*p.total, &*p.step);
            old += q.value(|k| q.offset[k] + total[k]);
            new += q.value(|k| q.offset[k] + total[k] + step[k]);
        }
        let actual = old - new;
        let rho = if self.predicted > T::zero() {
            actual / self.predicted
        } else {
            -T::one()
        };
        if rho > T::zero() && new.finite() {
            core::mem::swap(&mut self.robot, &mut self.candidate);
            for k in 0..n {
                p.total[k] += p.step[k];
            }
            let rel = actual / old.max(T::EPS);
            self.cost = self.cand_cost;
            let t = T::of(2.0) * rho - T::one();
            // (A kept factor stays valid only at the same damping: it changes when the
            // curvature is formed again.)
            let refresh = self.cfg.keep_curvature && rho < T::of(0.5);
            if !self.cfg.keep_curvature || refresh {
                self.lambda *= T::of(1.0 / 3.0).max(T::one() - t * t * t);
                self.factored = false;
            }
            self.nu = T::of(2.0);
            self.iteration = self.iteration.saturating_add(1);
            if rel < self.cfg.cost_tolerance {
                self.finish(LmStop::Converged);
            } else if self.iteration >= self.cfg.max_iterations {
                self.phase = Phase::Done(LmStop::MaxIterations);
            } else if self.cfg.keep_curvature {
                // The candidate's pass left its gradient; the curvature is an earlier point's,
                // formed afresh when it predicted the step poorly.
                self.phase = if refresh {
                    Phase::Accumulate
                } else {
                    Phase::Solve
                };
            } else {
                // The candidate's pass left its normal equations: the next solve's. (A held
                // column that grew needs the full ones first.)
                self.phase = if self.held_column_grew() {
                    Phase::Reanalyse
                } else {
                    Phase::Solve
                };
            }
        } else {
            self.reject(Phase::Accumulate);
        }
    }
}

/// Root-mean-square position error (mm) of `robot` over `data` (3-D distance per pose).
pub fn rms_error<T: Real, const N: usize, const V: usize, M: Observation<T, N>>(
    robot: &Robot<T, N, V>,
    data: &[M],
) -> T {
    if data.is_empty() {
        return T::zero();
    }
    let mut fk = ForwardKinematics::new();
    let mut s = T::zero();
    for m in data {
        // An observation of a point the robot does not have has no error: NaN, not a number.
        let p = fk
            .compute_at(robot, m.q(), m.tool(), m.temperature())
            .unwrap_or(Vector3::repeat(T::of(f64::NAN)));
        s += (m.point() - p).norm_squared();
    }
    (s / T::of(data.len() as f64)).sqrt()
}

/// Root-mean-square orientation error (rad, the angle between measured and model tool frame)
/// of `robot` over the 6-D observations in `data`; `None` when there are none.
pub fn rms_orientation_error<T: Real, const N: usize, const V: usize, M: Observation<T, N>>(
    robot: &Robot<T, N, V>,
    data: &[M],
) -> Option<T> {
    let mut fk = ForwardKinematics::new();
    let (mut s, mut n) = (T::zero(), 0usize);
    for m in data {
        let Some((o, _)) = m.orientation() else {
            continue;
        };
        if fk
            .compute_at(robot, m.q(), m.tool(), m.temperature())
            .is_none()
        {
            return Some(T::of(f64::NAN));
        }
        s += crate::model::frame::orientation_error(o, &fk.tool_pose(robot)).norm_squared();
        n += 1;
    }
    (n > 0).then(|| (s / T::of(n as f64)).sqrt())
}

mod snapshot;
