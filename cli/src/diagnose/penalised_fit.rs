//! Penalised Levenberg–Marquardt on dense (heap) normal equations: the refits of the
//! discrepancy search.
//!
//! The library's [`kinecal::identify::lm::Levenberg`] fits the geometry from the nominal model (robust
//! damping, identifiability analysis). Once effects join the model, two things need more than
//! it offers: correction tables need a penalty on their knot values (a light ridge towards zero
//! and a second-difference smoothness term: a knot that few poses excite must not run off, and
//! a table's constant part must go to the joint's `theta`, which is free), and the search runs
//! hundreds of short refits from a nearby solution on subsets of the poses. Here the normal
//! equations live on the heap (models with six 3.6° tables have ~500 parameters), only the
//! columns a pose excites are accumulated (a table touches two knots), and the cost minimised is
//!
//! `Σ |r_i|² + xᵀ Π x`,
//!
//! `x` being the parameters in scaled units ([`Param::scale`]: 1 mm at the tool per unit) and
//! `Π` the table penalty, scaled by the table's own mean diagonal of `JᵀJ` so that it is light
//! whatever the number of poses.

use crate::diagnose::dense::{cholesky, cholesky_inverse};
use kinecal::model::effects::EffectKind;
use kinecal::model::param::{apply_delta, value, Param};
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn, Vector3};

/// Strength of the table penalty, relative to the mean diagonal of the table's block of `JᵀJ`.
///
/// Default: a ridge of 1e-3 (a knot excited by 0.1 % of an average knot's information is held
/// near zero; well-excited knots are not biased) and no smoothness term. Measured on the UR10
/// data (1,000 poses identify, 1,773 held out): ridge 1e-3 and 1e-2 give 0.1225 and 0.1229 mm
/// held out, 1e-4 gives 0.142 mm; smoothness 0.01 and 0.1 give 0.124 and 0.155 mm, and on
/// simulated coarse tables smoothness rounds off the kinks the data have. The independent
/// study found the same ("smoothness penalties did not help; the ridge strength barely
/// mattered"), so smoothness stays available but off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TablePenalty {
    /// Ridge towards zero on every knot value.
    pub ridge: f64,
    /// Weight of the squared second differences of neighbouring knots.
    pub smoothness: f64,
}

impl Default for TablePenalty {
    fn default() -> Self {
        Self {
            ridge: 1e-3,
            smoothness: 0.0,
        }
    }
}

/// The free parameters of a fit and how they are scaled and penalised.
#[derive(Clone, Debug)]
pub struct Problem {
    pub params: Vec<Param>,
    /// [`Param::scale`] of each parameter (mm per unit).
    pub scale: Vec<f64>,
    /// `1 / scale`: a pose's columns are scaled by multiplication (divisions would be the
    /// slowest part of the inner loop of every pass over the poses).
    inv_scale: Vec<f64>,
    /// For effect value `k` of the robot: its index in `params` (None: held).
    effect_index: Vec<Option<usize>>,
    /// Indices in `params` of the non-effect parameters.
    geometric: Vec<usize>,
    /// Knot indices in `params` of every table, lowest knot first.
    pub tables: Vec<Vec<usize>>,
    pub penalty: TablePenalty,
}

