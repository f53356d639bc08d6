//! The [`Levenberg`] stepper: its state, its public calls, and the phases of a run (a pass
//! over the data, a solve, the acceptance of a step, the identifiability decisions), which
//! call into the modules beside it one way: a pass ([`super::pass`], [`super::normal`]), the
//! damped solve ([`super::solve`]), the analysis ([`super::analysis`]).

use super::analysis::{analyse, estimate_all, held_column_grew};
use super::config::LmConfig;
use super::normal::{
    accumulate_pose, clear_normal_equations, split_parts, tables_in_order, Columns, Reach,
};
use super::pass::{Pass, PassKind, PassPart};
use super::penalty::{check_penalty, LmPenalty, NoPenalty, PenaltyError, PenaltyPartsRef};
use super::residual::check_observations;
use super::solve::{solve, Solved};
use super::status::{LmError, LmProgress, LmStop};
use super::storage::{storage_fits, FixedLm, LmStorage};
use crate::io::measurement::Observation;
use crate::model::param::{apply_delta, check_params, value, Param, ParamError};
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};

/// Where a run stands between calls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Phase {
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

/// The Levenberg–Marquardt stepper for a robot with `N` joints and effect values kept in `V`,
/// over the caller's `Storage` (the parameters and the normal equations: an [`LmStorage`]) and
/// `Penalty` (none by default: an [`LmPenalty`]).
// `repr(C)`, in the order rustc chose before (storage, models, scalars, workspace, flags: no
// padding): rustc's own order puts the member with the largest niche first, so a niche new in
// one member moves all the others. When `ForwardKinematics` gained `temp_c: Option<T>`, `fk`
// (440 bytes in the firmware) went in front of the storage and LLVM addressed the LM pass's
// `JᵀJ` update differently: 9 more instructions per 4 entries on the M4F (`lm_pose_f32` 7,467
// -> 8,221, none of them new code).
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Levenberg<
    T: Real,
    const N: usize,
    V: ValueStorage,
    Storage: LmStorage<T>,
    Penalty: LmPenalty<T> = NoPenalty,
> {
    pub(super) st: Storage,
    pub(super) cfg: LmConfig<T>,
    pub(super) robot: Robot<T, N, V>,
    pub(super) candidate: Robot<T, N, V>,
    pub(super) pen: Penalty,
    pub(super) cost: T,
    pub(super) acc_cost: T,
    pub(super) cand_cost: T,
    pub(super) lambda: T,
    pub(super) nu: T,
    pub(super) predicted: T,
    pub(super) next: usize,
    pub(super) n_poses: usize,
    pub(super) iteration: u32,
    pub(super) evaluations: u32,
    pub(super) fk: ForwardKinematics<T, N>,
    pub(super) phase: Phase,
    pub(super) analysed: bool,
    /// `work` holds the factor of the damped system of the current `JᵀJ`, damping and active
    /// set (kept curvature only; not in snapshots: a restored run factors again, to the same
    /// numbers).
    pub(super) factored: bool,
    /// Identifiability analyses done so far.
    pub(super) analyses: u8,
}

/// A solver in fixed arrays with room for `P` parameters (firmware; small host problems).
pub type FixedLevenberg<T, const N: usize, V, const P: usize> = Levenberg<T, N, V, FixedLm<T, P>>;

impl<T: Real, const N: usize, V: ValueStorage, const P: usize> Levenberg<T, N, V, FixedLm<T, P>> {
    /// A solver in fixed arrays with room for the `P` parameters of `params`.
    pub fn fixed(
        start: Robot<T, N, V>,
        params: crate::model::param::ParamSet<P>,
        cfg: LmConfig<T>,
    ) -> Result<Self, LmError> {
        Self::new(start, FixedLm::new(params), cfg)
    }
}

impl<T: Real, const N: usize, V: ValueStorage, Storage: LmStorage<T>> Levenberg<T, N, V, Storage> {
    /// A solver starting from `start` (the nominal model or any other, e.g. a previous fit),
    /// estimating the parameters of `storage` (all must exist in the robot, and the storage
    /// must have room for them).
    pub fn new(start: Robot<T, N, V>, storage: Storage, cfg: LmConfig<T>) -> Result<Self, LmError> {
        Self::with_penalty(start, storage, NoPenalty, cfg)
    }
}

