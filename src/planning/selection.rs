//! Measurement planning: choose `n` poses from a pool of feasible candidates so that the
//! identified model predicts the tool point best where the robot works (Jost et al. 2017's
//! KPI design), or by a classical criterion (D, A).
//!
//! The paper optimises the poses continuously with SQP; here the poses are *selected* from a
//! pool of feasible configurations (see [`crate::planning::pose_pool`]), which makes every constraint
//! exact and the code allocation-free: greedy construction, then Fedorov exchange passes
//! (remove one pose, add the best candidate, keep the swap when it helps) until a pass changes
//! nothing. Every trial is a rank-3 update of the information matrix, evaluated through the
//! Woodbury identity with the 3×3 matrix `S = I + G M⁻¹ Gᵀ`:
//!
//! - D: gain `ln det S` (the increase of `ln det M`);
//! - A: gain `trace(S⁻¹ U Uᵀ)`, `U = G M⁻¹` (the decrease of `trace M⁻¹`);
//! - KPI: gain `trace(S⁻¹ (U Lᵀ)(U Lᵀ)ᵀ)`, `L` the stacked tool Jacobians at the working
//!   configurations (the decrease of `trace L M⁻¹ Lᵀ`).
//!
//! Each costs `3r²` for `U` plus `O(r)`, `r` the number of identifiable directions.
//! Coordinates are reduced to the identifiable subspace first ([`Basis`]): the structural null
//! directions are the same for every pose, so they are removed once, from the pool's
//! information, and the information matrix of any useful design is then invertible. A tiny
//! ridge keeps it invertible while the first poses are being chosen.

// `!(x > y)` is deliberate: it is also true for NaN. Index loops mirror the formulas.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::num::linalg::{cholesky, symmetric_eigen, LinalgError, Square};
use crate::planning::information::{Information, PoseRows};
use crate::Real;
use heapless::Vec;

/// What a design minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Criterion {
    /// Maximise `det JᵀJ` (equivalently Borm & Menq's O1 for a fixed number of poses).
    D,
    /// Minimise the trace of the parameter covariance.
    A,
    /// Minimise the summed variance of the tool point at the working configurations.
    Kpi,
}

/// Why planning failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlanError {
    /// The pool has fewer unselected candidates than poses requested, or no poses requested.
    PoolTooSmall,
    /// More working configurations than the capacity, or none for the KPI criterion.
    WorkConfigurations,
    /// A dimension exceeds a capacity, or a Jacobian holds NaN/inf.
    Size,
    /// The information matrix lost positive definiteness (a ridge of zero, or NaN input).
    Numerical,
}

impl From<LinalgError> for PlanError {
    fn from(e: LinalgError) -> Self {
        match e {
            LinalgError::Size => PlanError::Size,
            LinalgError::NotPositiveDefinite => PlanError::Numerical,
        }
    }
}

/// A feasible configuration of the pool with its Jacobian block (scaled parameters, or the
/// identifiable coordinates after [`Basis::reduce_pool`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate<T: Real, const N: usize, const P: usize> {
    /// Joint readings (rad).
    pub q: [T; N],
    /// The pose's three rows of the scaled identification Jacobian.
    pub rows: PoseRows<T, P>,
    /// Angle of incidence (rad) at this pose.
    pub incidence: T,
    /// Smallest collision clearance (mm) at this pose.
    pub clearance: T,
    /// Part of the current design (set by the planner).
    pub selected: bool,
}

/// An orthonormal basis of the identifiable subspace of the scaled parameters: the
/// eigenvectors of a rich information matrix (the whole pool's) above a relative threshold.
#[derive(Clone, Debug, PartialEq)]
pub struct Basis<T: Real, const P: usize> {
    /// Columns `0..rank` are the basis vectors (weakest first).
    vectors: Square<T, P>,
    n: usize,
    rank: usize,
    /// Mean eigenvalue per pose of the information the basis was built from: the natural
    /// size of one pose's information, used to size the ridge.
    per_pose: T,
}

