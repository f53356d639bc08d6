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

use crate::identify::lm_pass::{accumulate_pose, clear_normal_equations, split_parts, Columns};
pub use crate::identify::lm_pass::{Pass, PassKind, PassPart};
use crate::identify::lm_storage::storage_fits;
pub use crate::identify::lm_storage::{FixedLm, LmParts, LmPartsRef, LmStorage};
use crate::model::param::{apply_delta, check_params, Param, ParamError};
use crate::num::linalg::{
    cholesky, cholesky_solve, pivoted_cholesky_preferring, Flat, LinalgError,
};
use crate::{ForwardKinematics, Measurement, Real, Robot};
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
    /// the starting model.
    pub max_analyses: u8,
    /// Relative pivot a held parameter needs to join on a re-analysis (stricter than
    /// `rank_tolerance`): moving off the nominal geometry turns exact dependencies (d of
    /// parallel axes) into near ones, which the data still cannot determine.
    pub activation_tolerance: T,
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
        }
    }
}

/// Why the solver refused a call.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LmError {
    /// No measurements, or fewer residuals than active parameters.
    TooFewMeasurements,
    /// The measurement slice changed length between calls.
    DataChanged,
    /// A measurement holds NaN or infinity.
    NonFiniteMeasurement,
    /// The parameter set does not fit the robot or the capacity.
    Params(ParamError),
    /// Parts handed to [`Levenberg::complete_pass`] are not of the pending pass, do not cover
    /// the data once, or hold other parameters; or no pass is pending.
    PassMismatch,
}

/// Why the solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LmStop {
    /// The cost stopped decreasing (relative change below tolerance).
    Converged,
    /// The step became negligibly small.
    SmallStep,
    /// The iteration limit was reached.
    MaxIterations,
    /// No step could lower the cost even with very strong damping.
    NoProgress,
}

/// Where a run stands after a [`Levenberg::step`] call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmProgress<T: Real> {
    pub iteration: u32,
    /// Full passes over all poses so far (model evaluations of all poses).
    pub evaluations: u32,
    /// Sum of squared residuals (mm²) at the current estimate (after the first pass).
    pub cost: T,
    /// `Some` once the run has finished.
    pub stopped: Option<LmStop>,
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
    Done(LmStop),
}