impl<T: Real, const N: usize, V: ValueStorage, Storage: LmStorage<T>, Penalty: LmPenalty<T>>
    Levenberg<T, N, V, Storage, Penalty>
{
    /// [`Levenberg::new`] minimising `Σ|r_i|² + uᵀΠu` with the caller's `penalty` (see
    /// [`crate::identify::lm`]); its terms must lie within the parameter list, its
    /// arrays have room for it, its weights and priors be finite (weights ≥ 0).
    pub fn with_penalty(
        start: Robot<T, N, V>,
        mut storage: Storage,
        mut penalty: Penalty,
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
    /// workers ([`crate::identify::lm`]); `None` while the next work is a solve, after the end, or
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
        let robot = if kind == PassKind::Candidate {
            &self.candidate
        } else {
            &self.robot
        };
        Some(Pass {
            kind,
            id: self.evaluations,
            robot,
            columns: Columns {
                params: p.params,
                scale: p.scale,
                reach: Reach::of_scales(&p.scale[..p.params.len().min(p.scale.len())]),
                active: p.active,
                full: self.full_columns(),
                gradient_only: self.gradient_only(),
                tables_in_order: tables_in_order(robot, p.params),
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

    pub(super) fn clear_normal_equations(&mut self) {
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
    pub(super) fn gradient_only(&self) -> bool {
        self.cfg.keep_curvature && self.phase == Phase::Evaluate
    }

    /// Held columns enter the normal equations in full on the passes that decide
    /// identifiability (the first, a confirmation, a re-analysis), and on every pass with
    /// `complete_passes`; otherwise just their diagonal.
    pub(super) fn full_columns(&self) -> bool {
        !self.analysed
            || self.complete_at_estimate()
            || matches!(self.phase, Phase::Confirm(_) | Phase::Reanalyse)
    }

    /// With `complete_passes` (and not `keep_curvature`, whose curvature is an earlier
    /// point's): the normal equations in place are complete (every column, held ones too) and
    /// the estimate's whenever the run is between passes, since every pass forms them in full
    /// and a rejected candidate's are formed again at the estimate; an analysis reads them.
    fn complete_at_estimate(&self) -> bool {
        self.cfg.complete_passes && !self.cfg.keep_curvature
    }

    /// What follows when a held column grew: with complete normal equations in place, the
    /// analysis on them and a solve; else a pass forming the held columns in full first.
    fn reanalysis(&mut self) -> Phase {
        if self.complete_at_estimate() {
            self.factored = false;
            self.analyse();
            Phase::Solve
        } else {
            Phase::Reanalyse
        }
    }

    /// Adds one pose's residual and scaled Jacobian to the normal equations.
    fn accumulate<M: Observation<T, N>>(&mut self, m: &M) {
        let full = self.full_columns();
        let gradient_only = self.gradient_only();
        let (mut columns, mut sums) =
            split_parts::<_, Storage>(self.st.parts(), full, gradient_only, false);
        if self.cfg.scale_by_products {
            let n = columns.params.len().min(columns.scale.len());
            columns.reach = Reach::of_scales(&columns.scale[..n]);
        }
        let robot = if self.phase == Phase::Evaluate {
            &self.candidate
        } else {
            &self.robot
        };
        self.acc_cost += accumulate_pose(&mut self.fk, robot, m, &columns, &mut sums);
    }

    /// The end of a pass: of a candidate's, accept or reject it; of the estimate's, decide what
    /// comes next.
    #[inline(never)]
    pub(super) fn end_pass(&mut self) {
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
                estimate_all(&mut self.st);
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
            // A held column grew: analyse again, from this pass when it formed every column;
            // else the held columns' off-diagonal terms are missing: one full pass.
            _ if self.held_column_grew() => self.reanalysis(),
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

    /// True when a held parameter's column has grown since the last analysis and another
    /// analysis is allowed ([`super::analysis`]).
    fn held_column_grew(&self) -> bool {
        held_column_grew(&self.cfg, self.analyses, &self.st)
    }

    /// Decides which parameters the data determine at the current model
    /// ([`super::analysis`]); true when the set changed.
    fn analyse(&mut self) -> bool {
        let first = !self.analysed;
        let changed = analyse(&self.cfg, first, &mut self.st, self.pen.parts_ref());
        self.analysed = true;
        self.analyses = self.analyses.saturating_add(1);
        changed
    }

    /// Solves the damped normal equations ([`super::solve`]) and moves on: to the candidate's
    /// pass, to the end of the run, or (a step the model refuses) to a harder damping.
    #[inline(never)]
    pub(super) fn solve(&mut self) {
        let outcome = solve(
            &self.cfg,
            self.cost,
            &mut self.lambda,
            &mut self.factored,
            &mut self.predicted,
            &mut self.st,
            self.pen.parts(),
        );
        match outcome {
            Solved::Stop(stop) => self.finish(stop),
            Solved::NoProgress => self.phase = Phase::Done(LmStop::NoProgress),
            Solved::Candidate => {
                let p = self.st.parts();
                let n = p.params.len();
                self.candidate.clone_from(&self.robot);
                if apply_delta(&mut self.candidate, p.params, &p.delta[..n]).is_err() {
                    self.reject(Phase::Solve);
                    return;
                }
                self.cand_cost = T::zero();
                self.next = 0;
                self.phase = Phase::Evaluate;
            }
        }
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
        } else if self.complete_at_estimate() {
            // What a confirming pass would form is in place: the same sums.
            self.factored = false;
            self.phase = if self.analyse() {
                Phase::Solve
            } else {
                Phase::Done(stop)
            };
        } else {
            self.next = 0;
            self.phase = Phase::Confirm(stop);
        }
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
                // The candidate's pass left its normal equations: the next solve's. A held
                // column that grew is analysed again: from them when they are complete, else
                // after a pass forming the held columns in full.
                self.phase = if self.held_column_grew() {
                    self.reanalysis()
                } else {
                    Phase::Solve
                };
            }
        } else {
            self.reject(Phase::Accumulate);
        }
    }
}
