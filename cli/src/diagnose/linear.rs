//! The refits' problem and the linear algebra the discrepancy search does around them.
//!
//! [`Problem`] is a parameter set of a refit: which parameters are free, their scales
//! ([`Param::scale`]: 1 mm at the tool per unit) and the penalty on the knots of correction
//! tables ([`TablePenalty`]), expressed as the library's penalty terms
//! ([`kinecal::identify::lm`]). The refits themselves are the library's
//! Levenberg–Marquardt ([`crate::diagnose::refit`]); what is here serves the screen and the
//! noise estimate, which work on normal equations directly: every pose's residual and sparse
//! scaled columns ([`Problem::pose_rows`]), their normal-equation sums per fold ([`Normal`],
//! [`NormalSums`]), the penalty matrix `Π` for a normal matrix ([`Problem::penalty_matrix`],
//! the same `Π` the library's run uses), the effective number of parameters of a penalised fit
//! and per-pose squared errors.
//!
//! The cost a refit minimises is `Σ |r_i|² + xᵀ Π x`, `x` being the parameters in scaled
//! units and `Π` the table penalty, scaled by the table's own mean diagonal of `JᵀJ` so that
//! it is light whatever the number of poses.

use crate::compute::banded::SymmetricBand;
use crate::compute::dense::{cholesky, cholesky_inverse};
use kinecal::identify::lm::{observation_cost, PenaltyTerm};
use kinecal::model::effects::EffectKind;
use kinecal::model::frame::orientation_error;
use kinecal::model::param::{value, Param};
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::{DMatrix, DVector, Vector3};

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
    /// The free parameters, in the order of the normal equations.
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
    /// Knot indices in `params` of every table, lowest knot first (consecutive).
    pub tables: Vec<Vec<usize>>,
    /// Strength of the penalty on every table.
    pub penalty: TablePenalty,
}