impl Problem {
    /// The parameters `params` of `robot` (duplicates ignored). Tables must be free as a whole
    /// or held as a whole.
    pub fn new<const N: usize, const V: usize>(
        robot: &Robot<f64, N, V>,
        params: &[Param],
        penalty: TablePenalty,
    ) -> anyhow::Result<Self> {
        let mut list: Vec<Param> = Vec::with_capacity(params.len());
        for p in params {
            if !list.contains(p) {
                list.push(*p);
            }
        }
        let reach = robot.reach();
        let nv = robot.effects().values().len();
        let mut effect_index = vec![None; nv];
        let mut geometric = Vec::new();
        for (i, p) in list.iter().enumerate() {
            match *p {
                Param::Effect(k) => {
                    let slot = effect_index
                        .get_mut(k as usize)
                        .ok_or_else(|| anyhow::anyhow!("effect value {k} does not exist"))?;
                    *slot = Some(i);
                }
                p => {
                    anyhow::ensure!(
                        p.joint().is_none_or(|j| j < N),
                        "parameter {p:?} does not exist"
                    );
                    geometric.push(i)
                }
            }
        }
        let mut tables = Vec::new();
        for e in robot
            .effects()
            .iter()
            .filter(|e| e.kind == EffectKind::Table)
        {
            let idx: Vec<Option<usize>> = (e.first..e.first + e.len)
                .map(|k| effect_index[k as usize])
                .collect();
            if idx.iter().all(Option::is_some) {
                tables.push(idx.into_iter().flatten().collect());
            } else {
                anyhow::ensure!(
                    idx.iter().all(Option::is_none),
                    "a table must be free or held as a whole"
                );
            }
        }
        let scale: Vec<f64> = list.iter().map(|p| p.scale(reach)).collect();
        let inv_scale = scale.iter().map(|s| 1.0 / s).collect();
        Ok(Self {
            params: list,
            scale,
            inv_scale,
            effect_index,
            geometric,
            tables,
            penalty,
        })
    }

    pub fn len(&self) -> usize {
        self.params.len()
    }
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// Current values of the parameters in scaled units (the base rotation counts as zero:
    /// it is updated as a small rotation and never penalised).
    pub fn scaled_values<const N: usize, const V: usize>(
        &self,
        robot: &Robot<f64, N, V>,
    ) -> DVector<f64> {
        DVector::from_iterator(
            self.len(),
            self.params.iter().zip(&self.scale).map(|(p, s)| match p {
                Param::Effect(_) => value(robot, *p).unwrap_or(0.0) * s,
                _ => 0.0,
            }),
        )
    }

    /// The penalty matrix `Π` (scaled units) for a normal matrix whose diagonal is `diag`.
    pub fn penalty_matrix(&self, diag: &DVector<f64>) -> DMatrix<f64> {
        let mut pen = DMatrix::zeros(self.len(), self.len());
        for t in &self.tables {
            add_table_penalty(&mut pen, t, diag, self.penalty);
        }
        pen
    }

    /// Residual and the non-zero scaled Jacobian columns of one pose at `robot`.
    pub fn pose_rows<const N: usize, const V: usize>(
        &self,
        fk: &mut ForwardKinematics<f64, N>,
        robot: &Robot<f64, N, V>,
        m: &Measurement<f64, N>,
        cols: &mut Vec<(usize, Vector3<f64>)>,
    ) -> Vector3<f64> {
        cols.clear();
        let r = m.point - fk.compute(robot, &m.q);
        for &i in &self.geometric {
            if let Ok(c) = fk.column(robot, self.params[i]) {
                cols.push((i, c * self.inv_scale[i]));
            }
        }
        let effects = robot.effects();
        for e in effects.iter() {
            let j = e.joint as usize;
            if j >= N {
                continue;
            }
            let first = e.first as usize;
            if e.kind == EffectKind::Table {
                let (seg, w) = e.segment(m.q[j]);
                let jc = fk.reading_column(robot, j);
                for (kk, wk) in [(seg, 1.0 - w), (seg + 1, w)] {
                    if wk == 0.0 {
                        continue;
                    }
                    if let Some(Some(i)) = self.effect_index.get(first + kk) {
                        cols.push((*i, jc * (wk * self.inv_scale[*i])));
                    }
                }
            } else {
                for k in first..first + e.len as usize {
                    if let Some(Some(i)) = self.effect_index.get(k) {
                        if let Ok(c) = fk.column(robot, Param::Effect(k as u16)) {
                            cols.push((*i, c * self.inv_scale[*i]));
                        }
                    }
                }
            }
        }
        r
    }
}

