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

pub use crate::calibration::folds::{subset, Folds};
use crate::compute::banded::{is_banded, BandedFactor, SymmetricBand};
use crate::compute::dense::{cholesky, cholesky_inverse, sub_gram_lower, LowerFactor};
use crate::compute::parallel;
use crate::diagnose::linear::{
    add_table_penalty, add_table_penalty_band, add_tiny_ridge, add_tiny_ridge_band,
    observation_blocks, Normal, NormalSums, Problem, TablePenalty,
};
use crate::diagnose::pose_columns::PoseColumns;
use crate::diagnose::refit::fold_errors;
use crate::diagnose::table_screen::{dot3, AlongReading, ReadingProducts};
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::{DMatrix, DVector, Vector3};
use std::sync::OnceLock;

/// Held-out squared error (mm²) of every pose: for each fold, `problem` is refitted from
/// `start` on the other folds and the fold's poses are predicted.
pub fn refit_errors<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    folds: &Folds,
    max_iterations: u32,
) -> anyhow::Result<Vec<f64>> {
    let mut out = refit_errors_each(&[(start, problem)], data, folds, max_iterations)?;
    Ok(out.swap_remove(0))
}

/// [`refit_errors`] of several models (start and parameter set) at once: their fold fits are
/// independent, so all of them are spread over the cores together (the library's
/// Levenberg–Marquardt, [`crate::diagnose::refit::fold_errors`]).
pub fn refit_errors_each<const N: usize, V: kinecal::ValueStorage>(
    models: &[(&Robot<f64, N, V>, &Problem)],
    data: &[Measurement<f64, N>],
    folds: &Folds,
    max_iterations: u32,
) -> anyhow::Result<Vec<Vec<f64>>> {
    fold_errors(models, data, folds, max_iterations)
}

/// Root of the mean of squared errors.
pub fn rms(sq: &[f64]) -> f64 {
    if sq.is_empty() {
        0.0
    } else {
        (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
    }
}

/// One fold's penalised training normal equations `H δ = g − Π x` (`H` with the tiny ridge),
/// the Cholesky factor `L` of `H` and `L⁻¹(g − Π x)`.
#[derive(Debug)]
struct FoldFactor {
    h: DMatrix<f64>,
    rhs: DVector<f64>,
    l: LowerFactor,
    z: DVector<f64>,
}

/// A fold's own sums of a candidate's columns `C`: `B = JᵀC`, `D = CᵀC`, `e = Cᵀr`.
type OwnSums<'a> = (&'a DMatrix<f64>, &'a Gram, &'a DVector<f64>);

/// A candidate's block `D = CᵀC` of the normal matrix: a table's knots as a band (hundreds of
/// knots: `m²` entries would cost more than the fold's solve), any other candidate's dense.
#[derive(Clone, Debug)]
enum Gram {
    Dense(DMatrix<f64>),
    Band(SymmetricBand),
}

impl Gram {
    /// The sum of the folds' blocks (all of one kind and size).
    fn sum(parts: &[Gram]) -> Gram {
        let mut total = parts[0].clone();
        for part in &parts[1..] {
            match (&mut total, part) {
                (Gram::Dense(t), Gram::Dense(x)) => *t += x,
                (Gram::Band(t), Gram::Band(x)) => t.add_assign(x),
                (t, x) => *t = Gram::Dense(t.dense() + x.dense()),
            }
        }
        total
    }

    fn minus(&self, other: &Gram) -> Gram {
        match (self, other) {
            (Gram::Dense(a), Gram::Dense(b)) => Gram::Dense(a - b),
            (Gram::Band(a), Gram::Band(b)) => Gram::Band(a.minus(b)),
            (a, b) => Gram::Dense(a.dense() - b.dense()),
        }
    }

    fn dense(&self) -> DMatrix<f64> {
        match self {
            Gram::Dense(d) => d.clone(),
            Gram::Band(d) => d.to_dense(),
        }
    }

    fn into_dense(self) -> DMatrix<f64> {
        match self {
            Gram::Dense(d) => d,
            Gram::Band(d) => d.to_dense(),
        }
    }

    /// Adds a table's penalty on all of its rows (its knots).
    fn add_table_penalty(&mut self, tp: TablePenalty) {
        match self {
            Gram::Dense(d) => {
                let diag = d.diagonal();
                add_table_penalty(d, d.nrows(), &diag, tp);
            }
            Gram::Band(d) => {
                let diag = d.diagonal();
                add_table_penalty_band(d, &diag, tp);
            }
        }
    }