impl<T: Real, const P: usize> Basis<T, P> {
    /// The identifiable subspace of `info` (directions with eigenvalue above `tol·λmax`).
    pub fn new(info: &Information<T, P>, tol: T) -> Result<Self, PlanError> {
        let n = info.dim();
        let mut a = *info.matrix();
        let mut values = [T::zero(); P];
        let mut v = [[T::zero(); P]; P];
        symmetric_eigen(&mut a, n, &mut values, &mut v)?;
        let max = if n > 0 { values[n - 1] } else { T::zero() };
        if !(max > T::zero()) || !max.finite() {
            return Err(PlanError::Numerical);
        }
        let first = values
            .iter()
            .take(n)
            .position(|l| *l > tol * max)
            .unwrap_or(n);
        let rank = n - first;
        let mut vectors = [[T::zero(); P]; P];
        let mut sum = T::zero();
        for k in 0..rank {
            sum += values[first + k];
            for i in 0..n {
                vectors[i][k] = v[i][first + k];
            }
        }
        let poses = T::of(info.poses().max(1) as f64);
        Ok(Self {
            vectors,
            n,
            rank,
            per_pose: sum / (T::of(rank.max(1) as f64) * poses),
        })
    }

    /// Dimension of the identifiable subspace.
    pub fn rank(&self) -> usize {
        self.rank
    }
    /// Number of scaled parameters.
    pub fn dim(&self) -> usize {
        self.n
    }
    /// Mean information per pose and direction (see the field's doc).
    pub fn per_pose(&self) -> T {
        self.per_pose
    }

    /// Rows in identifiable coordinates: `G·V` (first `rank` columns; the rest zero).
    pub fn reduce(&self, g: &PoseRows<T, P>) -> PoseRows<T, P> {
        let mut out = [[T::zero(); P]; 3];
        for (o, row) in out.iter_mut().zip(g.iter()) {
            for k in 0..self.rank {
                let mut s = T::zero();
                for i in 0..self.n {
                    s += row[i] * self.vectors[i][k];
                }
                o[k] = s;
            }
        }
        out
    }

    /// Reduces every candidate's rows in place.
    pub fn reduce_pool<const N: usize>(&self, pool: &mut [Candidate<T, N, P>]) {
        for c in pool.iter_mut() {
            c.rows = self.reduce(&c.rows);
        }
    }
}

/// Information of a growing design in identifiable coordinates, its (ridged) inverse, and the
/// working-configuration Jacobians: everything the rank-3 trial updates need.
#[derive(Clone, Debug, PartialEq)]
pub struct DesignState<T: Real, const P: usize, const WORKS: usize> {
    r: usize,
    m: Square<T, P>,
    minv: Square<T, P>,
    work: Vec<PoseRows<T, P>, WORKS>,
    ridge: T,
    poses: usize,
}

/// Inverse of the SPD 3×3 matrix `s` (adjugate); `None` when not positive definite.
fn inv3<T: Real>(s: &[[T; 3]; 3]) -> Option<[[T; 3]; 3]> {
    let c00 = s[1][1] * s[2][2] - s[1][2] * s[2][1];
    let c01 = s[0][2] * s[2][1] - s[0][1] * s[2][2];
    let c02 = s[0][1] * s[1][2] - s[0][2] * s[1][1];
    let det = s[0][0] * c00 + s[1][0] * c01 + s[2][0] * c02;
    if !(det > T::zero()) || !det.finite() {
        return None;
    }
    let c11 = s[0][0] * s[2][2] - s[0][2] * s[2][0];
    let c12 = s[0][2] * s[1][0] - s[0][0] * s[1][2];
    let c22 = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    let d = T::one() / det;
    Some([
        [c00 * d, c01 * d, c02 * d],
        [c01 * d, c11 * d, c12 * d],
        [c02 * d, c12 * d, c22 * d],
    ])
}

impl<T: Real, const P: usize, const WORKS: usize> DesignState<T, P, WORKS> {
    /// An empty design in `r` identifiable coordinates; `work` are the reduced tool Jacobians
    /// of the working configurations; `ridge` (absolute, > 0) is added to the diagonal of
    /// the information before inverting.
    pub fn new(r: usize, work: &[PoseRows<T, P>], ridge: T) -> Result<Self, PlanError> {
        if r > P || r == 0 {
            return Err(PlanError::Size);
        }
        if !(ridge > T::zero()) || !ridge.finite() {
            return Err(PlanError::Numerical);
        }
        let mut w = Vec::new();
        for g in work {
            w.push(*g).map_err(|_| PlanError::WorkConfigurations)?;
        }
        let mut s = Self {
            r,
            m: [[T::zero(); P]; P],
            minv: [[T::zero(); P]; P],
            work: w,
            ridge,
            poses: 0,
        };
        s.refactor()?;
        Ok(s)
    }

