//! A run's first pass taken from another run that ended where this one starts.
//!
//! A fit is often refitted from its own result: with a prior pulling the parameters towards
//! their file values, or over fewer parameters. The refit's first pass would evaluate every
//! pose at the model the first run ended at, and that run's last pass already formed those
//! normal equations: [`Levenberg::complete_first_pass_from`] copies them instead of passing
//! over the data again. The entries are the same sums (each entry of `JᵀJ` and `Jᵀr` is a sum
//! over the poses of its own two columns, whatever the other columns are), so the refit goes
//! on exactly as after its own pass when the two passes summed the poses in the same order
//! (both by [`Levenberg::step`], or both in the same parts: [`crate::identify::lm`]'s passes)
//! and scaled the columns alike: the refit takes the first run's column scales
//! ([`Levenberg::adopt_scales_of`]; a solver's own come from its start's reach, and a fit
//! moves the reach a little).

use super::levenberg::{Levenberg, Phase};
use super::normal::Reach;
use super::penalty::LmPenalty;
use super::status::{LmError, LmProgress, LmStop};
use super::storage::LmStorage;
use crate::model::param::value;
use crate::{Real, ValueStorage};

impl<T: Real, const N: usize, V: ValueStorage, Storage: LmStorage<T>, Penalty: LmPenalty<T>>
    Levenberg<T, N, V, Storage, Penalty>
{
    /// Takes `other`'s column scales for this run's parameters (all must be among `other`'s),
    /// before the run's first pass: the run then estimates in `other`'s scaled units. A
    /// solver's scales come from its start's reach ([`crate::model::param::Param::scale`]);
    /// a refit from a fit's result that adopts the fit's scales is the same refit,
    /// preconditioned as the fit was. Refused with [`LmError::PassMismatch`] (the run
    /// unchanged) after the run's first pass or for a parameter `other` lacks.
    pub fn adopt_scales_of<S2: LmStorage<T>, Q2: LmPenalty<T>>(
        &mut self,
        other: &Levenberg<T, N, V, S2, Q2>,
    ) -> Result<(), LmError> {
        if !(self.phase == Phase::Accumulate && self.evaluations == 0 && self.next == 0) {
            return Err(LmError::PassMismatch);
        }
        let n = self.st.params().len();
        let q = other.st.parts_ref();
        let p = self.st.parts();
        if p.scale.len() < n || p.params.len() < n || q.scale.len() < q.params.len() {
            return Err(LmError::PassMismatch);
        }
        let at = |param| q.params.iter().position(|x| *x == param);
        if p.params[..n].iter().any(|x| at(*x).is_none()) {
            return Err(LmError::PassMismatch);
        }
        // The penalty's offsets are the start's scaled distance from the prior: in the new
        // units too (checked finite before anything changes).
        let scales = |k: usize| at(p.params[k]).map_or(p.scale[k], |i| q.scale[i]);
        if let Some(pen) = self.pen.parts() {
            if pen.offset.len() < n || pen.prior.len() < n {
                return Err(LmError::PassMismatch);
            }
            let offset = |k: usize| {
                (value(&self.robot, p.params[k]).unwrap_or(T::zero()) - pen.prior[k]) * scales(k)
            };
            if (0..n).any(|k| !offset(k).finite()) {
                return Err(LmError::PassMismatch);
            }
            for k in 0..n {
                pen.offset[k] = offset(k);
            }
        }
        for k in 0..n {
            if let Some(i) = at(p.params[k]) {
                p.scale[k] = q.scale[i];
            }
        }
        Ok(())
    }

    /// Completes this run's first pass with the normal equations `done` ended with, as if the
    /// pass had run, after taking `done`'s column scales ([`Self::adopt_scales_of`]). `done` must have run over the same data (the caller's promise: the
    /// solver cannot see it) and converged ([`LmStop::Converged`] or [`LmStop::SmallStep`]:
    /// its normal equations are then its final model's) at exactly this run's start, forming
    /// every column this run estimates in its passes (estimated there, or
    /// [`LmConfig::complete_passes`](super::LmConfig::complete_passes)).
    ///
    /// Refused with [`LmError::PassMismatch`] otherwise, or when this run has passed over any
    /// data or its first pass sums only `Jᵀr`; the run is then unchanged and its own pass can
    /// follow.
    pub fn complete_first_pass_from<S2: LmStorage<T>, Q2: LmPenalty<T>>(
        &mut self,
        done: &Levenberg<T, N, V, S2, Q2>,
    ) -> Result<LmProgress<T>, LmError> {
        let fresh = self.phase == Phase::Accumulate && self.evaluations == 0 && self.next == 0;
        let converged = matches!(
            done.phase,
            Phase::Done(LmStop::Converged | LmStop::SmallStep)
        );
        if !fresh
            || self.cfg.keep_curvature
            || !converged
            || done.cfg.keep_curvature
            || done.n_poses == 0
            || self.robot != done.robot
        {
            return Err(LmError::PassMismatch);
        }
        let n = self.st.params().len();
        if done.n_poses.saturating_mul(3) < n {
            return Err(LmError::TooFewMeasurements);
        }
        let all_columns = done.cfg.complete_passes;
        let q = done.st.parts_ref();
        let m = q.params.len();
        {
            let p = self.st.parts();
            // A caller's storage that shrank since the solver checked it is refused, not
            // indexed.
            let square =
                |stride: usize, len: usize| stride.checked_mul(stride).is_some_and(|l| len >= l);
            if n > p.stride
                || m > q.stride
                || !square(p.stride, p.jtj.len())
                || !square(q.stride, q.jtj.len())
                || [p.jtr.len(), p.scale.len(), p.nz.len(), p.params.len()]
                    .iter()
                    .any(|l| *l < n)
                || [q.jtr.len(), q.scale.len(), q.active.len()]
                    .iter()
                    .any(|l| *l < m)
            {
                return Err(LmError::PassMismatch);
            }
            // Every parameter of this run among `done`'s, its column formed in full there.
            let formed = |x: &_| {
                q.params
                    .iter()
                    .position(|y| y == x)
                    .is_some_and(|i| all_columns || q.active[i])
            };
            if !p.params[..n].iter().all(formed) {
                return Err(LmError::PassMismatch);
            }
        }
        self.adopt_scales_of(done)?;
        let p = self.st.parts();
        let reach = |s: &[T]| Reach::of_scales(s).map(|r| r.mm);
        if reach(&p.scale[..n]) != reach(&q.scale[..m]) {
            return Err(LmError::PassMismatch);
        }
        // Where each parameter is in `done`'s list (in `nz`, a pose's scratch that the next
        // pass sets afresh).
        for k in 0..n {
            p.nz[k] = q.params.iter().position(|x| *x == p.params[k]).unwrap_or(0);
        }
        let (s, qs) = (p.stride, q.stride);
        for i in 0..n {
            let a = p.nz[i];
            for j in 0..=i {
                let b = p.nz[j];
                let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
                p.jtj[i * s + j] = q.jtj[hi * qs + lo];
            }
            p.jtr[i] = q.jtr[a];
        }
        self.n_poses = done.n_poses;
        self.acc_cost = done.cost;
        self.end_pass();
        Ok(self.progress())
    }
}
