//! One pass of a [`crate::identify::lm::Levenberg`] run over the measurements, spread over workers.
//!
//! A run alternates passes over all poses (accumulate the residuals and normal equations at
//! the estimate or at a candidate step) with solves of `P × P` systems. The passes are
//! where the time goes with many poses, and they are sums: each worker can take a slice of the
//! measurements into its own partial sums, and the solver adds the parts. [`Levenberg::pass`]
//! hands out the pass the run needs next (borrowing the solver immutably, so the workers may
//! share it), [`Pass::accumulate`] fills one [`PassPart`], and [`Levenberg::complete_pass`]
//! merges the parts and moves the run on. The outcome equals [`Levenberg::step`] over the same
//! data up to the order of summation; a caller who always cuts the data into the same parts
//! gets the same numbers whatever the number of threads.
//!
//! The library spawns nothing: the caller chooses the workers (host threads, or one core after
//! another) and owns each part's storage, as it owns the solver's.
//!
//! [`Levenberg::pass`]: crate::identify::lm::Levenberg::pass
//! [`Levenberg::complete_pass`]: crate::identify::lm::Levenberg::complete_pass
//! [`Levenberg::step`]: crate::identify::lm::Levenberg::step

use super::normal::{accumulate_pose, clear_normal_equations, split_parts, Columns};
use super::residual::check_observations;
use super::status::LmError;
use super::storage::LmStorage;
use crate::io::measurement::Observation;
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};

/// What a pass computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PassKind {
    /// Residuals and normal equations `JᵀJ`, `Jᵀr` at the current estimate.
    Estimate,
    /// The same at a candidate step: its cost decides the step, and when it is accepted (the
    /// usual case) its normal equations are the next iteration's.
    Candidate,
}

/// The pass a run needs next (see the [module](crate::identify::lm)). Borrowing the solver, it is shared by
/// the workers of one pass.
#[derive(Clone, Copy, Debug)]
pub struct Pass<'a, T: Real, const N: usize, V: ValueStorage> {
    pub(super) kind: PassKind,
    /// Which pass of the run this is (parts of another pass are refused).
    pub(super) id: u32,
    /// The model the pass evaluates (the estimate, or the candidate).
    pub(super) robot: &'a Robot<T, N, V>,
    pub(super) columns: Columns<'a, T>,
}

/// One worker's share of a pass: its partial sums, in storage for the solver's parameters
/// (only the normal equations `jtj`, `jtr` and the per-pose scratch `cx`, `cy`, `cz`, `nz` are
/// used;
/// the other arrays may be empty).
#[derive(Clone, Debug)]
pub struct PassPart<T: Real, Storage: LmStorage<T>> {
    pub(super) storage: Storage,
    pub(super) cost: T,
    pub(super) poses: usize,
    /// The pass these sums belong to (`None`: never used).
    pub(super) id: Option<u32>,
}

impl<T: Real, Storage: LmStorage<T>> PassPart<T, Storage> {
    /// A part with `storage` for the same parameters as the solver's.
    pub fn new(storage: Storage) -> Self {
        Self {
            storage,
            cost: T::zero(),
            poses: 0,
            id: None,
        }
    }

    /// Poses accumulated into this part in its pass.
    pub fn poses(&self) -> usize {
        self.poses
    }

    /// The part's sum of squared residuals (mm²).
    pub fn cost(&self) -> T {
        self.cost
    }

    /// The part's storage: its normal equations `JᵀJ` (lower triangle) and `Jᵀr` of the
    /// scaled columns over the poses accumulated in its pass (`parts_ref().jtj`, `.jtr`).
    pub fn storage(&self) -> &Storage {
        &self.storage
    }
}

impl<T: Real, const N: usize, V: ValueStorage> Pass<'_, T, N, V> {
    /// What this pass computes.
    pub fn kind(&self) -> PassKind {
        self.kind
    }

    /// The model this pass evaluates (the estimate, or the candidate).
    pub fn robot(&self) -> &Robot<T, N, V> {
        self.robot
    }

    /// Adds `poses` (a slice of the run's measurements; every pose in exactly one part) to
    /// `part`, starting it afresh when it last served another pass. `fk` is the worker's own
    /// scratch.
    pub fn accumulate<Storage: LmStorage<T>, M: Observation<T, N>>(
        &self,
        fk: &mut ForwardKinematics<T, N>,
        poses: &[M],
        part: &mut PassPart<T, Storage>,
    ) -> Result<(), LmError> {
        if part.storage.params() != self.columns.params || !part_fits(&mut part.storage) {
            return Err(LmError::PassMismatch);
        }
        check_observations(self.robot, poses)?;
        let n = self.columns.params.len();
        if part.id != Some(self.id) {
            part.id = Some(self.id);
            part.cost = T::zero();
            part.poses = 0;
            let p = part.storage.parts();
            if self.columns.gradient_only {
                p.jtr[..n].fill(T::zero());
            } else {
                clear_normal_equations(p.jtj, p.jtr, p.stride, n);
            }
        }
        let (_, mut sums) = split_parts::<_, Storage>(
            part.storage.parts(),
            self.columns.full,
            self.columns.gradient_only,
            true,
        );
        for m in poses {
            part.cost += accumulate_pose(fk, self.robot, m, &self.columns, &mut sums);
        }
        sums.flush(n);
        part.poses += poses.len();
        Ok(())
    }
}

/// Checks that a part's storage has room for what a pass writes: the normal equations and the
/// per-pose scratch (the solver's other arrays may be empty).
fn part_fits<T: Real, Storage: LmStorage<T>>(st: &mut Storage) -> bool {
    let n = st.params().len();
    let p = st.parts();
    p.stride >= n
        && p.stride
            .checked_mul(p.stride)
            .is_some_and(|m| p.jtj.len() >= m)
        && p.jtr.len() >= n
        && [p.cx.len(), p.cy.len(), p.cz.len()].iter().all(|l| *l >= n)
        && p.nz.len() >= n
}