    /// `xᵀ D x`.
    fn quadratic(&self, x: &DVector<f64>) -> f64 {
        match self {
            Gram::Dense(d) => x.dot(&(d * x)),
            Gram::Band(d) => x.dot(&d.mul_vector(x)),
        }
    }

    /// [`Elimination::cheaper`] for this block with `p` model parameters.
    fn cheaper(&self, p: usize) -> Elimination {
        match self {
            Gram::Dense(d) => Elimination::cheaper(p, d.nrows(), d),
            Gram::Band(d) => Elimination::cheaper_of(p, d.len(), true),
        }
    }

    /// `R` of `D + tiny ridge = R Rᵀ` (`None`: not positive definite).
    fn band_factor(self) -> Option<BandedFactor> {
        match self {
            Gram::Dense(mut d) => {
                add_tiny_ridge(&mut d);
                BandedFactor::new(&d, TABLE_BAND)
            }
            Gram::Band(mut d) => {
                add_tiny_ridge_band(&mut d);
                BandedFactor::of_band(&d)
            }
        }
    }
}

/// The current model linearised at its full-data solution, with per-fold factors.
#[derive(Debug)]
pub struct Linearised {
    /// The poses of each fold, in increasing order.
    fold_poses: Vec<Vec<usize>>,
    /// Pose `i`'s blocks of rows are `blocks[i]..blocks[i + 1]` (of `residuals`, `columns`).
    blocks: Vec<usize>,
    residuals: Vec<Vector3<f64>>,
    columns: PoseColumns,
    /// Per fold: factor of the penalised training matrix and `L⁻¹(g − Π x)`.
    factors: Vec<Option<FoldFactor>>,
    /// Each fold's own normal sums (its held-out poses).
    own: Vec<Normal>,
    p: usize,
    /// Per joint, the products of its reading directions with the model's columns and the
    /// residuals, formed at the first table on that joint the screen compares.
    reading: Vec<OnceLock<ReadingProducts>>,
}

impl Linearised {
    pub fn new<const N: usize, V: kinecal::ValueStorage>(
        robot: &Robot<f64, N, V>,
        problem: &Problem,
        data: &[Measurement<f64, N>],
        folds: &Folds,
    ) -> Self {
        let p = problem.len();
        let FoldSums {
            fold_poses,
            blocks,
            residuals,
            columns,
            per_fold,
            total,
        } = fold_sums(robot, problem, data, folds);
        let x = problem.scaled_values(robot);
        let factors = parallel::map_each(&per_fold, |nf| {
            let tr = total.minus(nf);
            let pen = problem.penalty_matrix(&tr.a.diagonal());
            let mut h = &tr.a + &pen;
            add_tiny_ridge(&mut h);
            let rhs = &tr.g - &pen * &x;
            let l = LowerFactor::new(cholesky(h.clone())?.unpack_dirty())?;
            let z = l.l().solve_lower_triangular(&rhs)?;
            Some(FoldFactor { h, rhs, l, z })
        });
        Self {
            fold_poses,
            blocks,
            residuals,
            columns,
            factors,
            own: per_fold,
            p,
            reading: (0..N).map(|_| OnceLock::new()).collect(),
        }
    }

    /// Whether the screen of `extra` takes the table shortcut (its columns along a reading
    /// direction, with products formed for those directions), for tests.
    #[doc(hidden)]
    pub fn takes_table_shortcut(&self, extra: &PoseColumns) -> bool {
        self.shortcut(extra).is_some()
    }

