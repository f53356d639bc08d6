//! Deterministic k-fold cross-validation of a model, by full refits and by one linearised
//! step (the cheap screen of the discrepancy search).
//!
//! Folds are drawn once per search from the seed: the poses (grouped so that repeats of one
//! configuration share a fold) are shuffled by Xoshiro256++ and dealt out round-robin. Every
//! comparison in a search uses the same folds, so per-pose held-out errors of two models can be
//! paired.
//!
//! The screen linearises at the current full-data solution: for fold `f` the training normal
//! equations are the totals minus the fold's own, the candidate's columns are appended by a
//! Schur complement on the factor of the current model's (factored once per fold and round),
//! and the held-out residuals are predicted as `r_i − J_i δ`. At the solution the linearisation
//! is accurate to second order, so the screen ranks candidates like the refits do at a fraction
//! of the cost; only the best few are refitted.

use crate::penalised_fit::{
    add_table_penalty, add_tiny_ridge, fit, squared_errors, Normal, Problem, TablePenalty,
};
use crate::significance::pose_groups;
use kinecal::{ForwardKinematics, Measurement, Param, Robot};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn, Vector3};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Assignment of every pose to one of `k` folds.
#[derive(Clone, Debug, PartialEq)]
pub struct Folds {
    pub k: usize,
    /// Fold of each pose.
    pub of: Vec<usize>,
}

impl Folds {
    /// Deterministic folds for `data` (groups of identical readings stay together).
    pub fn new<const N: usize>(data: &[Measurement<f64, N>], k: usize, seed: u64) -> Self {
        let groups = pose_groups(data);
        let n_groups = groups.iter().copied().max().map_or(0, |g| g + 1);
        let k = k.clamp(2, n_groups.max(2));
        let mut order: Vec<usize> = (0..n_groups).collect();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x6b69_6e65_6361_6c00);
        order.shuffle(&mut rng);
        let mut fold_of_group = vec![0; n_groups];
        for (pos, g) in order.iter().enumerate() {
            fold_of_group[*g] = pos % k;
        }
        Self {
            k,
            of: groups.iter().map(|g| fold_of_group[*g]).collect(),
        }
    }

    /// Indices of the poses in fold `f` (held out) and of the others (training).
    pub fn split(&self, f: usize) -> (Vec<usize>, Vec<usize>) {
        let test = (0..self.of.len()).filter(|i| self.of[*i] == f).collect();
        let train = (0..self.of.len()).filter(|i| self.of[*i] != f).collect();
        (test, train)
    }
}

/// The poses at `idx`.
pub fn subset<const N: usize>(
    data: &[Measurement<f64, N>],
    idx: &[usize],
) -> Vec<Measurement<f64, N>> {
    idx.iter().map(|&i| data[i]).collect()
}

/// Held-out squared error (mm²) of every pose: for each fold, `problem` is refitted from
/// `start` on the other folds and the fold's poses are predicted.
pub fn refit_errors<const N: usize, const V: usize>(
    start: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    folds: &Folds,
    max_iterations: u32,
) -> anyhow::Result<Vec<f64>> {
    let mut out = vec![0.0; data.len()];
    for f in 0..folds.k {
        let (test, train) = folds.split(f);
        if test.is_empty() {
            continue;
        }
        let fitted = fit(start, problem, &subset(data, &train), max_iterations)?;
        let e = squared_errors(&fitted.robot, &subset(data, &test));
        for (i, v) in test.iter().zip(e) {
            out[*i] = v;
        }
    }
    Ok(out)
}