    /// Number of poses in the design.
    pub fn poses(&self) -> usize {
        self.poses
    }
    /// Number of identifiable coordinates `r`.
    pub fn rank(&self) -> usize {
        self.r
    }
    /// The information in identifiable coordinates (without the ridge).
    pub fn information(&self) -> &Square<T, P> {
        &self.m
    }

    /// Recomputes `(M + ridge·I)⁻¹` by Cholesky (cheap next to a pass over the pool, and it
    /// keeps rounding from accumulating over many updates).
    fn refactor(&mut self) -> Result<(), PlanError> {
        let r = self.r;
        let mut l = self.m;
        for (i, row) in l.iter_mut().enumerate().take(r) {
            row[i] += self.ridge;
        }
        cholesky(&mut l, r)?;
        // L⁻¹ (lower), then M⁻¹ = L⁻ᵀ L⁻¹.
        let mut li = [[T::zero(); P]; P];
        for j in 0..r {
            li[j][j] = T::one() / l[j][j];
            for i in j + 1..r {
                let mut s = T::zero();
                for k in j..i {
                    s += l[i][k] * li[k][j];
                }
                li[i][j] = -s / l[i][i];
            }
        }
        for i in 0..r {
            for j in 0..=i {
                let mut s = T::zero();
                for k in i..r {
                    s += li[k][i] * li[k][j];
                }
                self.minv[i][j] = s;
                self.minv[j][i] = s;
            }
        }
        Ok(())
    }

    fn update(&mut self, g: &PoseRows<T, P>, sign: T) -> Result<(), PlanError> {
        let r = self.r;
        if g.iter().any(|row| row.iter().take(r).any(|v| !v.finite())) {
            return Err(PlanError::Size);
        }
        for i in 0..r {
            let (a, b, c) = (g[0][i] * sign, g[1][i] * sign, g[2][i] * sign);
            for j in 0..r {
                self.m[i][j] += a * g[0][j] + b * g[1][j] + c * g[2][j];
            }
        }
        self.refactor()
    }

    /// Adds a measured pose (reduced rows).
    pub fn add(&mut self, g: &PoseRows<T, P>) -> Result<(), PlanError> {
        let old = self.m;
        match self.update(g, T::one()) {
            Ok(()) => {
                self.poses += 1;
                Ok(())
            }
            Err(e) => {
                self.m = old;
                Err(e)
            }
        }
    }

    /// Removes a pose added before.
    pub fn remove(&mut self, g: &PoseRows<T, P>) -> Result<(), PlanError> {
        let old = self.m;
        match self.update(g, -T::one()) {
            Ok(()) => {
                self.poses = self.poses.saturating_sub(1);
                Ok(())
            }
            Err(e) => {
                self.m = old;
                let _ = self.refactor();
                Err(e)
            }
        }
    }