    /// The reading products `extra`'s sums are formed from, when it is a table's columns
    /// along reading directions with products for them.
    fn shortcut<'a>(
        &'a self,
        extra: &'a PoseColumns,
    ) -> Option<(&'a ReadingProducts, &'a AlongReading)> {
        let along = extra
            .along()
            .filter(|a| a.blocks.directions.len() == self.residuals.len())?;
        Some((self.reading_products(along)?, along))
    }

    /// The products of `along`'s directions with the model's columns and residuals, per fold
    /// in the order of the readings (formed once per joint and round); `None` when none were
    /// formed for these directions and readings.
    fn reading_products(&self, along: &AlongReading) -> Option<&ReadingProducts> {
        let products = self
            .reading
            .get(along.table.joint as usize)?
            .get_or_init(|| {
                let blocks: Vec<_> = (0..self.residuals.len())
                    .map(|b| (self.columns.pose(b), &self.residuals[b]))
                    .collect();
                let folds = self.fold_poses.iter().map(|poses| {
                    poses
                        .iter()
                        .flat_map(|&i| self.blocks[i]..self.blocks[i + 1])
                        .collect()
                });
                ReadingProducts::new(self.p, &blocks, &along.blocks, folds)
            });
        products.fits(along).then_some(products)
    }

    /// Held-out squared errors of the current model itself (linearised refits).
    pub fn baseline(&self) -> Vec<f64> {
        self.screen(&PoseColumns::empty(self.residuals.len()), 0, None)
    }

    /// Held-out squared errors (one per observation) with `m` extra columns
    /// (`extra.pose(b)`: block `b`'s non-zero ones, indices `0..m`, blocks as
    /// [`crate::diagnose::pose_columns::PoseKinematics::columns`] lays them out); `table`: the
    /// extra columns are a table's knots, penalised like this.
    pub fn screen(&self, extra: &PoseColumns, m: usize, table: Option<TablePenalty>) -> Vec<f64> {
        self.screen_by(extra, m, table, None)
    }

    /// [`Self::screen`], solving each fold's system by `elimination` (`None`: the cheaper one
    /// for this candidate, [`Elimination::cheaper`]). Both give the same errors up to rounding.
    pub fn screen_by(
        &self,
        extra: &PoseColumns,
        m: usize,
        table: Option<TablePenalty>,
        elimination: Option<Elimination>,
    ) -> Vec<f64> {
        let mut out = vec![f64::INFINITY; self.blocks.len() - 1];
        self.solve_folds(extra, m, table, elimination, |f, dp, dc, _| {
            let (dp, dc) = (dp.as_slice(), dc.as_slice());
            for &i in &self.fold_poses[f] {
                let mut sq = 0.0;
                for b in self.blocks[i]..self.blocks[i + 1] {
                    let mut pred = self.residuals[b];
                    subtract_columns(&mut pred, self.columns.pose(b), dp);
                    subtract_columns(&mut pred, extra.pose(b), dc);
                    sq += pred.norm_squared();
                }
                out[i] = sq;
            }
        });
        out
    }

    /// Each fold's linearised training fit with the candidate's columns appended, handed to
    /// `visit(fold, δp, δc, the fold's own (B, D, e))`; a fold whose system cannot be solved is
    /// not visited.
    fn solve_folds(
        &self,
        extra: &PoseColumns,
        m: usize,
        table: Option<TablePenalty>,
        elimination: Option<Elimination>,
        mut visit: impl FnMut(usize, &DVector<f64>, &DVector<f64>, OwnSums<'_>),
    ) {
        debug_assert_eq!(
            extra.poses(),
            self.residuals.len(),
            "one set of columns per block"
        );
        let p = self.p;
        // Per-fold blocks: B = Jᵀ C (p × m), D = Cᵀ C (m × m), e = Cᵀ r.
        let k = self.fold_poses.len();
        let mut b = vec![DMatrix::<f64>::zeros(p, m); k];
        let mut e = vec![DVector::<f64>::zeros(m); k];
        // Fold by fold, so that only one fold's blocks are being written at a time.
        let d: Vec<Gram> = match self.shortcut(extra) {
            Some((products, along)) => (0..k)
                .map(|f| {
                    let mut df = SymmetricBand::zeros(m, TABLE_BAND);
                    products.add_fold(f, along, b[f].as_mut_slice(), &mut df, &mut e[f]);
                    Gram::Band(df)
                })
                .collect(),
            None => (0..k)
                .map(|f| {
                    let mut df = DMatrix::zeros(m, m);
                    self.add_own_sums(f, extra, b[f].as_mut_slice(), &mut df, &mut e[f]);
                    Gram::Dense(df)
                })
                .collect(),
        };
        let (bt, dt, et) = (sum(&b), Gram::sum(&d), sum(&e));
        for (f, ((bf, df), ef)) in b.iter().zip(&d).zip(&e).enumerate() {
            let Some(factor) = &self.factors[f] else {
                continue;
            };
            // The training blocks: totals minus the fold's own.
            let (btr, mut dtr, etr) = (&bt - bf, dt.minus(df), &et - ef);
            if let (Some(tp), true) = (table, m > 0) {
                dtr.add_table_penalty(tp);
            }
            let eliminate = elimination.unwrap_or_else(|| dtr.cheaper(p));
            let solved = match eliminate {
                _ if m == 0 => factor
                    .l
                    .l()
                    .tr_solve_lower_triangular(&factor.z)
                    .map(|dp| (dp, DVector::zeros(0))),
                Elimination::Candidate => eliminate_candidate(factor, btr, dtr, etr),
                Elimination::Model => eliminate_model(factor, btr, dtr.into_dense(), etr),
            };
            let Some((dp, dc)) = solved else { continue };
            visit(f, &dp, &dc, (bf, df, ef));
        }
    }

    /// Fold `f`'s own sums of the columns `extra` (any candidate): `bf` is `B = JᵀC`
    /// (`p × m`, column-major), `df` is `D = CᵀC` and `ef` is `e = Cᵀr`, all added to.
    fn add_own_sums(
        &self,
        f: usize,
        extra: &PoseColumns,
        bf: &mut [f64],
        df: &mut DMatrix<f64>,
        ef: &mut DVector<f64>,
    ) {
        let p = self.p;
        for i in self.fold_poses[f]
            .iter()
            .flat_map(|&i| self.blocks[i]..self.blocks[i + 1])
        {
            let cols = extra.pose(i);
            let r = &self.residuals[i];
            for (x, (ci, cv)) in cols.iter().enumerate() {
                ef[*ci] += cv.dot(r);
                for (cj, cw) in &cols[..=x] {
                    let v = cv.dot(cw);
                    df[(*ci, *cj)] += v;
                    if ci != cj {
                        df[(*cj, *ci)] += v;
                    }
                }
            }
            // B's columns two at a time (a table's two knots around the reading), so that
            // the model's columns are read once per pair.
            let model = self.columns.pose(i);
            let mut rest = cols;
            while let [(c1, v1), (c2, v2), tail @ ..] = rest {
                let (o1, o2) = (c1 * p, c2 * p);
                for (gj, gv) in model {
                    bf[o1 + gj] += dot3(gv, v1);
                    bf[o2 + gj] += dot3(gv, v2);
                }
                rest = tail;
            }
            if let [(c1, v1)] = rest {
                let bc = &mut bf[c1 * p..(c1 + 1) * p];
                for (gj, gv) in model {
                    bc[*gj] += dot3(gv, v1);
                }
            }
        }
    }

    /// The RMS of [`Self::screen`]'s held-out errors without a pass over the poses: each fold's
    /// held-out sum of squares `Σ |r − J δp − C δc|²` expanded over its own normal sums
    /// (`ssr − 2δpᵀg − 2δcᵀe + δpᵀAδp + 2δpᵀBδc + δcᵀDδc`). The screen of a round ranks
    /// hundreds of candidates by this figure alone; without the per-pose predictions the search
    /// on 11,911 poses took 13.1 s instead of 18.6 s (host-tests/scripts/diagnose_series_a_size.sh).
    pub fn screen_rms(&self, extra: &PoseColumns, m: usize, table: Option<TablePenalty>) -> f64 {
        let mut ssr = 0.0;
        let mut solved = vec![false; self.fold_poses.len()];
        self.solve_folds(extra, m, table, None, |f, dp, dc, (b, d, e)| {
            let own = &self.own[f];
            let cross = b * dc;
            let fold = own.ssr - 2.0 * dp.dot(&own.g) - 2.0 * dc.dot(e)
                + dp.dot(&(&own.a * dp))
                + 2.0 * dp.dot(&cross)
                + d.quadratic(dc);
            ssr += fold.max(0.0);
            solved[f] = true;
        });
        let n = self.blocks.len() - 1;
        let unsolved = (0..solved.len()).any(|f| !solved[f] && !self.fold_poses[f].is_empty());
        if n == 0 {
            0.0
        } else if unsolved {
            f64::INFINITY
        } else {
            (ssr / n as f64).sqrt()
        }
    }
}