/// Adds `w·(ridge·I + smoothness·DᵀD)` on the knots `t` (indices into the matrix), `w` the mean
/// of `diag` over the knots.
pub fn add_table_penalty(
    pen: &mut DMatrix<f64>,
    t: &[usize],
    diag: &DVector<f64>,
    p: TablePenalty,
) {
    if t.is_empty() {
        return;
    }
    let w = t.iter().map(|&i| diag[i]).sum::<f64>() / t.len() as f64;
    let w = if w > 0.0 && w.is_finite() { w } else { 1.0 };
    for &i in t {
        pen[(i, i)] += w * p.ridge;
    }
    if t.len() >= 3 && p.smoothness > 0.0 {
        for k in 1..t.len() - 1 {
            let idx = [t[k - 1], t[k], t[k + 1]];
            let c = [1.0, -2.0, 1.0];
            for a in 0..3 {
                for b in 0..3 {
                    pen[(idx[a], idx[b])] += w * p.smoothness * c[a] * c[b];
                }
            }
        }
    }
}

/// Normal equations `JᵀJ`, `Jᵀr` and the sum of squared residuals over some poses.
#[derive(Clone, Debug)]
pub struct Normal {
    pub a: DMatrix<f64>,
    pub g: DVector<f64>,
    pub ssr: f64,
    pub poses: usize,
}

impl Normal {
    pub fn zeros(p: usize) -> Self {
        Self {
            a: DMatrix::zeros(p, p),
            g: DVector::zeros(p),
            ssr: 0.0,
            poses: 0,
        }
    }

    /// The normal equations of the union of disjoint sets of poses (`p` parameters), from
    /// those of each set.
    pub fn sum<'a>(p: usize, parts: impl IntoIterator<Item = &'a Normal>) -> Normal {
        let mut total = Normal::zeros(p);
        for n in parts {
            total.a += &n.a;
            total.g += &n.g;
            total.ssr += n.ssr;
            total.poses += n.poses;
        }
        total
    }

    /// `self − other` (training = all − held-out fold).
    pub fn minus(&self, other: &Normal) -> Normal {
        Normal {
            a: &self.a - &other.a,
            g: &self.g - &other.g,
            ssr: self.ssr - other.ssr,
            poses: self.poses - other.poses,
        }
    }

    /// Normal equations of `robot` over `data`.
    pub fn of<const N: usize, const V: usize>(
        problem: &Problem,
        robot: &Robot<f64, N, V>,
        data: &[Measurement<f64, N>],
    ) -> Normal {
        let mut sums = NormalSums::new(problem.len());
        for_each_pose_rows(problem, robot, data, |r, cols| sums.add(r, cols));
        sums.finish()
    }
}

