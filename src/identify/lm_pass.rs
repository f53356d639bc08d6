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

use crate::identify::lm_status::LmError;
use crate::identify::lm_storage::{LmParts, LmStorage};
use crate::io::measurement::Observation;
use crate::model::effects::{Effect, EffectKind};
use crate::model::frame::orientation_error;
use crate::model::param::Param;
use crate::{ForwardKinematics, Real, Robot};
use nalgebra::Vector3;

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

/// The pass a run needs next (see the [module](self)). Borrowing the solver, it is shared by
/// the workers of one pass.
#[derive(Clone, Copy, Debug)]
pub struct Pass<'a, T: Real, const N: usize, const V: usize> {
    pub(crate) kind: PassKind,
    /// Which pass of the run this is (parts of another pass are refused).
    pub(crate) id: u32,
    /// The model the pass evaluates (the estimate, or the candidate).
    pub(crate) robot: &'a Robot<T, N, V>,
    pub(crate) columns: Columns<'a, T>,
}

/// One worker's share of a pass: its partial sums, in storage for the solver's parameters
/// (only the normal equations `jtj`, `jtr` and the per-pose scratch `cx`, `cy`, `cz`, `nz` are
/// used;
/// the other arrays may be empty).
#[derive(Clone, Debug)]
pub struct PassPart<T: Real, S: LmStorage<T>> {
    pub(crate) storage: S,
    pub(crate) cost: T,
    pub(crate) poses: usize,
    /// The pass these sums belong to (`None`: never used).
    pub(crate) id: Option<u32>,
}

impl<T: Real, S: LmStorage<T>> PassPart<T, S> {
    /// A part with `storage` for the same parameters as the solver's.
    pub fn new(storage: S) -> Self {
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
    pub fn storage(&self) -> &S {
        &self.storage
    }
}

impl<T: Real, const N: usize, const V: usize> Pass<'_, T, N, V> {
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
    pub fn accumulate<S: LmStorage<T>, M: Observation<T, N>>(
        &self,
        fk: &mut ForwardKinematics<T, N>,
        poses: &[M],
        part: &mut PassPart<T, S>,
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
        let (_, mut sums) = split_parts(
            part.storage.parts(),
            self.columns.full,
            self.columns.gradient_only,
        );
        for m in poses {
            part.cost += accumulate_pose(fk, self.robot, m, &self.columns, &mut sums);
        }
        part.poses += poses.len();
        Ok(())
    }
}

/// Checks that a part's storage has room for what a pass writes: the normal equations and the
/// per-pose scratch (the solver's other arrays may be empty).
fn part_fits<T: Real, S: LmStorage<T>>(st: &mut S) -> bool {
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

/// Zeroes the first `n` rows and entries of normal equations with row stride `stride`.
pub(crate) fn clear_normal_equations<T: Real>(
    jtj: &mut [T],
    jtr: &mut [T],
    stride: usize,
    n: usize,
) {
    for i in 0..n {
        jtj[i * stride..i * stride + n].fill(T::zero());
    }
    jtr[..n].fill(T::zero());
}

/// Where one pose's contribution goes: the lower triangle of `JᵀJ` (row stride `stride`),
/// `Jᵀr`, and the per-pose scratch of non-zero columns.
pub(crate) struct NormalSums<'a, T> {
    pub stride: usize,
    pub jtj: &'a mut [T],
    pub jtr: &'a mut [T],
    pub cx: &'a mut [T],
    pub cy: &'a mut [T],
    pub cz: &'a mut [T],
    pub nz: &'a mut [usize],
}

/// A storage's arrays as what one pose reads (the parameters, scales, estimated set) and where
/// it adds (the normal equations and their per-pose scratch).
pub(crate) fn split_parts<T>(
    p: LmParts<'_, T>,
    full: bool,
    gradient_only: bool,
) -> (Columns<'_, T>, NormalSums<'_, T>) {
    let columns = Columns {
        params: p.params,
        scale: p.scale,
        active: p.active,
        full,
        gradient_only,
    };
    let sums = NormalSums {
        stride: p.stride,
        jtj: p.jtj,
        jtr: p.jtr,
        cx: p.cx,
        cy: p.cy,
        cz: p.cz,
        nz: p.nz,
    };
    (columns, sums)
}

/// The parameters, their scales, which are estimated, and whether held columns enter in full:
/// what a pass needs to know of the solver.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Columns<'a, T> {
    pub params: &'a [Param],
    pub scale: &'a [T],
    pub active: &'a [bool],
    pub full: bool,
    /// Only `Jᵀr` (and the cost): `JᵀJ` is left as it is (a solver keeping its curvature).
    pub gradient_only: bool,
}