impl Problem {
    /// The parameters `params` of `robot` (duplicates ignored). Tables must be free as a whole
    /// or held as a whole, their knots in consecutive order in `params`.
    pub fn new<const N: usize, V: kinecal::ValueStorage>(
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
                let knots: Vec<usize> = idx.into_iter().flatten().collect();
                anyhow::ensure!(
                    knots.windows(2).all(|w| w[1] == w[0] + 1),
                    "a table's knots must be consecutive in the parameter list"
                );
                tables.push(knots);
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

    /// The number of free parameters.
    pub fn len(&self) -> usize {
        self.params.len()
    }
    /// True when nothing is free.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// The table penalty as the library's terms: one relative term per table, on its knots'
    /// positions in `params`.
    pub fn penalty_terms(&self) -> Vec<PenaltyTerm<f64>> {
        self.tables
            .iter()
            .filter(|t| !t.is_empty())
            .map(|t| table_term(t[0], t.len(), self.penalty))
            .collect()
    }

    /// Current values of the parameters in scaled units (the base rotation counts as zero:
    /// it is updated as a small rotation and never penalised).
    pub fn scaled_values<const N: usize, V: kinecal::ValueStorage>(
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

    /// The penalty matrix `Π` (scaled units) for a normal matrix whose diagonal is `diag`:
    /// the one a library run resolves at its first pass.
    pub fn penalty_matrix(&self, diag: &DVector<f64>) -> DMatrix<f64> {
        let mut pen = DMatrix::zeros(self.len(), self.len());
        for t in self.penalty_terms() {
            add_term(&mut pen, &t, diag);
        }
        pen
    }

    /// Residual and the non-zero scaled Jacobian columns of one observation's point at `robot`,
    /// weighted as the library's runs weigh them (`w ⊙ (p_m − p)`; unit weights leave
    /// millimetres). `fk` holds the pose afterwards, for [`Self::orientation_rows`].
    pub fn pose_rows<const N: usize, V: kinecal::ValueStorage>(
        &self,
        fk: &mut ForwardKinematics<f64, N>,
        robot: &Robot<f64, N, V>,
        m: &Measurement<f64, N>,
        cols: &mut Vec<(usize, Vector3<f64>)>,
    ) -> Vector3<f64> {
        cols.clear();
        let p = fk
            .compute_at(robot, &m.q, m.tool as usize, m.conditions())
            .unwrap_or_default();
        let weighted = m.weight != Vector3::repeat(1.0);
        let r = m.point - p;
        self.block_columns(
            fk,
            robot,
            m,
            cols,
            |fk, p| fk.column(robot, p).ok(),
            |fk, j| fk.reading_column(robot, j),
        );
        if weighted {
            for (_, c) in cols.iter_mut() {
                *c = c.component_mul(&m.weight);
            }
            return r.component_mul(&m.weight);
        }
        r
    }

    /// The orientation's residual (the rotation vector of the measured frame against the
    /// model's, times the observation's weight) and its non-zero scaled columns, for a 6-D
    /// observation whose point [`Self::pose_rows`] just computed (`fk` at its pose); `None`
    /// for a position observation.
    pub fn orientation_rows<const N: usize, V: kinecal::ValueStorage>(
        &self,
        fk: &ForwardKinematics<f64, N>,
        robot: &Robot<f64, N, V>,
        m: &Measurement<f64, N>,
        cols: &mut Vec<(usize, Vector3<f64>)>,
    ) -> Option<Vector3<f64>> {
        cols.clear();
        let o = m.orientation.as_ref()?;
        let w = m.orientation_weight;
        let r = orientation_error(o, &fk.tool_pose(robot)) * w;
        self.block_columns(
            fk,
            robot,
            m,
            cols,
            |fk, p| fk.rotation_column(robot, p).ok(),
            |fk, j| fk.reading_rotation_column(robot, j),
        );
        for (_, c) in cols.iter_mut() {
            *c *= w;
        }
        Some(r)
    }

    /// The non-zero scaled columns of one block of rows (`column`: a parameter's, `reading`:
    /// a joint reading's) at the pose `fk` holds.
    fn block_columns<const N: usize, V: kinecal::ValueStorage>(
        &self,
        fk: &ForwardKinematics<f64, N>,
        robot: &Robot<f64, N, V>,
        m: &Measurement<f64, N>,
        cols: &mut Vec<(usize, Vector3<f64>)>,
        column: impl Fn(&ForwardKinematics<f64, N>, Param) -> Option<Vector3<f64>>,
        reading: impl Fn(&ForwardKinematics<f64, N>, usize) -> Vector3<f64>,
    ) {
        for &i in &self.geometric {
            if let Some(c) = column(fk, self.params[i]) {
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
                let jc = reading(fk, j);
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
                        if let Some(c) = column(fk, Param::Effect(k as u16)) {
                            cols.push((*i, c * self.inv_scale[*i]));
                        }
                    }
                }
            }
        }
    }
}

/// Calls `f` with every block of rows of one observation at `robot` (its residual and
/// non-zero scaled columns): the point's, then for a 6-D observation the orientation's.
pub fn observation_blocks<const N: usize, V: kinecal::ValueStorage>(
    problem: &Problem,
    fk: &mut ForwardKinematics<f64, N>,
    robot: &Robot<f64, N, V>,
    m: &Measurement<f64, N>,
    cols: &mut Vec<(usize, Vector3<f64>)>,
    mut f: impl FnMut(&Vector3<f64>, &[(usize, Vector3<f64>)]),
) {
    let r = problem.pose_rows(fk, robot, m, cols);
    f(&r, cols);
    if let Some(r) = problem.orientation_rows(fk, robot, m, cols) {
        f(&r, cols);
    }
}

/// The library's penalty term of a table whose `len` knots start at position `first`.
pub fn table_term(first: usize, len: usize, p: TablePenalty) -> PenaltyTerm<f64> {
    PenaltyTerm::relative(first, len, p.ridge, p.smoothness)
}

/// Adds the term `t`, weighted as the library weighs it for a normal matrix whose diagonal is
/// `diag`, to `pen`.
fn add_term(pen: &mut DMatrix<f64>, t: &PenaltyTerm<f64>, diag: &DVector<f64>) {
    for_term_entries(t, diag, |i, j, v| pen[(i, j)] += v);
}

/// Calls `add(i, j, w · entry)` for each entry of the term `t` (half-bandwidth 2), weighted
/// as the library weighs it for a normal matrix whose diagonal is `diag`.
fn for_term_entries(
    t: &PenaltyTerm<f64>,
    diag: &DVector<f64>,
    mut add: impl FnMut(usize, usize, f64),
) {
    let w = t.weight(|k| diag[k]);
    for i in 0..t.len {
        for j in i.saturating_sub(2)..(i + 3).min(t.len) {
            add(t.first + i, t.first + j, w * t.entry(i, j));
        }
    }
}