/// `pred −= Σ c · x[j]` over the sparse columns `(j, c)`.
#[inline(always)]
fn subtract_columns(pred: &mut Vector3<f64>, columns: &[(usize, Vector3<f64>)], x: &[f64]) {
    let (mut px, mut py, mut pz) = (pred.x, pred.y, pred.z);
    for (j, c) in columns {
        let s = x[*j];
        px -= c.x * s;
        py -= c.y * s;
        pz -= c.z * s;
    }
    *pred = Vector3::new(px, py, pz);
}

/// How the screen solves a fold's training system with a candidate's `m` columns appended,
/// `[H B; Bᵀ D] [δp; δc] = [g; e]`: by one of the two Schur complements.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Elimination {
    /// The model's parameters first, on the factor of `H` the round keeps: `D − BᵀH⁻¹B`
    /// (`p²m + pm² + m³/3` operations).
    Model,
    /// The candidate's first, when `D` is a band (a table's knots): `H − B D⁻¹ Bᵀ`, a new
    /// `p × p` factor (`p²m + p³/3`), the cheaper for a table with more knots than about half
    /// the model's parameters.
    Candidate,
}

impl Elimination {
    /// The one with fewer operations for `p` model parameters and the candidate block `d`.
    pub fn cheaper(p: usize, m: usize, d: &DMatrix<f64>) -> Self {
        Self::cheaper_of(p, m, is_banded(d, TABLE_BAND))
    }