    /// How much adding the pose `g` improves `criterion` (larger is better, ≥ 0): see the
    /// module docs. Non-finite rows give −∞.
    pub fn gain(&self, criterion: Criterion, g: &PoseRows<T, P>) -> T {
        let r = self.r;
        let mut u = [[T::zero(); P]; 3];
        for i in 0..r {
            let row = &self.minv[i];
            let (mut s0, mut s1, mut s2) = (T::zero(), T::zero(), T::zero());
            for j in 0..r {
                let m = row[j];
                s0 += m * g[0][j];
                s1 += m * g[1][j];
                s2 += m * g[2][j];
            }
            u[0][i] = s0;
            u[1][i] = s1;
            u[2][i] = s2;
        }
        let dot = |a: &[T; P], b: &[T; P]| {
            let mut s = T::zero();
            for k in 0..r {
                s += a[k] * b[k];
            }
            s
        };
        let mut s = [[T::zero(); 3]; 3];
        for a in 0..3 {
            for b in a..3 {
                let v = dot(&u[a], &g[b]) + if a == b { T::one() } else { T::zero() };
                s[a][b] = v;
                s[b][a] = v;
            }
        }
        let bad = -T::max_value().unwrap_or(T::one());
        let sinv = match inv3(&s) {
            Some(x) => x,
            None => return bad,
        };
        let mut q = [[T::zero(); 3]; 3];
        match criterion {
            Criterion::D => {
                let det = s[0][0] * (s[1][1] * s[2][2] - s[1][2] * s[2][1])
                    - s[0][1] * (s[1][0] * s[2][2] - s[1][2] * s[2][0])
                    + s[0][2] * (s[1][0] * s[2][1] - s[1][1] * s[2][0]);
                return if det > T::zero() { det.ln() } else { bad };
            }
            Criterion::A => {
                for a in 0..3 {
                    for b in a..3 {
                        let v = dot(&u[a], &u[b]);
                        q[a][b] = v;
                        q[b][a] = v;
                    }
                }
            }
            Criterion::Kpi => {
                for w in self.work.iter() {
                    let mut z = [[T::zero(); 3]; 3];
                    for a in 0..3 {
                        for m in 0..3 {
                            z[a][m] = dot(&u[a], &w[m]);
                        }
                    }
                    for a in 0..3 {
                        for b in 0..3 {
                            q[a][b] += z[a][0] * z[b][0] + z[a][1] * z[b][1] + z[a][2] * z[b][2];
                        }
                    }
                }
            }
        }
        let mut t = T::zero();
        for a in 0..3 {
            for b in 0..3 {
                t += sinv[a][b] * q[b][a];
            }
        }
        if t.finite() {
            t
        } else {
            bad
        }
    }

    /// Current value of `criterion` with the ridge: `−ln det(M + ridge·I)` for D,
    /// `trace (M + ridge·I)⁻¹` for A, `trace L (M + ridge·I)⁻¹ Lᵀ` for KPI (σ = 1).
    pub fn objective(&self, criterion: Criterion) -> T {
        let r = self.r;
        match criterion {
            Criterion::D => {
                let mut l = self.m;
                for (i, row) in l.iter_mut().enumerate().take(r) {
                    row[i] += self.ridge;
                }
                if cholesky(&mut l, r).is_err() {
                    return T::max_value().unwrap_or(T::one());
                }
                let mut s = T::zero();
                for (i, row) in l.iter().enumerate().take(r) {
                    s += row[i].ln();
                }
                -(s + s)
            }
            Criterion::A => (0..r).fold(T::zero(), |acc, i| acc + self.minv[i][i]),
            Criterion::Kpi => self.kpi_trace_with(&self.minv),
        }
    }

    fn kpi_trace_with(&self, minv: &Square<T, P>) -> T {
        let r = self.r;
        let mut t = T::zero();
        for w in self.work.iter() {
            for row in w.iter() {
                for i in 0..r {
                    let mut s = T::zero();
                    for j in 0..r {
                        s += minv[i][j] * row[j];
                    }
                    t += row[i] * s;
                }
            }
        }
        t
    }

    /// Predicted tool-point variance (mm², trace of `C_s`) at each working configuration for
    /// noise `sigma`, from the information *without* the ridge; `false` (and `out` untouched)
    /// while the design does not yet determine every identifiable direction.
    pub fn tool_variances(&self, sigma: T, out: &mut [T]) -> bool {
        let r = self.r;
        let mut l = self.m;
        // Relative pivot test: the design must see every direction clearly.
        let mut dmax = T::zero();
        for (i, row) in l.iter().enumerate().take(r) {
            dmax = dmax.max(row[i]);
        }
        if cholesky(&mut l, r).is_err() {
            return false;
        }
        for (i, row) in l.iter().enumerate().take(r) {
            if !(row[i] * row[i] > dmax * T::EPS * T::of(64.0)) {
                return false;
            }
        }
        let s2 = sigma * sigma;
        for (o, w) in out.iter_mut().zip(self.work.iter()) {
            let mut t = T::zero();
            for row in w.iter() {
                // ‖L⁻¹ g‖² = g M⁻¹ gᵀ.
                let mut y = [T::zero(); P];
                for i in 0..r {
                    let mut s = row[i];
                    for k in 0..i {
                        s -= l[i][k] * y[k];
                    }
                    y[i] = s / l[i][i];
                    t += y[i] * y[i];
                }
            }
            *o = t * s2;
        }
        true
    }