/// Which rows of an observation a block of the Jacobian is: the point's three coordinates,
/// or the three components of the orientation error (6-D observations).
pub(crate) trait Rows {
    /// `∂(rows)/∂param` at the last computed pose.
    fn column<T: Real, const N: usize, const V: usize>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Vector3<T>;
    /// `∂(rows)/∂r'_j`, the corrected reading of joint `j` (what a joint correction adds to).
    fn reading<T: Real, const N: usize, const V: usize>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        j: usize,
    ) -> Vector3<T>;
}

/// The point's rows.
pub(crate) struct PointRows;
/// The orientation's rows.
pub(crate) struct OrientationRows;

impl Rows for PointRows {
    #[inline(always)]
    fn column<T: Real, const N: usize, const V: usize>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Vector3<T> {
        // Parameters were checked against the robot at construction: a column always exists.
        fk.column(robot, p).unwrap_or_else(|_| Vector3::zeros())
    }
    #[inline(always)]
    fn reading<T: Real, const N: usize, const V: usize>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        j: usize,
    ) -> Vector3<T> {
        fk.reading_column(robot, j)
    }
}

impl Rows for OrientationRows {
    #[inline(always)]
    fn column<T: Real, const N: usize, const V: usize>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Vector3<T> {
        fk.rotation_column(robot, p)
            .unwrap_or_else(|_| Vector3::zeros())
    }
    #[inline(always)]
    fn reading<T: Real, const N: usize, const V: usize>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        j: usize,
    ) -> Vector3<T> {
        fk.reading_rotation_column(robot, j)
    }
}

/// The weighted residual of one observation at `robot` and its squared norm (the observation's
/// share of the cost): the point's `w ⊙ (p_m − p)` and, for a 6-D observation, the orientation
/// error's rotation vector times its weight. `fk` holds the pose afterwards. `None` when the
/// robot has no tool point `m.tool`.
#[inline(always)]
pub(crate) fn residual<T: Real, const N: usize, const V: usize, M: Observation<T, N>>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    m: &M,
) -> Option<(Vector3<T>, Option<Vector3<T>>)> {
    // Only a model with value capacity can have a thermal-expansion term (the firmware's has
    // none: no instruction here).
    if V > 0 {
        fk.temp_c = m.temperature();
    }
    let p = if m.tool() == 0 {
        fk.compute(robot, m.q())
    } else {
        fk.compute_point(robot, m.q(), m.tool())?
    };
    let mut r = m.point() - p;
    if let Some(w) = m.weight() {
        r = r.component_mul(&w);
    }
    let rot = m
        .orientation()
        .map(|(o, w)| orientation_error(o, &fk.tool_pose(robot)) * w);
    Some((r, rot))
}

/// The weighted squared residual of one observation (the module documentation of
/// [`crate::io::measurement`] gives it); `None` when the
/// robot has no tool point `m.tool`.
pub fn observation_cost<T: Real, const N: usize, const V: usize, M: Observation<T, N>>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    m: &M,
) -> Option<T> {
    let (r, rot) = residual(fk, robot, m)?;
    Some(r.norm_squared() + rot.map_or(T::zero(), |v| v.norm_squared()))
}

/// Adds one observation's residual and scaled Jacobian to `out` and returns its squared
/// (weighted) residual: the point's rows, then for a 6-D observation the orientation's.
pub(crate) fn accumulate_pose<T: Real, const N: usize, const V: usize, M: Observation<T, N>>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    m: &M,
    set: &Columns<'_, T>,
    out: &mut NormalSums<'_, T>,
) -> T {
    // The pass checked that the robot has the observation's point.
    let Some((r, rot)) = residual(fk, robot, m) else {
        return T::zero();
    };
    let mut cost = accumulate_rows::<PointRows, T, N, V>(fk, robot, r, m.weight(), set, out);
    if let (Some(rr), Some((_, w))) = (rot, m.orientation()) {
        let w = Some(Vector3::repeat(w));
        cost += accumulate_rows::<OrientationRows, T, N, V>(fk, robot, rr, w, set, out);
    }
    cost
}