    /// The one with fewer operations for `p` model parameters and `m` candidate columns whose
    /// block is (`banded`) or is not a band of [`TABLE_BAND`].
    fn cheaper_of(p: usize, m: usize, banded: bool) -> Self {
        let (pf, mf) = (p as f64, m as f64);
        if banded && pf * pf * pf < 3.0 * pf * mf * mf + mf * mf * mf {
            Elimination::Candidate
        } else {
            Elimination::Model
        }
    }
}

/// Half-bandwidth of a table's block of the normal matrix: a reading's rows touch the two
/// knots around it, and the smoothness penalty (second differences) couples knots two apart.
const TABLE_BAND: usize = 2;

/// [`Elimination::Model`]: `y = L⁻¹ B`, the Schur complement `D − yᵀy` for `δc`, then `δp`.
fn eliminate_model(
    factor: &FoldFactor,
    btr: DMatrix<f64>,
    dtr: DMatrix<f64>,
    etr: DVector<f64>,
) -> Option<(DVector<f64>, DVector<f64>)> {
    let mut y = btr;
    factor.l.solve_in_place(&mut y);
    let yt = y.transpose();
    let mut s = dtr;
    sub_gram_lower(s.as_view_mut(), yt.as_view(), y.as_view());
    add_tiny_ridge(&mut s);
    let mut rhs = etr;
    rhs.gemv(-1.0, &yt, &factor.z, 1.0);
    let dc = cholesky(s)?.solve(&rhs);
    let mut t = factor.z.clone();
    t.gemv(-1.0, &y, &dc, 1.0);
    factor
        .l
        .l()
        .tr_solve_lower_triangular_mut(&mut t)
        .then_some((t, dc))
}

/// [`Elimination::Candidate`]: `D = R Rᵀ` (band), `W = B R⁻ᵀ`, the Schur complement
/// `H − W Wᵀ` for `δp`, then `δc = R⁻ᵀ(R⁻¹e − Wᵀ δp)`.
fn eliminate_candidate(
    factor: &FoldFactor,
    btr: DMatrix<f64>,
    dtr: Gram,
    etr: DVector<f64>,
) -> Option<(DVector<f64>, DVector<f64>)> {
    let r = dtr.band_factor()?;
    let mut w = btr;
    r.solve_right_transposed(&mut w);
    let mut we = etr;
    r.solve_lower(&mut we);
    let mut s = factor.h.clone();
    sub_gram_lower(s.as_view_mut(), w.as_view(), w.transpose().as_view());
    let mut rhs = factor.rhs.clone();
    rhs.gemv(-1.0, &w, &we, 1.0);
    let dp = cholesky(s)?.solve(&rhs);
    let mut dc = we;
    dc.gemv_tr(-1.0, &w, &dp, 1.0);
    r.solve_upper(&mut dc);
    Some((dp, dc))
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
    /// Held-out rows (3 per position observation, 6 per 6-D one).
    pub coordinates: usize,
    /// `Σ_f tr B_f`: what the fold fits add to `E[Σ |r_i|²] / σ²` beyond `coordinates`.
    pub trace: f64,
    /// `Σ_f tr B_f²` (for the degrees of freedom of the estimate).
    pub trace_squared: f64,
}

/// Every pose's residual and sparse columns at `robot`, the normal equations of each fold, and
/// their total.
struct FoldSums {
    /// The poses of each fold, in increasing order.
    fold_poses: Vec<Vec<usize>>,
    /// Pose `i`'s blocks of rows are `blocks[i]..blocks[i + 1]`.
    blocks: Vec<usize>,
    residuals: Vec<Vector3<f64>>,
    columns: PoseColumns,
    per_fold: Vec<Normal>,
    total: Normal,
}

