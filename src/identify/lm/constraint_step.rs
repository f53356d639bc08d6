//! A [`Levenberg`] run over constraint groups (sockets, planes, distances, tracker points:
//! [`crate::io::constraint`]) instead of tracker observations: the same phases, analysis,
//! snapshots and storage, a group at a time ([`super::constraint`]).

use super::constraint::{accumulate_group, constraint_scratch_len};
use super::levenberg::{Levenberg, Phase};
use super::normal::split_parts;
use super::penalty::LmPenalty;
use super::status::{LmError, LmProgress};
use super::storage::LmStorage;
use crate::io::constraint::{ConstraintGroup, ConstraintRow};
use crate::model::param::ParamError;
use crate::{Real, ValueStorage};

/// Checks a constraint session against the robot and the run: every group valid and within
/// the rows, every row finite and of a tool point the robot has, scratch enough, and more
/// residuals than the shapes' unknowns and the parameters.
fn check_session<T: Real, const N: usize, V: ValueStorage>(
    robot: &crate::Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
    groups: &[ConstraintGroup<T>],
    params: usize,
    scratch: usize,
) -> Result<(), LmError> {
    if scratch < constraint_scratch_len(params) {
        return Err(LmError::Params(ParamError::Shape));
    }
    let mut dof = 0usize;
    for g in groups {
        let Some(r) = g.rows(rows) else {
            return Err(LmError::BadGroup);
        };
        if !g.is_valid() {
            return Err(LmError::BadGroup);
        }
        if r.iter().any(|row| !row.is_valid()) {
            return Err(LmError::NonFiniteMeasurement);
        }
        if r.iter()
            .any(|row| row.tool as usize >= robot.tool_point_count())
        {
            return Err(LmError::UnknownToolPoint);
        }
        dof = dof.saturating_add(g.residual_rows().saturating_sub(g.unknowns()));
    }
    if groups.is_empty() || dof < params {
        return Err(LmError::TooFewMeasurements);
    }
    Ok(())
}

impl<T: Real, const N: usize, V: ValueStorage, Storage: LmStorage<T>, Penalty: LmPenalty<T>>
    Levenberg<T, N, V, Storage, Penalty>
{
    /// [`Self::step`] over a constraint session: `groups` of `rows` (the same slices on every
    /// call of a run), with `scratch` of at least [`constraint_scratch_len`] numbers for the
    /// parameters (the caller's; its contents need not survive between calls). Does one kind
    /// of work and returns the progress: at most `budget` rows, whole groups at a time (a
    /// group larger than the budget is done alone: a call's work is at most the larger of the
    /// budget and the largest group); or the end of a pass (the identifiability analysis, the
    /// acceptance of a step); or a solve.
    ///
    /// A socket's centre and a plane's normal and offset are estimated with the model (see
    /// [`super::constraint`]; [`super::constraint_shape`] gives them at the result). What the
    /// session cannot see is held and reported by [`Self::unidentifiable`]: the base and the
    /// first joint's offset from sockets, planes or distances alone; an overall scale from
    /// sockets and planes without a distance or tracker point (held by the analysis, given a
    /// `rank_tolerance` such as [`super::LmConfig::for_constraints`]'s).
    pub fn step_constraints(
        &mut self,
        rows: &[ConstraintRow<T, N>],
        groups: &[ConstraintGroup<T>],
        scratch: &mut [T],
        budget: usize,
    ) -> Result<LmProgress<T>, LmError> {
        let n = self.st.params().len();
        if self.n_poses == 0 {
            check_session(&self.robot, rows, groups, n, scratch.len())?;
            self.n_poses = groups.len();
        } else if groups.len() != self.n_poses {
            return Err(LmError::DataChanged);
        } else if scratch.len() < constraint_scratch_len(n) {
            return Err(LmError::Params(ParamError::Shape));
        }
        if budget == 0 {
            return Ok(self.progress());
        }
        // One kind of work per call: groups (up to the budget), the end of a pass (the
        // analysis), or a solve.
        match self.phase {
            Phase::Done(_) => {}
            Phase::Solve => self.solve(),
            _ if self.next == self.n_poses => self.end_pass(),
            _ => {
                if self.next == 0 {
                    self.clear_normal_equations();
                }
                let mut left = budget;
                let mut worked = false;
                while self.next < self.n_poses {
                    let g = &groups[self.next];
                    let len = g.len as usize;
                    if worked && len > left {
                        break;
                    }
                    self.accumulate_group(rows, g, scratch);
                    self.next += 1;
                    left = left.saturating_sub(len);
                    worked = true;
                }
            }
        }
        Ok(self.progress())
    }

    /// Runs a constraint session to the end in one call (desktop use).
    pub fn run_constraints(
        &mut self,
        rows: &[ConstraintRow<T, N>],
        groups: &[ConstraintGroup<T>],
        scratch: &mut [T],
    ) -> Result<LmProgress<T>, LmError> {
        loop {
            let p = self.step_constraints(rows, groups, scratch, usize::MAX)?;
            if p.stopped.is_some() {
                return Ok(p);
            }
        }
    }

    /// Adds one group to the pending pass.
    fn accumulate_group(
        &mut self,
        rows: &[ConstraintRow<T, N>],
        g: &ConstraintGroup<T>,
        scratch: &mut [T],
    ) {
        let full = self.full_columns();
        let gradient_only = self.gradient_only();
        let (columns, mut sums) =
            split_parts::<_, Storage>(self.st.parts(), full, gradient_only, false);
        let robot = if self.phase == Phase::Evaluate {
            &self.candidate
        } else {
            &self.robot
        };
        self.acc_cost +=
            accumulate_group(&mut self.fk, robot, rows, g, &columns, &mut sums, scratch);
    }
}