/// `Jᵀr` and the sum of squared residuals of `robot` over `data`: [`Normal::of`] without
/// `JᵀJ` (the same sums, in the same order), for about half the cost.
pub fn gradient<const N: usize, const V: usize>(
    problem: &Problem,
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> (DVector<f64>, f64) {
    let mut g = DVector::zeros(problem.len());
    let mut ssr = 0.0;
    for_each_pose_rows(problem, robot, data, |r, cols| {
        ssr += r.norm_squared();
        for (i, c) in cols {
            g[*i] += c.dot(r);
        }
    });
    (g, ssr)
}

/// Calls `f` with the residual and the non-zero scaled columns ([`Problem::pose_rows`]) of
/// every pose of `data`, in order.
fn for_each_pose_rows<const N: usize, const V: usize>(
    problem: &Problem,
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    mut f: impl FnMut(&Vector3<f64>, &[(usize, Vector3<f64>)]),
) {
    let mut fk = ForwardKinematics::new();
    let mut cols = Vec::with_capacity(problem.len());
    for m in data {
        let r = problem.pose_rows(&mut fk, robot, m, &mut cols);
        f(&r, &cols);
    }
}

/// [`Normal`] being accumulated pose by pose.
///
/// This is the inner loop of every fit: a pose excites a few dozen of up to ~500 columns, and
/// each pair of them is one update. `JᵀJ` is symmetric, so only one triangle is accumulated
/// and it is mirrored once by [`Self::finish`]. The triangle kept is the upper one of a flat
/// column-major buffer: the columns of a pose mostly come in increasing index order, so the
/// updates of one column's pairs land next to each other in memory. Every entry receives the same
/// additions in the same order as a full-matrix accumulation would give it, so the sums are
/// the same to the last bit.
#[derive(Clone, Debug)]
pub struct NormalSums {
    p: usize,
    /// Column-major `p × p`; only entries `(row ≤ column)` are written.
    upper: Vec<f64>,
    g: Vec<f64>,
    ssr: f64,
    poses: usize,
}

impl NormalSums {
    /// Empty sums for `p` parameters.
    pub fn new(p: usize) -> Self {
        Self {
            p,
            upper: vec![0.0; p * p],
            g: vec![0.0; p],
            ssr: 0.0,
            poses: 0,
        }
    }

    /// Adds one pose: its residual `r` and its non-zero columns (distinct indices).
    pub fn add(&mut self, r: &Vector3<f64>, cols: &[(usize, Vector3<f64>)]) {
        self.ssr += r.norm_squared();
        self.poses += 1;
        for (x, (i, ci)) in cols.iter().enumerate() {
            self.g[*i] += ci.dot(r);
            for (j, cj) in &cols[..=x] {
                let (row, col) = if j <= i { (*j, *i) } else { (*i, *j) };
                self.upper[col * self.p + row] += ci.dot(cj);
            }
        }
    }

    /// The normal equations (the upper triangle mirrored into the lower one).
    pub fn finish(self) -> Normal {
        let mut a = DMatrix::from_vec(self.p, self.p, self.upper);
        a.fill_lower_triangle_with_upper_triangle();
        Normal {
            a,
            g: DVector::from_vec(self.g),
            ssr: self.ssr,
            poses: self.poses,
        }
    }
}

/// Adds the tiny ridge `μ_i = 1e-10 · max(h_ii, 1e-12 · mean h_ii)` to the diagonal: relative
/// to each column's own size (so that a weakly excited but real direction is not held), with a
/// floor that keeps directions no pose excites (an empty knot) at zero.
pub fn add_tiny_ridge(h: &mut DMatrix<f64>) {
    let p = h.nrows();
    if p == 0 {
        return;
    }
    let mean = (0..p).map(|i| h[(i, i)]).sum::<f64>() / p as f64;
    let floor = 1e-12 * mean.max(f64::MIN_POSITIVE);
    for i in 0..p {
        let d = h[(i, i)];
        h[(i, i)] = d + 1e-10 * d.max(floor) + floor;
    }
}

/// `H = JᵀJ + Π` of one linearisation point, with the Cholesky factor of its damped form
/// for the damping last used: steps from the same `H` and damping with a fresh gradient cost
/// two triangular solves, not a factorisation.
struct Curvature {
    h: DMatrix<f64>,
    factor: Option<(f64, Cholesky<f64, Dyn>)>,
}

impl Curvature {
    fn new(a: &DMatrix<f64>, pen: &DMatrix<f64>) -> Self {
        Self {
            h: a + pen,
            factor: None,
        }
    }

    /// Solves `(H + λ·diag H + μ) δ = rhs` (`λ` the Levenberg damping, `μ` the tiny ridge of
    /// [`add_tiny_ridge`]); `None` when not positive definite or not finite.
    fn solve(&mut self, damping: f64, rhs: &DVector<f64>) -> Option<DVector<f64>> {
        let p = self.h.nrows();
        if p == 0 {
            return Some(DVector::zeros(0));
        }
        if self.factor.as_ref().is_none_or(|(d, _)| *d != damping) {
            let mut h = self.h.clone();
            for i in 0..p {
                h[(i, i)] *= 1.0 + damping;
            }
            add_tiny_ridge(&mut h);
            self.factor = Some((damping, cholesky(h)?));
        }
        let (_, factor) = self.factor.as_ref()?;
        let d = factor.solve(rhs);
        d.iter().all(|v| v.is_finite()).then_some(d)
    }

    /// The decrease of the penalised cost that the linearised model predicts for the step
    /// `δ` solved for `rhs = g − Π x`: `2 δᵀ rhs − δᵀ H δ`.
    fn predicted_reduction(&self, step: &DVector<f64>, rhs: &DVector<f64>) -> f64 {
        2.0 * step.dot(rhs) - step.dot(&(&self.h * step))
    }
}

/// Result of a penalised fit.
#[derive(Clone, Debug)]
pub struct FitOutcome<const N: usize, const V: usize> {
    pub robot: Robot<f64, N, V>,
    /// Sum of squared residuals (mm²) at the solution.
    pub ssr: f64,
    /// Accepted steps.
    pub iterations: u32,
    /// The penalty `Π` the fit used (scaled units; fixed at the start).
    pub penalty: DMatrix<f64>,
}

impl<const N: usize, const V: usize> FitOutcome<N, V> {
    /// Effective number of parameters, `tr((JᵀJ + Π)⁻¹ JᵀJ)` at the solution: the degrees of
    /// freedom the fit used (= the parameter count without penalty). `problem` and `data` must
    /// be the fit's. Computed on demand (one pass over the poses and an O(p³) inverse) because
    /// only the final model's report needs it.
    pub fn effective_parameters(&self, problem: &Problem, data: &[Measurement<f64, N>]) -> f64 {
        effective_parameters(&Normal::of(problem, &self.robot, data).a, &self.penalty)
    }
}

/// At most this many rejected steps in a row end a fit.
const MAX_REJECTS: u32 = 12;
/// A step whose predicted decrease is below this fraction of the cost is not tried: the fit
/// has converged (the cost's rounding could not even tell whether it helped).
const NEGLIGIBLE_REDUCTION: f64 = 1e-12;
/// An accepted step whose actual decrease is below this fraction of the predicted one shows
/// that the curvature `JᵀJ` in use no longer describes the cost: it is formed again.
const WELL_PREDICTED: f64 = 0.5;
/// An accepted step that gains more than this fraction of what the step before it gained
/// shows slow convergence (the curvature in use is too far from the current one): it is
/// formed again.
const SLOW_CONVERGENCE: f64 = 0.1;

/// Penalised Levenberg–Marquardt from `start` over `data` (at most `max_iterations` steps).
pub fn fit<const N: usize, const V: usize>(
    start: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    max_iterations: u32,
) -> anyhow::Result<FitOutcome<N, V>> {
    fit_from(
        start,
        problem,
        data,
        Normal::of(problem, start, data),
        max_iterations,
    )
}

/// [`fit`] with the normal equations at `start` already known (`normal`, as
/// [`Normal::of`]`(problem, start, data)` would give them, up to rounding): the fold fits of
/// one model all start from the same robot, so one pass over all poses gives every fold's
/// starting point as a sum of the other folds' own.
///
/// The refits start next to their solution and the model is nearly linear in its parameters
/// (a fit typically takes one large step and one or two tiny ones), so the curvature `JᵀJ`
/// is kept from the start, and with it the factor of the damped system, for as long as it
/// serves: a step then costs one pass for the cost and the gradient `Jᵀr` at the trial point
/// (no `JᵀJ`) and two triangular solves. `JᵀJ` is formed again at the current point when a
/// step is rejected, gains less than half what it predicted, or gains more than a tenth of
/// what the step before it gained (slow convergence). Whatever curvature is used, the fixed
/// point is the stationary point of the penalised cost; the fit stops when the next step would
/// gain less than [`NEGLIGIBLE_REDUCTION`] of the cost, or an accepted one gained less than
/// 1e-10 of it.
pub fn fit_from<const N: usize, const V: usize>(
    start: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    normal: Normal,
    max_iterations: u32,
) -> anyhow::Result<FitOutcome<N, V>> {
    anyhow::ensure!(
        3 * data.len() > problem.len(),
        "{} poses cannot determine {} parameters",
        data.len(),
        problem.len()
    );
    let mut robot = start.clone();
    let pen = problem.penalty_matrix(&normal.a.diagonal());
    let mut x = problem.scaled_values(&robot);
    let Normal {
        a, mut g, mut ssr, ..
    } = normal;
    let mut cost = ssr + x.dot(&(&pen * &x));
    let mut curvature = Curvature::new(&a, &pen);
    // Whether `curvature` was formed at the current point.
    let mut current = true;
    let mut last_gain = f64::INFINITY;
    let set = kinecal_set(problem)?;
    let mut lambda = 1e-6;
    let mut iterations = 0;
    let mut rejects = 0;
    while iterations < max_iterations && rejects < MAX_REJECTS {
        let rhs = &g - &pen * &x;
        let Some(step) = curvature.solve(lambda, &rhs) else {
            lambda = (lambda * 10.0).max(1e-6);
            rejects += 1;
            continue;
        };
        let predicted = curvature.predicted_reduction(&step, &rhs);
        if predicted.is_nan() || predicted < NEGLIGIBLE_REDUCTION * cost {
            break;
        }
        let delta: Vec<f64> = step
            .iter()
            .zip(&problem.scale)
            .map(|(d, s)| d / s)
            .collect();
        let mut cand = robot.clone();
        if apply_delta(&mut cand, &set, &delta).is_err() {
            lambda = (lambda * 10.0).max(1e-6);
            rejects += 1;
            continue;
        }
        let (cand_g, cand_ssr) = gradient(problem, &cand, data);
        let cand_x = &x + &step;
        let cand_cost = cand_ssr + cand_x.dot(&(&pen * &cand_x));
        if cand_cost.is_finite() && cand_cost <= cost {
            let gain = cost - cand_cost;
            let rel = gain / cost.max(f64::MIN_POSITIVE);
            robot = cand;
            x = cand_x;
            g = cand_g;
            ssr = cand_ssr;
            cost = cand_cost;
            iterations += 1;
            rejects = 0;
            current = false;
            if rel < 1e-10 || step.norm() < 1e-10 || iterations >= max_iterations {
                break;
            }
            if gain < WELL_PREDICTED * predicted || gain > SLOW_CONVERGENCE * last_gain {
                curvature = Curvature::new(&Normal::of(problem, &robot, data).a, &pen);
                current = true;
                lambda = (lambda / 3.0).max(1e-12);
            }
            last_gain = gain;
        } else {
            lambda = (lambda * 4.0).max(1e-6);
            rejects += 1;
            if !current {
                curvature = Curvature::new(&Normal::of(problem, &robot, data).a, &pen);
                current = true;
            }
        }
    }
    Ok(FitOutcome {
        robot,
        ssr,
        iterations,
        penalty: pen,
    })
}

/// `tr((A + Π)⁻¹ A)`: the degrees of freedom a penalised fit uses (directions no pose
/// excites count zero).
pub fn effective_parameters(a: &DMatrix<f64>, pen: &DMatrix<f64>) -> f64 {
    let p = a.nrows();
    if p == 0 {
        return 0.0;
    }
    let mut h = a + pen;
    add_tiny_ridge(&mut h);
    // tr(H⁻¹ A) = Σ (H⁻¹)_ij A_ij, both symmetric.
    match cholesky(h).as_ref().and_then(cholesky_inverse) {
        Some(h_inv) => h_inv.component_mul(a).sum(),
        None => p as f64,
    }
}

/// The library's parameter-set type for [`apply_delta`] (capacity for any host model).
fn kinecal_set(problem: &Problem) -> anyhow::Result<kinecal::ParamSet<{ crate::VCAP + 64 }>> {
    let mut s = kinecal::ParamSet::new();
    for p in &problem.params {
        s.push(*p)
            .map_err(|e| anyhow::anyhow!("parameter set: {e:?}"))?;
    }
    Ok(s)
}

/// Squared 3-D position error (mm²) of every pose.
pub fn squared_errors<const N: usize, const V: usize>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Vec<f64> {
    let mut fk = ForwardKinematics::new();
    data.iter()
        .map(|m| (m.point - fk.compute(robot, &m.q)).norm_squared())
        .collect()
}