/// [`FoldSums`], one job per fold ([`parallel::map_each`]): a fold's sums add its poses in order, as
/// one pass over all poses would.
fn fold_sums<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    folds: &Folds,
) -> FoldSums {
    let p = problem.len();
    let fold_poses: Vec<Vec<usize>> = (0..folds.k).map(|f| folds.split(f).0).collect();
    type Block = (Vector3<f64>, Vec<(usize, Vector3<f64>)>);
    let parts = parallel::map_each(&fold_poses, |poses| {
        let mut fk = ForwardKinematics::new();
        let mut sums = NormalSums::new(p);
        let mut rows: Vec<Vec<Block>> = Vec::with_capacity(poses.len());
        let mut cols = Vec::new();
        for &i in poses {
            let mut blocks = Vec::with_capacity(1);
            observation_blocks(problem, &mut fk, robot, &data[i], &mut cols, |r, c| {
                sums.add(r, c);
                blocks.push((*r, c.to_vec()));
            });
            rows.push(blocks);
        }
        (sums.finish(), rows)
    });
    let mut per_pose: Vec<Vec<Block>> = vec![Vec::new(); data.len()];
    let mut per_fold = Vec::with_capacity(folds.k);
    for (poses, (normal, rows)) in fold_poses.iter().zip(parts) {
        for (&i, row) in poses.iter().zip(rows) {
            per_pose[i] = row;
        }
        per_fold.push(normal);
    }
    let entries = per_pose.iter().flatten().map(|(_, c)| c.len()).sum();
    let count = per_pose.iter().map(Vec::len).sum();
    let mut columns = PoseColumns::with_capacity(count, entries);
    let mut residuals = Vec::with_capacity(count);
    let mut blocks = Vec::with_capacity(data.len() + 1);
    blocks.push(0);
    for pose in per_pose {
        for (r, c) in pose {
            residuals.push(r);
            columns.push_pose(c);
        }
        blocks.push(residuals.len());
    }
    let total = Normal::sum(p, &per_fold);
    FoldSums {
        fold_poses,
        blocks,
        residuals,
        columns,
        per_fold,
        total,
    }
}

/// [`FoldInflation`] of `problem` at `robot` for these folds (see there).
///
/// Only the traces of `B_f = J_f C_f J_fᵀ` are needed, and with `N_f = J_fᵀJ_f` (the held-out
/// fold's own normal matrix) they are traces of `p × p` products: `tr B_f = tr(C_f N_f)` and
/// `tr B_f² = tr((C_f N_f)²)`, instead of forming `B_f` over the fold's `3 n_f` coordinates.
/// The folds are independent and computed in parallel ([`parallel::map_each`]).
pub fn fold_inflation<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    folds: &Folds,
) -> FoldInflation {
    let FoldSums {
        per_fold,
        total,
        residuals,
        ..
    } = fold_sums(robot, problem, data, folds);
    let traces = parallel::map_each(&per_fold, |nf| fold_traces(problem, &total.a, nf));
    let mut out = FoldInflation {
        coordinates: 3 * residuals.len(),
        trace: 0.0,
        trace_squared: 0.0,
    };
    for (trace, trace_squared) in traces.into_iter().flatten() {
        out.trace += trace.max(0.0);
        out.trace_squared += trace_squared;
    }
    out
}

/// `(tr B_f, tr B_f²)` of the fold whose own normal equations are `nf` (`total`: the normal
/// matrix of all poses). `None` for an empty fold, and for a fold whose training matrix
/// cannot be factored: it adds nothing, and the estimate then falls back towards the plain
/// held-out mean squared error (its upper end).
fn fold_traces(problem: &Problem, total: &DMatrix<f64>, nf: &Normal) -> Option<(f64, f64)> {
    if nf.poses == 0 || problem.is_empty() {
        return None;
    }
    let a = total - &nf.a;
    let pen = problem.penalty_matrix(&a.diagonal());
    let mut h = &a + &pen;
    add_tiny_ridge(&mut h);
    // `C_f = H⁻¹ A H⁻¹` by products with the explicit inverse.
    let h_inv = cholesky_inverse(&cholesky(h)?)?;
    let cn = &h_inv * &a * &h_inv * &nf.a;
    let trace = cn.trace();
    let trace_squared = cn.component_mul(&cn.transpose()).sum();
    (trace.is_finite() && trace_squared.is_finite()).then_some((trace, trace_squared))
}