/// Adds three rows (residual `r`, already weighted; columns from `R`, weighted by `weight`)
/// to `out` and returns `|r|²`.
///
/// Held columns join fully only on the passes that decide identifiability; otherwise just
/// their diagonal, which tells when the model has moved to where the data see them. When few
/// columns are non-zero at this pose (tables touch two knots of many) only their pairs are
/// updated: `O(k²)` for `k` of them instead of `O(P²)`.
#[inline(always)]
fn accumulate_rows<R: Rows, T: Real, const N: usize, const V: usize>(
    fk: &ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    r: Vector3<T>,
    weight: Option<Vector3<T>>,
    set: &Columns<'_, T>,
    out: &mut NormalSums<'_, T>,
) -> T {
    // A gradient-only pass leaves `JᵀJ` alone: no held column's diagonal either.
    let set = &Columns {
        full: set.full || set.gradient_only,
        ..*set
    };
    let Columns {
        params,
        scale,
        active,
        full,
        gradient_only,
    } = *set;
    let n = params.len();
    let s = out.stride;
    // Column k is (cx[k], cy[k], cz[k]) (zero when it does not enter); `nz`: the entering
    // non-zero ones. Tables (only a robot with room for effects can have one) touch two knots
    // of many: their columns are set apart.
    let with_tables = V > 0 && robot.effects().iter().any(|e| e.kind == EffectKind::Table);
    let k_nz = if with_tables {
        columns_with_tables::<R, T, N, V>(fk, robot, set, weight, out)
    } else {
        let mut k_nz = 0;
        for k in 0..n {
            let mut c = R::column(fk, robot, params[k]) / scale[k];
            if let Some(w) = weight {
                c = c.component_mul(&w);
            }
            if !active[k] && !full {
                out.jtj[k * s + k] += c.norm_squared();
                c = Vector3::zeros();
            } else if c.x != T::zero() || c.y != T::zero() || c.z != T::zero() {
                out.nz[k_nz] = k;
                k_nz += 1;
            }
            (out.cx[k], out.cy[k], out.cz[k]) = (c.x, c.y, c.z);
        }
        k_nz
    };
    let (cx, cy, cz, nz) = (&out.cx[..n], &out.cy[..n], &out.cz[..n], &out.nz[..k_nz]);
    if gradient_only {
        for &i in nz {
            out.jtr[i] += Vector3::new(cx[i], cy[i], cz[i]).dot(&r);
        }
        return r.norm_squared();
    }
    // Most columns enter (the geometric case): whole contiguous rows, zero columns adding
    // nothing. Few (tables touch two knots of many): only the pairs that do.
    let dense = 2 * k_nz >= n;
    // Sparse (a model with effects, where tables touch few of many columns): how many of the
    // entering columns are `0, 1, 2, …` (a contiguous leading run: the geometric columns).
    let lead = if dense || V == 0 {
        0
    } else {
        nz.iter().enumerate().take_while(|(a, j)| *a == **j).count()
    };
    for (a, &i) in nz.iter().enumerate() {
        let (xi, yi, zi) = (cx[i], cy[i], cz[i]);
        out.jtr[i] += Vector3::new(xi, yi, zi).dot(&r);
        let row = &mut out.jtj[i * s..i * s + i + 1];
        if dense {
            let cols = cx[..=i].iter().zip(&cy[..=i]).zip(&cz[..=i]);
            for (v, ((x, y), z)) in row.iter_mut().zip(cols) {
                *v += xi * *x + yi * *y + zi * *z;
            }
        } else {
            // nz is increasing, so every j ≤ i: the lower triangle. Its leading run `0..lead`
            // (the geometric columns, which every pose excites) as one contiguous row.
            let head = lead.min(a + 1);
            let cols = cx[..head].iter().zip(&cy[..head]).zip(&cz[..head]);
            for (v, ((x, y), z)) in row[..head].iter_mut().zip(cols) {
                *v += xi * *x + yi * *y + zi * *z;
            }
            for &j in &nz[head..=a] {
                row[j] += xi * cx[j] + yi * cy[j] + zi * cz[j];
            }
        }
    }
    r.norm_squared()
}