/// The Levenberg–Marquardt stepper for a robot with `N` joints and `V` effect values, over the
/// caller's storage `S` (the parameters and the normal equations: see [`crate::identify::lm_storage`]).
#[derive(Clone, Debug)]
pub struct Levenberg<T: Real, const N: usize, const V: usize, S: LmStorage<T>> {
    cfg: LmConfig<T>,
    robot: Robot<T, N, V>,
    candidate: Robot<T, N, V>,
    st: S,
    analysed: bool,
    /// Identifiability analyses done so far.
    analyses: u8,
    cost: T,
    acc_cost: T,
    cand_cost: T,
    lambda: T,
    nu: T,
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
    /// A solver starting from `start`, estimating the parameters of `storage` (all must exist
    /// in the robot, and the storage must have room for them).
    pub fn new(start: Robot<T, N, V>, mut storage: S, cfg: LmConfig<T>) -> Result<Self, LmError> {
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
        }
        Ok(Self {
            cfg,
            candidate: start.clone(),
            robot: start,
            st: storage,
            analysed: false,
            analyses: 0,
            cost: T::zero(),
            acc_cost: T::zero(),
            cand_cost: T::zero(),
            lambda: cfg.initial_damping,
            nu: T::of(2.0),
            predicted: T::zero(),
            next: 0,
            n_poses: 0,
            phase: Phase::Accumulate,
            iteration: 0,
            evaluations: 0,
            fk: ForwardKinematics::new(),
        })
    }

    /// The current estimate.
    pub fn robot(&self) -> &Robot<T, N, V> {
        &self.robot
    }
    /// The parameters being estimated.
    pub fn params(&self) -> &[Param] {
        self.st.params()
    }
    /// Parameters found unidentifiable (held at their start values); empty before the first pass.
    pub fn unidentifiable(&self) -> impl Iterator<Item = Param> + '_ {
        let active = self.st.parts_ref().active;
        self.st
            .params()
            .iter()
            .zip(active.iter())
            .filter(|(_, a)| !**a)
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
    pub fn step(
        &mut self,
        data: &[Measurement<T, N>],
        budget: usize,
    ) -> Result<LmProgress<T>, LmError> {
        if self.n_poses == 0 {
            if data.is_empty() || 3 * data.len() < self.st.params().len() {
                return Err(LmError::TooFewMeasurements);
            }
            if data.iter().any(|m| !m.is_finite()) {
                return Err(LmError::NonFiniteMeasurement);
            }
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
    pub fn run(&mut self, data: &[Measurement<T, N>]) -> Result<LmProgress<T>, LmError> {
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
            },
        })
    }

    /// Ends the pending pass with the workers' `parts` (every measurement in exactly one part,
    /// each part filled by [`Pass::accumulate`] in this pass), summed in slice order, and
    /// moves the run on as [`Self::step`] would at the end of the pass.
    pub fn complete_pass<P: LmStorage<T>>(
        &mut self,
        parts: &[PassPart<T, P>],
    ) -> Result<LmProgress<T>, LmError> {
        if self.pass().is_none() {
            return Err(LmError::PassMismatch);
        }
        let n = self.st.params().len();
        let mut poses = 0usize;
        for part in parts {
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
        let cost = parts.iter().fold(T::zero(), |c, part| c + part.cost);
        self.clear_normal_equations();
        let p = self.st.parts();
        for part in parts {
            let q = part.storage.parts_ref();
            for i in 0..n {
                let row = &mut p.jtj[i * p.stride..i * p.stride + i + 1];
                for (v, w) in row.iter_mut().zip(&q.jtj[i * q.stride..]) {
                    *v += *w;
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
        let p = self.st.parts();
        clear_normal_equations(p.jtj, p.jtr, p.stride, n);
        self.acc_cost = T::zero();
    }

    /// Held columns enter the normal equations in full on the passes that decide
    /// identifiability (the first, a confirmation, a re-analysis); otherwise just their
    /// diagonal.
    fn full_columns(&self) -> bool {
        !self.analysed || matches!(self.phase, Phase::Confirm(_) | Phase::Reanalyse)
    }

    /// Adds one pose's residual and scaled Jacobian to the normal equations.
    fn accumulate(&mut self, m: &Measurement<T, N>) {
        let full = self.full_columns();
        let (columns, mut sums) = split_parts(self.st.parts(), full);
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
        self.next = 0;
        self.evaluations += 1;
        self.cost = self.acc_cost;
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
        self.next = 0;
        self.evaluations += 1;
        self.decide();
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
                && d > dmax * self.cfg.rank_tolerance * self.cfg.rank_tolerance
                && d > T::of(4.0) * p.analysed_diag[k]
        })
    }

    /// Once the run would stop at `stop`: confirm the held set with a full pass at the final
    /// model (its normal matrix is then complete for covariance and confounding reports), or
    /// stop when nothing is held or no analysis is left.
    fn finish(&mut self, stop: LmStop) {
        let n = self.st.params().len();
        let held = self.st.parts_ref().active[..n].iter().any(|a| !*a);
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
        let p = self.st.parts();
        let s = p.stride;
        // The diagonal goes to analysed_diag (kept for the growth test).
        for i in 0..n {
            p.analysed_diag[i] = p.jtj[i * s + i];
        }
        let d = &*p.analysed_diag;
        let dmax = d[..n].iter().fold(T::zero(), |a, b| a.max(*b));
        for i in 0..n {
            for j in 0..=i {
                let v = if d[i] > T::zero() && d[j] > T::zero() {
                    p.jtj[i * s + j] / (d[i] * d[j]).sqrt()
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
            // A column with no information at all (relative to the strongest) is dropped too.
            if d[k] > dmax * T::EPS {
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
        let mut lambda = lambda;
        let outcome = loop {
            for a in 0..m {
                let ka = idx[a];
                for b in 0..=a {
                    p.work[a * s + b] = p.jtj[ka * s + idx[b]];
                }
                let diag = p.jtj[ka * s + ka];
                p.work[a * s + a] = diag + lambda * diag.max(mean_diag * T::EPS) + mu;
                p.g[a] = p.jtr[ka] - mu * p.total[ka];
            }
            p.x[..m].copy_from_slice(&p.g[..m]);
            let ok = Flat::new(&mut *p.work, s).and_then(|mut w| {
                cholesky(&mut w, m)?;
                cholesky_solve(&w, m, &mut p.x[..m])
            });
            match ok {
                Ok(()) if p.x[..m].iter().all(|v| v.finite()) => break Some(()),
                Ok(()) | Err(LinalgError::NotPositiveDefinite) | Err(LinalgError::Size) => {
                    // Not solvable at this damping: damp harder and retry, up to a limit.
                    lambda *= T::of(10.0);
                    if !(lambda < T::of(1e16)) {
                        break None;
                    }
                }
            }
        };
        self.lambda = lambda;
        if outcome.is_none() {
            self.phase = Phase::Done(LmStop::NoProgress);
            return;
        }
        // Predicted reduction of the (ridged) cost: xᵀ(2g − A x) = xᵀ(g + λ D x + … ).
        let mut pred = T::zero();
        for a in 0..m {
            let diag = p.jtj[idx[a] * s + idx[a]];
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
        if lambda <= T::one() && pred <= cfg.cost_tolerance * self.cost {
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
        self.lambda *= self.nu;
        self.nu *= T::of(2.0);
        self.iteration += 1;
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
        let old = self.cost + mu * ridge_old;
        let new = self.cand_cost + mu * ridge_new;
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
            self.lambda *= T::of(1.0 / 3.0).max(T::one() - t * t * t);
            self.nu = T::of(2.0);
            self.iteration += 1;
            if rel < self.cfg.cost_tolerance {
                self.finish(LmStop::Converged);
            } else if self.iteration >= self.cfg.max_iterations {
                self.phase = Phase::Done(LmStop::MaxIterations);
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
pub fn rms_error<T: Real, const N: usize, const V: usize>(
    robot: &Robot<T, N, V>,
    data: &[Measurement<T, N>],
) -> T {
    if data.is_empty() {
        return T::zero();
    }
    let mut fk = ForwardKinematics::new();
    let mut s = T::zero();
    for m in data {
        s += (m.point - fk.compute(robot, &m.q)).norm_squared();
    }
    (s / T::of(data.len() as f64)).sqrt()
}

mod snapshot_impl {
    //! Snapshot of the LM state: everything except scratch that the next phase rewrites.
    use super::*;
    use crate::io::snapshot::{
        restore_with, save_with, Decoder, Encoder, Kind, Snapshot, SnapshotError,
    };
    use crate::Frame;
    use embedded_io::{Read, Write};

    fn param_tag(p: Param) -> (u8, u16) {
        match p {
            Param::BaseX => (0, 0),
            Param::BaseY => (1, 0),
            Param::BaseZ => (2, 0),
            Param::BaseRx => (3, 0),
            Param::BaseRy => (4, 0),
            Param::BaseRz => (5, 0),
            Param::Alpha(i) => (6, i as u16),
            Param::A(i) => (7, i as u16),
            Param::Theta(i) => (8, i as u16),
            Param::D(i) => (9, i as u16),
            Param::Beta(i) => (10, i as u16),
            Param::ToolX => (11, 0),
            Param::ToolY => (12, 0),
            Param::ToolZ => (13, 0),
            Param::Effect(k) => (14, k),
        }
    }

    fn put_robot<T: Real, W: Write, const N: usize, const V: usize>(
        e: &mut Encoder<'_, W>,
        r: &Robot<T, N, V>,
    ) -> Result<(), SnapshotError> {
        let b = r.base();
        for v in [b.x, b.y, b.z, b.o] {
            e.reals(v.as_slice())?;
        }
        for j in r.joints() {
            e.reals(&[j.alpha, j.a, j.theta, j.d, j.beta, j.lower, j.upper])?;
        }
        e.reals(r.tool().as_slice())?;
        // The couplings are constant: stored so that a snapshot of another robot is refused.
        e.usize(r.couplings().len())?;
        for (joint, from, ratio) in r.couplings().iter() {
            e.usize(joint)?;
            e.usize(from)?;
            e.reals(&[ratio])?;
        }
        e.usize(r.effects().values().len())?;
        e.reals(r.effects().values())
    }

    /// Reads a robot into `r`, whose effect list must have the same shape.
    fn get_robot<T: Real, R: Read, const N: usize, const V: usize>(
        d: &mut Decoder<'_, R>,
        r: &mut Robot<T, N, V>,
    ) -> Result<(), SnapshotError> {
        let mut axes = [Vector3::<T>::zeros(); 4];
        for a in axes.iter_mut() {
            let mut v = [T::zero(); 3];
            d.reals(&mut v)?;
            *a = Vector3::new(v[0], v[1], v[2]);
        }
        let base = Frame {
            x: axes[0],
            y: axes[1],
            z: axes[2],
            o: axes[3],
        };
        let mut joints = *r.joints();
        for j in joints.iter_mut() {
            let mut v = [T::zero(); 7];
            d.reals(&mut v)?;
            *j = crate::Joint {
                alpha: v[0],
                a: v[1],
                theta: v[2],
                d: v[3],
                beta: v[4],
                lower: v[5],
                upper: v[6],
            };
        }
        let mut t = [T::zero(); 3];
        d.reals(&mut t)?;
        d.expect_shape(r.couplings().len())?;
        for (joint, from, ratio) in r.couplings().iter() {
            d.expect_shape(joint)?;
            d.expect_shape(from)?;
            let mut v = [T::zero(); 1];
            d.reals(&mut v)?;
            if v[0] != ratio {
                return Err(SnapshotError::Shape);
            }
        }
        d.expect_shape(r.effects().values().len())?;
        let (b, js, tool, eff) = r.parts_mut();
        d.reals(eff.values_mut())?;
        *b = base;
        *js = joints;
        *tool = Vector3::new(t[0], t[1], t[2]);
        r.refresh();
        Ok(())
    }

    /// A snapshot holds the parameter list, not the storage's capacity: it restores into any
    /// storage with room for the same parameters (fixed arrays or a host's heap).
    impl<T: Real, const N: usize, const V: usize, S: LmStorage<T> + Clone> Snapshot
        for Levenberg<T, N, V, S>
    {
        fn save<W: Write>(&self, w: &mut W) -> Result<(), SnapshotError> {
            let p = self.st.parts_ref();
            let s = p.stride;
            save_with::<T, W, _>(w, Kind::Levenberg, |e| {
                e.usize(N)?;
                e.usize(V)?;
                let n = p.params.len();
                e.usize(n)?;
                for q in p.params {
                    let (t, i) = param_tag(*q);
                    e.u8(t)?;
                    e.u16(i)?;
                }
                put_robot(e, &self.robot)?;
                put_robot(e, &self.candidate)?;
                for k in 0..n {
                    e.bool(p.active[k])?;
                }
                e.bool(self.analysed)?;
                e.u8(self.analyses)?;
                e.reals(&p.analysed_diag[..n])?;
                e.reals(&p.scale[..n])?;
                e.reals(&p.total[..n])?;
                for i in 0..n {
                    e.reals(&p.jtj[i * s..i * s + n])?;
                }
                e.reals(&p.jtr[..n])?;
                e.reals(&p.step[..n])?;
                e.reals(&[
                    self.cost,
                    self.acc_cost,
                    self.cand_cost,
                    self.lambda,
                    self.nu,
                    self.predicted,
                ])?;
                e.usize(self.next)?;
                e.usize(self.n_poses)?;
                let (ph, stop) = match self.phase {
                    Phase::Accumulate => (0, 0),
                    Phase::Solve => (1, 0),
                    Phase::Evaluate => (2, 0),
                    Phase::Done(s) => (3, s as u8),
                    Phase::Confirm(s) => (4, s as u8),
                    Phase::Reanalyse => (5, 0),
                };
                e.u8(ph)?;
                e.u8(stop)?;
                e.u32(self.iteration)?;
                e.u32(self.evaluations)
            })
        }

        fn restore<R: Read>(&mut self, r: &mut R) -> Result<(), SnapshotError> {
            let restored = restore_with::<T, R, _, _>(r, Kind::Levenberg, |d| {
                d.expect_shape(N)?;
                d.expect_shape(V)?;
                let n = self.st.params().len();
                d.expect_shape(n)?;
                for q in self.st.params() {
                    let (t, i) = param_tag(*q);
                    if d.u8()? != t || d.u16()? != i {
                        return Err(SnapshotError::Shape);
                    }
                }
                let mut s = self.clone();
                get_robot(d, &mut s.robot)?;
                get_robot(d, &mut s.candidate)?;
                let p = s.st.parts();
                let st = p.stride;
                for k in 0..n {
                    p.active[k] = d.bool()?;
                }
                s.analysed = d.bool()?;
                s.analyses = d.u8()?;
                d.reals(&mut p.analysed_diag[..n])?;
                d.reals(&mut p.scale[..n])?;
                d.reals(&mut p.total[..n])?;
                for i in 0..n {
                    d.reals(&mut p.jtj[i * st..i * st + n])?;
                }
                d.reals(&mut p.jtr[..n])?;
                d.reals(&mut p.step[..n])?;
                let bad_scale = p.scale[..n].iter().any(|x| !(*x > T::zero()));
                let mut v = [T::zero(); 6];
                d.reals(&mut v)?;
                [s.cost, s.acc_cost, s.cand_cost, s.lambda, s.nu, s.predicted] = v;
                s.next = d.usize()?;
                s.n_poses = d.usize()?;
                let ph = d.u8()?;
                let stop = d.u8()?;
                let reason = match stop {
                    0 => LmStop::Converged,
                    1 => LmStop::SmallStep,
                    2 => LmStop::MaxIterations,
                    3 => LmStop::NoProgress,
                    _ => return Err(SnapshotError::Invalid),
                };
                s.phase = match ph {
                    0 => Phase::Accumulate,
                    1 => Phase::Solve,
                    2 => Phase::Evaluate,
                    3 => Phase::Done(reason),
                    4 => Phase::Confirm(reason),
                    5 => Phase::Reanalyse,
                    _ => return Err(SnapshotError::Invalid),
                };
                s.iteration = d.u32()?;
                s.evaluations = d.u32()?;
                if s.next > s.n_poses || bad_scale {
                    return Err(SnapshotError::Invalid);
                }
                Ok(s)
            })?;
            *self = restored;
            Ok(())
        }
    }
}