/// Root of the mean of squared errors.
pub fn rms(sq: &[f64]) -> f64 {
    if sq.is_empty() {
        0.0
    } else {
        (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
    }
}

/// Sparse scaled columns of one pose: (column index, ∂p/∂x).
pub type PoseColumns = Vec<(usize, Vector3<f64>)>;

/// Cholesky factor of one fold's penalised training matrix and `L⁻¹(g − Π x)`.
type FoldFactor = (Cholesky<f64, Dyn>, DVector<f64>);

/// The current model linearised at its full-data solution, with per-fold factors.
#[derive(Debug)]
pub struct Linearised {
    folds: Folds,
    residuals: Vec<Vector3<f64>>,
    columns: Vec<PoseColumns>,
    /// Per fold: factor of the penalised training matrix and `L⁻¹(g − Π x)`.
    factors: Vec<Option<FoldFactor>>,
    p: usize,
}

impl Linearised {
    pub fn new<const N: usize, const V: usize>(
        robot: &Robot<f64, N, V>,
        problem: &Problem,
        data: &[Measurement<f64, N>],
        folds: &Folds,
    ) -> Self {
        let p = problem.len();
        let FoldSums {
            residuals,
            columns,
            per_fold,
            total,
        } = fold_sums(robot, problem, data, folds);
        let x = problem.scaled_values(robot);
        let factors = per_fold
            .iter()
            .map(|nf| {
                let tr = total.minus(nf);
                let pen = problem.penalty_matrix(&tr.a.diagonal());
                let mut h = &tr.a + &pen;
                add_tiny_ridge(&mut h);
                let rhs = &tr.g - &pen * &x;
                let chol = h.cholesky()?;
                let z = chol.l_dirty().solve_lower_triangular(&rhs)?;
                Some((chol, z))
            })
            .collect();
        Self {
            folds: folds.clone(),
            residuals,
            columns,
            factors,
            p,
        }
    }

    /// Held-out squared errors of the current model itself (linearised refits).
    pub fn baseline(&self) -> Vec<f64> {
        self.screen(&vec![Vec::new(); self.residuals.len()], 0, None)
    }

    /// Held-out squared errors with `m` extra columns (`extra[i]`: pose `i`'s non-zero ones,
    /// indices `0..m`); `table`: the extra columns are a table's knots, penalised like this.
    pub fn screen(&self, extra: &[PoseColumns], m: usize, table: Option<TablePenalty>) -> Vec<f64> {
        let n = self.residuals.len();
        let p = self.p;
        // Per-fold blocks: B = Jᵀ C (p × m), D = Cᵀ C (m × m), e = Cᵀ r.
        let k = self.folds.k;
        let mut b = vec![DMatrix::<f64>::zeros(p, m); k];
        let mut d = vec![DMatrix::<f64>::zeros(m, m); k];
        let mut e = vec![DVector::<f64>::zeros(m); k];
        for (i, cols) in extra.iter().enumerate().take(n) {
            let f = self.folds.of[i];
            let r = &self.residuals[i];
            for (x, (ci, cv)) in cols.iter().enumerate() {
                e[f][*ci] += cv.dot(r);
                for (cj, cw) in &cols[..=x] {
                    let v = cv.dot(cw);
                    d[f][(*ci, *cj)] += v;
                    if ci != cj {
                        d[f][(*cj, *ci)] += v;
                    }
                }
                for (gj, gv) in &self.columns[i] {
                    b[f][(*gj, *ci)] += gv.dot(cv);
                }
            }
        }
        let (bt, dt, et) = (sum(&b), sum(&d), sum(&e));
        let mut out = vec![f64::INFINITY; n];
        for f in 0..k {
            let Some((chol, z)) = &self.factors[f] else {
                continue;
            };
            let btr = &bt - &b[f];
            let mut dtr = &dt - &d[f];
            let etr = &et - &e[f];
            if let (Some(tp), true) = (table, m > 0) {
                let idx: Vec<usize> = (0..m).collect();
                let diag = dtr.diagonal();
                let mut pen = DMatrix::zeros(m, m);
                add_table_penalty(&mut pen, &idx, &diag, tp);
                dtr += pen;
            }
            let l = chol.l_dirty();
            let (dp, dc) = if m > 0 {
                let Some(y) = l.solve_lower_triangular(&btr) else {
                    continue;
                };
                let mut s = &dtr - y.transpose() * &y;
                add_tiny_ridge(&mut s);
                let rhs = &etr - y.transpose() * z;
                let Some(sc) = s.cholesky() else { continue };
                let dc = sc.solve(&rhs);
                let Some(dp) = l.tr_solve_lower_triangular(&(z - &y * &dc)) else {
                    continue;
                };
                (dp, dc)
            } else {
                let Some(dp) = l.tr_solve_lower_triangular(z) else {
                    continue;
                };
                (dp, DVector::zeros(0))
            };
            for i in (0..n).filter(|i| self.folds.of[*i] == f) {
                let mut pred = self.residuals[i];
                for (j, c) in &self.columns[i] {
                    pred -= c * dp[*j];
                }
                for (j, c) in &extra[i] {
                    pred -= c * dc[*j];
                }
                out[i] = pred.norm_squared();
            }
        }
        out
    }
}

fn sum<R: nalgebra::Dim, C: nalgebra::Dim>(
    v: &[nalgebra::OMatrix<f64, R, C>],
) -> nalgebra::OMatrix<f64, R, C>
where
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<R, C>,
{
    let mut s = v[0].clone();
    for x in &v[1..] {
        s += x;
    }
    s
}

/// The scaled columns of `params` at every pose of `data` for `robot` (for a candidate: the
/// robot with the candidate added at zero values, so the points are the current model's).
pub fn candidate_columns<const N: usize, const V: usize>(
    robot: &Robot<f64, N, V>,
    params: &[Param],
    data: &[Measurement<f64, N>],
) -> Vec<PoseColumns> {
    let reach = robot.reach();
    let scale: Vec<f64> = params.iter().map(|p| p.scale(reach)).collect();
    let mut fk = ForwardKinematics::new();
    data.iter()
        .map(|m| {
            fk.compute(robot, &m.q);
            params
                .iter()
                .enumerate()
                .filter_map(|(k, p)| {
                    let c = fk.column(robot, *p).ok()? / scale[k];
                    (c.norm_squared() > 0.0).then_some((k, c))
                })
                .collect()
        })
        .collect()
}

/// How much the fold fits' own estimation error inflates the held-out errors.
///
/// With the model linearised at its full-data solution and noise of variance σ² per
/// coordinate, the held-out residuals of fold `f` are `r_f = y_f − J_f δ̂_f`, where the training
/// fit `δ̂_f = H_f⁻¹ (J_Tᵀ y_T − Π x)` (`A_f = J_TᵀJ_T`, `H_f = A_f + Π_f` plus the tiny ridge,
/// exactly the factor the screen and the refits use) has covariance `σ² C_f`,
/// `C_f = H_f⁻¹ A_f H_f⁻¹`. So `Cov(r_f) = σ² (I + B_f)` with `B_f = J_f C_f J_fᵀ` (positive
/// semi-definite): every held-out squared error carries the noise of its own pose **plus** the
/// error of a fit made without it. With few poses per fold and many parameters that second part
/// is large (24 poses, 5 folds, ~25 parameters: the held-out mean squared error is ~1.5–2× the
/// noise's), which is why a held-out RMS is an upward-biased estimate of the noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoldInflation {
    /// Held-out coordinates (3 per pose).
    pub coordinates: usize,
    /// `Σ_f tr B_f`: what the fold fits add to `E[Σ |r_i|²] / σ²` beyond `coordinates`.
    pub trace: f64,
    /// `Σ_f tr B_f²` (for the degrees of freedom of the estimate).
    pub trace_squared: f64,
}

