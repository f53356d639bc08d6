//! Online optimum experimental design: measure, update, propose the next pose, stop when the
//! tool point is known well enough (the outlook of Jost et al. 2017, done on the controller).
//!
//! After each measurement the stepper adds the pose's Jacobian block to the information
//! matrix (a rank-3 update), reports the predicted standard deviation of the tool point at
//! every working configuration, proposes the feasible pool pose that lowers the KPI most, and
//! says when the worst predicted standard deviation is at or below the target. Everything is
//! linearised at the stepper's model (the nominal one, or the latest identified one: build a
//! new stepper after re-identification, re-adding the measured poses).

// `!(x > y)` is deliberate: it is also true for NaN. Index loops mirror the formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::model::param::ParamSet;
use crate::planning::information::{scaled_rows, PoseRows};
use crate::planning::selection::{Basis, Candidate, Criterion, DesignState, PlanError};
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};

/// Where an online design stands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Status<T: Real, const WORKS: usize> {
    /// Measurements taken so far.
    pub measurements: usize,
    /// Predicted standard deviation of the tool point (mm, `√trace C_s`) per working
    /// configuration; `None` until every identifiable direction is determined.
    pub tool_std: Option<[T; WORKS]>,
    /// The largest of them (∞ while undetermined).
    pub worst_std: T,
    /// True once `worst_std` is at or below the target.
    pub reached: bool,
}

/// The online stepper for `N` joints, effect values kept in `V`, `P` parameters and `WORKS` working
/// configurations.
#[derive(Clone, Debug)]
pub struct OnlineDesign<
    T: Real,
    const N: usize,
    V: ValueStorage,
    const P: usize,
    const WORKS: usize,
> {
    robot: Robot<T, N, V>,
    params: ParamSet<P>,
    basis: Basis<T, P>,
    state: DesignState<T, P, WORKS>,
    works: usize,
    sigma: T,
    target_std: T,
    fk: ForwardKinematics<T, N>,
}

impl<T: Real, const N: usize, V: ValueStorage, const P: usize, const WORKS: usize>
    OnlineDesign<T, N, V, P, WORKS>
{
    /// A stepper for `robot` (the model used for the Jacobians), the identified `params`, the
    /// identifiable `basis` (e.g. from the pool), the working configurations `work`, noise
    /// `sigma` (mm per coordinate) and the target standard deviation (mm) of the tool point.
    pub fn new(
        robot: Robot<T, N, V>,
        params: ParamSet<P>,
        basis: Basis<T, P>,
        work: &[[T; N]],
        sigma: T,
        target_std: T,
    ) -> Result<Self, PlanError> {
        if work.is_empty() || work.len() > WORKS {
            return Err(PlanError::WorkConfigurations);
        }
        if basis.dim() != params.len()
            || !(sigma > T::zero())
            || !sigma.finite()
            || !target_std.finite()
        {
            return Err(PlanError::Size);
        }
        params.check(&robot).map_err(|_| PlanError::Size)?;
        let mut fk = ForwardKinematics::new();
        let mut rows: [PoseRows<T, P>; WORKS] = [[[T::zero(); P]; 3]; WORKS];
        for (r, q) in rows.iter_mut().zip(work.iter()) {
            fk.compute(&robot, q);
            let mut g = [[T::zero(); P]; 3];
            scaled_rows(&robot, &fk, params.as_slice(), &mut g).map_err(|_| PlanError::Size)?;
            *r = basis.reduce(&g);
        }
        let ridge = basis.per_pose() * T::EPS.sqrt();
        let state = DesignState::new(basis.rank(), &rows[..work.len()], ridge)?;
        Ok(Self {
            robot,
            params,
            basis,
            state,
            works: work.len(),
            sigma,
            target_std,
            fk,
        })
    }

    /// The Jacobian block of configuration `q` in identifiable coordinates.
    pub fn rows(&mut self, q: &[T; N]) -> Result<PoseRows<T, P>, PlanError> {
        self.fk.compute(&self.robot, q);
        let mut g = [[T::zero(); P]; 3];
        scaled_rows(&self.robot, &self.fk, self.params.as_slice(), &mut g)
            .map_err(|_| PlanError::Size)?;
        Ok(self.basis.reduce(&g))
    }

    /// Adds a measurement taken at `q` (rad) and returns the new status.
    pub fn add_measurement(&mut self, q: &[T; N]) -> Result<Status<T, WORKS>, PlanError> {
        if !q.iter().all(|v| v.finite()) {
            return Err(PlanError::Size);
        }
        let g = self.rows(q)?;
        self.state.add(&g)?;
        Ok(self.status())
    }

    /// Adds the pool candidate `index` as measured and marks it so it is not proposed again.
    pub fn add_candidate(
        &mut self,
        pool: &mut [Candidate<T, N, P>],
        index: usize,
    ) -> Result<Status<T, WORKS>, PlanError> {
        let c = pool.get_mut(index).ok_or(PlanError::PoolTooSmall)?;
        self.state.add(&c.rows)?;
        c.selected = true;
        Ok(self.status())
    }

    /// Predicted precision and whether the target is reached.
    pub fn status(&self) -> Status<T, WORKS> {
        let mut var = [T::zero(); WORKS];
        let known = self
            .state
            .tool_variances(self.sigma, &mut var[..self.works]);
        let inf = T::max_value().unwrap_or(T::one());
        let (tool_std, worst) = if known {
            let mut std = [T::zero(); WORKS];
            let mut worst = T::zero();
            for (s, v) in std.iter_mut().zip(var.iter()).take(self.works) {
                *s = v.max(T::zero()).sqrt();
                worst = worst.max(*s);
            }
            (Some(std), worst)
        } else {
            (None, inf)
        };
        Status {
            measurements: self.state.poses(),
            tool_std,
            worst_std: worst,
            reached: known && worst <= self.target_std,
        }
    }

    /// The unselected pool candidate (rows in this stepper's identifiable coordinates, see
    /// [`Basis::reduce_pool`]) whose measurement would lower the KPI most.
    pub fn propose(&self, pool: &[Candidate<T, N, P>]) -> Option<usize> {
        self.state.best(Criterion::Kpi, pool).map(|(i, _)| i)
    }

    /// The model the Jacobians are evaluated with.
    pub fn robot(&self) -> &Robot<T, N, V> {
        &self.robot
    }
}