/// Adds `w·(ridge·I + smoothness·DᵀD)` on the `m` leading rows and columns of `pen` (a
/// candidate table's knots), `w` the mean of `diag` over them: the library's term.
pub fn add_table_penalty(pen: &mut DMatrix<f64>, m: usize, diag: &DVector<f64>, p: TablePenalty) {
    if m > 0 {
        add_term(pen, &table_term(0, m, p), diag);
    }
}

/// [`add_table_penalty`] on a table's block kept as a band (half-bandwidth 2 or more).
pub fn add_table_penalty_band(pen: &mut SymmetricBand, diag: &DVector<f64>, p: TablePenalty) {
    if !pen.is_empty() {
        let term = table_term(0, pen.len(), p);
        for_term_entries(&term, diag, |i, j, v| {
            if j <= i {
                pen.add_lower(i, j, v)
            }
        });
    }
}

/// Normal equations `JᵀJ`, `Jᵀr` and the sum of squared residuals over some poses.
#[derive(Clone, Debug)]
pub struct Normal {
    /// `JᵀJ` (scaled columns).
    pub a: DMatrix<f64>,
    /// `Jᵀr`.
    pub g: DVector<f64>,
    /// Sum of squared residuals (mm²).
    pub ssr: f64,
    /// Number of blocks of three rows summed (one per position observation, two per 6-D one).
    pub poses: usize,
}

impl Normal {
    /// Empty sums for `p` parameters.
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
    pub fn of<const N: usize, V: kinecal::ValueStorage>(
        problem: &Problem,
        robot: &Robot<f64, N, V>,
        data: &[Measurement<f64, N>],
    ) -> Normal {
        let mut sums = NormalSums::new(problem.len());
        for_each_pose_rows(problem, robot, data, |r, cols| sums.add(r, cols));
        sums.finish()
    }
}

/// Calls `f` with every block of rows ([`observation_blocks`]) of every observation of
/// `data`, in order.
fn for_each_pose_rows<const N: usize, V: kinecal::ValueStorage>(
    problem: &Problem,
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    mut f: impl FnMut(&Vector3<f64>, &[(usize, Vector3<f64>)]),
) {
    let mut fk = ForwardKinematics::new();
    let mut cols = Vec::with_capacity(problem.len());
    for m in data {
        observation_blocks(problem, &mut fk, robot, m, &mut cols, &mut f);
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

    /// Adds one block of three rows (a point's, or a 6-D observation's orientation): its
    /// residual `r` and its non-zero columns (distinct indices). `poses` counts blocks.
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
    if let Some(floor) = tiny_ridge_floor(h.diagonal().as_slice()) {
        for i in 0..h.nrows() {
            h[(i, i)] = with_tiny_ridge(h[(i, i)], floor);
        }
    }
}

/// [`add_tiny_ridge`] on a band.
pub fn add_tiny_ridge_band(h: &mut SymmetricBand) {
    if let Some(floor) = tiny_ridge_floor(h.diagonal().as_slice()) {
        h.update_diagonal(|_, d| with_tiny_ridge(d, floor));
    }
}

/// The tiny ridge's floor for the diagonal `diag` (`None`: empty).
fn tiny_ridge_floor(diag: &[f64]) -> Option<f64> {
    let mean = diag.iter().sum::<f64>() / diag.len() as f64;
    (!diag.is_empty()).then(|| 1e-12 * mean.max(f64::MIN_POSITIVE))
}

/// A diagonal element `d` with the tiny ridge of `floor`.
fn with_tiny_ridge(d: f64, floor: f64) -> f64 {
    d + 1e-10 * d.max(floor) + floor
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

/// Squared error of every observation, weighted as the library's runs weigh it
/// ([`observation_cost`]): the squared 3-D distance (mm²) for an unweighted position, plus the
/// weighted orientation error of a 6-D observation.
pub fn squared_errors<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Vec<f64> {
    let mut fk = ForwardKinematics::new();
    data.iter()
        .map(|m| observation_cost(&mut fk, robot, m).unwrap_or(f64::NAN))
        .collect()
}