/// Every pose's residual and sparse columns at `robot`, the normal equations of each fold, and
/// their total.
struct FoldSums {
    residuals: Vec<Vector3<f64>>,
    columns: Vec<PoseColumns>,
    per_fold: Vec<Normal>,
    total: Normal,
}

fn fold_sums<const N: usize, const V: usize>(
    robot: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    folds: &Folds,
) -> FoldSums {
    let p = problem.len();
    let mut fk = ForwardKinematics::new();
    let mut residuals = Vec::with_capacity(data.len());
    let mut columns = Vec::with_capacity(data.len());
    let mut per_fold: Vec<Normal> = (0..folds.k).map(|_| Normal::zeros(p)).collect();
    let mut total = Normal::zeros(p);
    let mut cols = Vec::new();
    for (i, m) in data.iter().enumerate() {
        let r = problem.pose_rows(&mut fk, robot, m, &mut cols);
        per_fold[folds.of[i]].add(&r, &cols);
        residuals.push(r);
        columns.push(cols.clone());
    }
    for n in &per_fold {
        total.a += &n.a;
        total.g += &n.g;
        total.ssr += n.ssr;
        total.poses += n.poses;
    }
    FoldSums {
        residuals,
        columns,
        per_fold,
        total,
    }
}

/// [`FoldInflation`] of `problem` at `robot` for these folds (see there).
pub fn fold_inflation<const N: usize, const V: usize>(
    robot: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    folds: &Folds,
) -> FoldInflation {
    let p = problem.len();
    let FoldSums {
        columns,
        per_fold,
        total,
        ..
    } = fold_sums(robot, problem, data, folds);
    let mut out = FoldInflation {
        coordinates: 3 * data.len(),
        trace: 0.0,
        trace_squared: 0.0,
    };
    for (f, nf) in per_fold.iter().enumerate() {
        let test: Vec<usize> = (0..data.len()).filter(|i| folds.of[*i] == f).collect();
        if test.is_empty() || p == 0 {
            continue;
        }
        let a = &total.a - &nf.a;
        let pen = problem.penalty_matrix(&a.diagonal());
        let mut h = &a + &pen;
        add_tiny_ridge(&mut h);
        // A fold whose training matrix cannot be factored adds nothing: the estimate then
        // falls back towards the plain held-out mean squared error (its upper end).
        let Some(chol) = h.cholesky() else { continue };
        let mut jt = DMatrix::<f64>::zeros(p, 3 * test.len());
        for (k, i) in test.iter().enumerate() {
            for (j, c) in &columns[*i] {
                for x in 0..3 {
                    jt[(*j, 3 * k + x)] += c[x];
                }
            }
        }
        let g = chol.solve(&jt);
        let b = g.transpose() * (&a * &g);
        if b.iter().all(|v| v.is_finite()) {
            out.trace += b.trace().max(0.0);
            out.trace_squared += b.norm_squared();
        }
    }
    out
}