    /// Index of the unselected candidate with the largest gain, and the gain.
    pub fn best<const N: usize>(
        &self,
        criterion: Criterion,
        pool: &[Candidate<T, N, P>],
    ) -> Option<(usize, T)> {
        let mut best: Option<(usize, T)> = None;
        for (i, c) in pool.iter().enumerate() {
            if c.selected {
                continue;
            }
            let g = self.gain(criterion, &c.rows);
            if best.is_none_or(|(_, b)| g > b) {
                best = Some((i, g));
            }
        }
        best
    }
}

/// How a selection went.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome<T: Real> {
    /// Exchange passes made (the last one changed nothing unless the limit was hit).
    pub passes: u32,
    /// Swaps accepted over all passes.
    pub exchanges: u32,
    /// Objective after greedy construction and at the end ([`DesignState::objective`]).
    pub greedy_objective: T,
    /// Objective at the end.
    pub objective: T,
}

/// Selects `design.len()` poses from `pool` (reduced rows) minimising `criterion`: greedy
/// construction, then at most `max_passes` Fedorov exchange passes. On return `design` holds
/// pool indices and exactly those candidates are marked `selected`; `state` holds the final
/// information. Candidates already marked `selected` on entry are cleared first.
pub fn select<T: Real, const N: usize, const P: usize, const WORKS: usize>(
    state: &mut DesignState<T, P, WORKS>,
    criterion: Criterion,
    pool: &mut [Candidate<T, N, P>],
    design: &mut [usize],
    max_passes: u32,
) -> Result<Outcome<T>, PlanError> {
    let n = design.len();
    if n == 0 || pool.len() < n {
        return Err(PlanError::PoolTooSmall);
    }
    if criterion == Criterion::Kpi && state.work.is_empty() {
        return Err(PlanError::WorkConfigurations);
    }
    for c in pool.iter_mut() {
        c.selected = false;
    }
    // Greedy.
    for slot in design.iter_mut() {
        let (i, _) = state.best(criterion, pool).ok_or(PlanError::PoolTooSmall)?;
        let rows = pool[i].rows;
        state.add(&rows)?;
        pool[i].selected = true;
        *slot = i;
    }
    let greedy_objective = state.objective(criterion);
    let (passes, exchanges) = exchange(state, criterion, pool, design, max_passes)?;
    Ok(Outcome {
        passes,
        exchanges,
        greedy_objective,
        objective: state.objective(criterion),
    })
}

/// Fedorov exchange passes on an existing design: `design` holds pool indices whose
/// candidates are marked `selected` and whose rows `state` contains. Each pass tries every
/// slot: remove its pose, add the best unselected candidate (or the same pose back), keep
/// the swap when it helps. Stops after a pass without a swap or after `max_passes`. Returns
/// the passes made and the swaps accepted. [`select`] ends with it; call it again after the
/// pool has grown (for example by poses near the selected ones).
pub fn exchange<T: Real, const N: usize, const P: usize, const WORKS: usize>(
    state: &mut DesignState<T, P, WORKS>,
    criterion: Criterion,
    pool: &mut [Candidate<T, N, P>],
    design: &mut [usize],
    max_passes: u32,
) -> Result<(u32, u32), PlanError> {
    if design.iter().any(|i| *i >= pool.len()) {
        return Err(PlanError::PoolTooSmall);
    }
    let n = design.len();
    // One design slot at a time.
    let mut passes = 0;
    let mut exchanges = 0;
    while passes < max_passes {
        passes += 1;
        let mut changed = false;
        for k in 0..n {
            let out = design[k];
            let rows = pool[out].rows;
            state.remove(&rows)?;
            pool[out].selected = false;
            let own = state.gain(criterion, &rows);
            let pick = match state.best(criterion, pool) {
                Some((i, g)) if i != out && g > own + own.abs() * T::of(1e-9) + T::EPS => i,
                _ => out,
            };
            let new_rows = pool[pick].rows;
            state.add(&new_rows)?;
            pool[pick].selected = true;
            if pick != out {
                design[k] = pick;
                exchanges += 1;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    Ok((passes, exchanges))
}