/// One pose's columns (as in [`accumulate_pose`]) of a robot with correction tables: a table
/// whose knots are consecutive in the parameter list (the usual order) is handled as a run:
/// its columns zeroed at once and only the two knots around the reading computed (one
/// segment look-up per table and pose instead of one per knot). Returns the number of
/// entering non-zero columns (in `out.nz`, increasing).
#[inline(never)]
fn columns_with_tables<R: Rows, T: Real, const N: usize, const V: usize>(
    fk: &ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    set: &Columns<'_, T>,
    weight: Option<Vector3<T>>,
    out: &mut NormalSums<'_, T>,
) -> usize {
    let Columns {
        params,
        scale,
        active,
        full,
        ..
    } = *set;
    let n = params.len();
    let s = out.stride;
    let mut k_nz = 0;
    // Column `k` is `c` (already scaled).
    let mut enter = |out: &mut NormalSums<'_, T>, k: usize, mut c: Vector3<T>| {
        if let Some(w) = weight {
            c = c.component_mul(&w);
        }
        if !active[k] && !full {
            out.jtj[k * s + k] += c.norm_squared();
            c = Vector3::zeros();
        } else if c.x != T::zero() || c.y != T::zero() || c.z != T::zero() {
            out.nz[k_nz] = k;
            k_nz += 1;
        }
        (out.cx[k], out.cy[k], out.cz[k]) = (c.x, c.y, c.z);
    };
    let mut tables = TableCache::new();
    let mut k = 0;
    while k < n {
        if let Param::Effect(v) = params[k] {
            if let Some(e) = table_run_at(robot, params, k, v) {
                let (len, j) = (e.len as usize, e.joint as usize);
                out.cx[k..k + len].fill(T::zero());
                out.cy[k..k + len].fill(T::zero());
                out.cz[k..k + len].fill(T::zero());
                let (seg, w) = e.segment(fk.q[j]);
                let jc = R::reading(fk, robot, j);
                for (i, phi) in [(seg, T::one() - w), (seg + 1, w)] {
                    if phi != T::zero() && i < len {
                        enter(out, k + i, jc * phi / scale[k + i]);
                    }
                }
                k += len;
                continue;
            }
        }
        // Parameters were checked against the robot at construction: a column always exists.
        let c = match params[k] {
            Param::Effect(v) => tables.column::<R, N, V>(fk, robot, v),
            _ => None,
        };
        let c = c.unwrap_or_else(|| R::column(fk, robot, params[k]));
        enter(out, k, c / scale[k]);
        k += 1;
    }
    k_nz
}

/// The table whose first knot is effect value `v` = `params[k]`, when all its knots follow in
/// order from position `k` (and its joint exists).
#[inline]
fn table_run_at<'r, T: Real, const N: usize, const V: usize>(
    robot: &'r Robot<T, N, V>,
    params: &[Param],
    k: usize,
    v: u16,
) -> Option<&'r Effect<T>> {
    let e = robot
        .effects()
        .iter()
        .find(|e| e.kind == EffectKind::Table && e.first == v)?;
    let len = e.len as usize;
    let run = params.get(k..k + len)?;
    let consecutive = run
        .iter()
        .enumerate()
        .all(|(i, p)| *p == Param::Effect(v.wrapping_add(i as u16)));
    (consecutive && (e.joint as usize) < N && len >= 2).then_some(e)
}

/// The table segment of the last table looked up at one pose: consecutive knots of a table
/// (the usual parameter order) find it without a search.
struct TableCache<T: Real> {
    /// Value indices `first .. first + len` of the table, the lower knot of the pose's segment
    /// (value index), the upper knot's weight and `∂p/∂r'_j`.
    hit: Option<(usize, usize, usize, T, Vector3<T>)>,
}

impl<T: Real> TableCache<T> {
    fn new() -> Self {
        Self { hit: None }
    }

    /// The column of effect value `v` when it is a table knot (`None`: not a table's): what
    /// [`ForwardKinematics::column`] gives, `∂p/∂r'_j · φ_v`.
    #[inline]
    fn column<R: Rows, const N: usize, const V: usize>(
        &mut self,
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        v: u16,
    ) -> Option<Vector3<T>> {
        let v = v as usize;
        let inside = |first: usize, len: usize| first <= v && v < first + len;
        if !self.hit.is_some_and(|(f, l, ..)| inside(f, l)) {
            let e: &Effect<T> = robot.effects().iter().find(|e| {
                e.kind == EffectKind::Table && inside(e.first as usize, e.len as usize)
            })?;
            let j = e.joint as usize;
            if j >= N {
                return None;
            }
            let (seg, w) = e.segment(fk.q[j]);
            let first = e.first as usize;
            self.hit = Some((
                first,
                e.len as usize,
                first + seg,
                w,
                R::reading(fk, robot, j),
            ));
        }
        let (_, _, lower, w, jc) = self.hit?;
        let phi = if v == lower {
            T::one() - w
        } else if v == lower + 1 {
            w
        } else {
            T::zero()
        };
        Some(jc * phi)
    }
}

/// `Ok` when every observation is finite and names a tool point of `robot`.
pub(crate) fn check_observations<T: Real, const N: usize, const V: usize, M: Observation<T, N>>(
    robot: &Robot<T, N, V>,
    data: &[M],
) -> Result<(), LmError> {
    if data.iter().any(|m| !m.is_valid()) {
        return Err(LmError::NonFiniteMeasurement);
    }
    if data.iter().any(|m| m.tool() >= robot.tool_point_count()) {
        return Err(LmError::UnknownToolPoint);
    }
    Ok(())
}
