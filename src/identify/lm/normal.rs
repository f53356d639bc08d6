//! The normal equations of a run, one observation at a time: its residual and scaled
//! Jacobian columns (the point's rows, and the orientation's for a 6-D observation) added to
//! `JᵀJ` (lower triangle) and `Jᵀr`, with the shortcuts that keep a pose `O(k²)` in the `k`
//! columns it excites (held columns' diagonal only, on the passes that need no more;
//! correction tables' two knots).

use super::residual::residual;
use super::storage::{LmParts, LmStorage};
use crate::io::measurement::Observation;
use crate::model::effects::{Effect, EffectKind};
use crate::model::param::Param;
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};
use core::marker::PhantomData;
use nalgebra::Vector3;

/// Zeroes the first `n` rows and entries of normal equations with row stride `stride`.
pub(super) fn clear_normal_equations<T: Real>(
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
/// `Jᵀr`, and the per-pose scratch of non-zero columns; `S`'s [`LmStorage::add_rows`] adds a
/// pose's dense rows.
pub(super) struct NormalSums<'a, T, S> {
    pub stride: usize,
    pub jtj: &'a mut [T],
    pub jtr: &'a mut [T],
    pub cx: &'a mut [T],
    pub cy: &'a mut [T],
    pub cz: &'a mut [T],
    pub nz: &'a mut [usize],
    /// Rows collected for [`LmStorage::add_batch`] (`S::BATCH_ROWS` rows of `stride`, then
    /// their residuals); empty: every pose's rows are added at once.
    pub batch: &'a mut [T],
    /// Rows collected in `batch` and not yet added.
    pub batched: usize,
    pub kernel: PhantomData<S>,
}

impl<T: Real, S: LmStorage<T>> NormalSums<'_, T, S> {
    /// Adds the rows collected in the batch (none: nothing to do) to the normal equations of
    /// the first `n` parameters.
    pub fn flush(&mut self, n: usize) {
        if self.batched == 0 {
            return;
        }
        let (rows, residuals) = self.batch.split_at(S::BATCH_ROWS * self.stride);
        S::add_batch(
            (&mut *self.jtj, &mut *self.jtr),
            self.stride,
            n,
            &rows[..self.batched * self.stride],
            &residuals[..self.batched],
        );
        self.batched = 0;
    }
}

/// A storage's arrays as what one pose reads (the parameters, scales, estimated set) and where
/// it adds (the normal equations and their per-pose scratch). `batched`: the rows of dense
/// poses are collected and added in blocks when the storage does that
/// ([`LmStorage::BATCH_ROWS`]) and has the room; the caller then flushes the sums at the end.
pub(super) fn split_parts<T: Real, S: LmStorage<T>>(
    p: LmParts<'_, T>,
    full: bool,
    gradient_only: bool,
    batched: bool,
) -> (Columns<'_, T>, NormalSums<'_, T, S>) {
    let room = S::BATCH_ROWS
        .checked_mul(p.stride + 1)
        .is_some_and(|need| p.batch.len() >= need);
    let batch = if batched && S::BATCH_ROWS >= 3 && room && !gradient_only {
        p.batch
    } else {
        &mut []
    };
    let columns = Columns {
        params: p.params,
        scale: p.scale,
        // One pose at a time (firmware): divided, as ever.
        reach: None,
        active: p.active,
        full,
        gradient_only,
        tables_in_order: false,
    };
    let sums = NormalSums {
        stride: p.stride,
        jtj: p.jtj,
        jtr: p.jtr,
        cx: p.cx,
        cy: p.cy,
        cz: p.cz,
        nz: p.nz,
        batch,
        batched: 0,
        kernel: PhantomData,
    };
    (columns, sums)
}

/// The parameters, their scales, which are estimated, and whether held columns enter in full:
/// what a pass needs to know of the solver.
#[derive(Clone, Copy, Debug)]
pub(super) struct Columns<'a, T> {
    pub params: &'a [Param],
    pub scale: &'a [T],
    /// The scale of the angles (the reach) with its inverse, when the columns are scaled by
    /// products: a pass over many poses (the host's passes); `None`: by divisions, as one
    /// pose at a time (firmware) does.
    pub reach: Option<Reach<T>>,
    pub active: &'a [bool],
    pub full: bool,
    /// Only `Jᵀr` (and the cost): `JᵀJ` is left as it is (a solver keeping its curvature).
    pub gradient_only: bool,
    /// Every table whose first knot is among `params` has all its knots follow in order
    /// ([`tables_in_order`], decided once for a pass over many poses): each pose then skips
    /// that check. `false`: each pose checks.
    pub tables_in_order: bool,
}

/// A robot's reach (mm per rad: the scale of angles and effect values) and its inverse.
#[derive(Clone, Copy, Debug)]
pub(super) struct Reach<T> {
    pub mm: T,
    pub inverse: T,
}

impl<T: Real> Reach<T> {
    /// The scale other than 1 in `scales` (the reach, per [`Param::scale`]), if any.
    pub fn of_scales(scales: &[T]) -> Option<Self> {
        let mm = scales.iter().copied().find(|s| *s != T::one())?;
        Some(Self {
            mm,
            inverse: T::one() / mm,
        })
    }
}

/// Column `c` of a parameter with scale `s`, scaled (`c / s`): unchanged for lengths (scale 1:
/// the division would give `c` exactly); with the reach given (a pass over many poses), by
/// the reach's inverse for the rest (a division per column and pose was a fifth of an identify
/// on the host); else, and for any other scale, divided.
#[inline(always)]
fn scaled<T: Real>(c: Vector3<T>, s: T, reach: Option<Reach<T>>) -> Vector3<T> {
    match reach {
        _ if s == T::one() => c,
        Some(r) if s == r.mm => c * r.inverse,
        _ => c / s,
    }
}

/// Which rows of an observation a block of the Jacobian is: the point's three coordinates,
/// or the three components of the orientation error (6-D observations).
pub(super) trait Rows {
    /// `∂(rows)/∂param` at the last computed pose.
    fn column<T: Real, const N: usize, V: ValueStorage>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Vector3<T>;
    /// `∂(rows)/∂r'_j`, the corrected reading of joint `j` (what a joint correction adds to).
    fn reading<T: Real, const N: usize, V: ValueStorage>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        j: usize,
    ) -> Vector3<T>;
}

/// The point's rows.
pub(super) struct PointRows;
/// The orientation's rows.
pub(super) struct OrientationRows;

impl Rows for PointRows {
    #[inline(always)]
    fn column<T: Real, const N: usize, V: ValueStorage>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Vector3<T> {
        // Parameters were checked against the robot at construction: a column always exists.
        fk.column(robot, p).unwrap_or_else(|_| Vector3::zeros())
    }
    #[inline(always)]
    fn reading<T: Real, const N: usize, V: ValueStorage>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        j: usize,
    ) -> Vector3<T> {
        fk.reading_column(robot, j)
    }
}

impl Rows for OrientationRows {
    #[inline(always)]
    fn column<T: Real, const N: usize, V: ValueStorage>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        p: Param,
    ) -> Vector3<T> {
        fk.rotation_column(robot, p)
            .unwrap_or_else(|_| Vector3::zeros())
    }
    #[inline(always)]
    fn reading<T: Real, const N: usize, V: ValueStorage>(
        fk: &ForwardKinematics<T, N>,
        robot: &Robot<T, N, V>,
        j: usize,
    ) -> Vector3<T> {
        fk.reading_rotation_column(robot, j)
    }
}

/// Adds one observation's residual and scaled Jacobian to `out` and returns its squared
/// (weighted) residual: the point's rows, then for a 6-D observation the orientation's.
pub(super) fn accumulate_pose<
    T: Real,
    const N: usize,
    V: ValueStorage,
    M: Observation<T, N>,
    S: LmStorage<T>,
>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    m: &M,
    set: &Columns<'_, T>,
    out: &mut NormalSums<'_, T, S>,
) -> T {
    // The pass checked that the robot has the observation's point.
    let Some((r, rot)) = residual(fk, robot, m) else {
        return T::zero();
    };
    let mut cost = accumulate_rows::<PointRows, T, N, V, S>(fk, robot, r, m.weight(), set, out);
    if let (Some(rr), Some((_, w))) = (rot, m.orientation()) {
        let w = Some(Vector3::repeat(w));
        cost += accumulate_rows::<OrientationRows, T, N, V, S>(fk, robot, rr, w, set, out);
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
fn accumulate_rows<R: Rows, T: Real, const N: usize, V: ValueStorage, S: LmStorage<T>>(
    fk: &ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    r: Vector3<T>,
    weight: Option<Vector3<T>>,
    set: &Columns<'_, T>,
    out: &mut NormalSums<'_, T, S>,
) -> T {
    // A gradient-only pass leaves `JᵀJ` alone: no held column's diagonal either.
    let set = &Columns {
        full: set.full || set.gradient_only,
        ..*set
    };
    let Columns {
        params,
        scale,
        reach,
        active,
        full,
        gradient_only,
        ..
    } = *set;
    let n = params.len();
    let s = out.stride;
    // Column k is (cx[k], cy[k], cz[k]) (zero when it does not enter); `nz`: the entering
    // non-zero ones. Tables (only a robot with room for effects can have one) touch two knots
    // of many: their columns are set apart. A pass that collects rows for a block update
    // writes the columns straight into the batch's next three rows.
    let with_tables =
        V::CAPACITY > 0 && robot.effects().iter().any(|e| e.kind == EffectKind::Table);
    let batching = S::BATCH_ROWS > 0 && !out.batch.is_empty() && !with_tables;
    let k_nz = if with_tables {
        columns_with_tables::<R, T, N, V, S>(fk, robot, set, weight, out)
    } else {
        let b = out.batched;
        let (dx, dy, dz) = if batching {
            // `batched + 3 ≤ S::BATCH_ROWS` rows of `s` (a full batch is added at once).
            let (x, rest) = out.batch[b * s..(b + 3) * s].split_at_mut(s);
            let (y, z) = rest.split_at_mut(s);
            (x, y, z)
        } else {
            (&mut *out.cx, &mut *out.cy, &mut *out.cz)
        };
        let mut k_nz = 0;
        for k in 0..n {
            let mut c = scaled(R::column(fk, robot, params[k]), scale[k], reach);
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
            (dx[k], dy[k], dz[k]) = (c.x, c.y, c.z);
        }
        k_nz
    };
    let (cx, cy, cz) = if batching {
        let rows = &out.batch[out.batched * s..(out.batched + 3) * s];
        (&rows[..n], &rows[s..s + n], &rows[2 * s..2 * s + n])
    } else {
        (&out.cx[..n], &out.cy[..n], &out.cz[..n])
    };
    let nz = &out.nz[..k_nz];
    if gradient_only {
        for &i in nz {
            out.jtr[i] += Vector3::new(cx[i], cy[i], cz[i]).dot(&r);
        }
        return r.norm_squared();
    }
    // Most columns enter (the geometric case): whole contiguous rows, zero columns adding
    // nothing. Few (tables touch two knots of many): only the pairs that do.
    if 2 * k_nz >= n {
        if batching {
            // The rows join the batch (the zero columns add nothing there either); a full
            // batch is added.
            let b = out.batched;
            let residuals = &mut out.batch[S::BATCH_ROWS * s..];
            residuals[b..b + 3].copy_from_slice(&[r.x, r.y, r.z]);
            out.batched += 3;
            if out.batched + 3 > S::BATCH_ROWS {
                out.flush(n);
            }
        } else {
            S::add_rows((out.jtj, out.jtr), s, (cx, cy, cz), [r.x, r.y, r.z], nz);
        }
        return r.norm_squared();
    }
    // Sparse (a model with effects, where tables touch few of many columns): how many of the
    // entering columns are `0, 1, 2, …` (a contiguous leading run: the geometric columns).
    let lead = if V::CAPACITY == 0 {
        0
    } else {
        nz.iter().enumerate().take_while(|(a, j)| *a == **j).count()
    };
    for (a, &i) in nz.iter().enumerate() {
        let (xi, yi, zi) = (cx[i], cy[i], cz[i]);
        out.jtr[i] += Vector3::new(xi, yi, zi).dot(&r);
        let row = &mut out.jtj[i * s..i * s + i + 1];
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
    r.norm_squared()
}

/// One pose's columns (as in [`accumulate_pose`]) of a robot with correction tables: a table
/// whose knots are consecutive in the parameter list (the usual order) is handled as a run:
/// its columns zeroed at once and only the two knots around the reading computed (one
/// segment look-up per table and pose instead of one per knot). Returns the number of
/// entering non-zero columns (in `out.nz`, increasing).
#[inline(never)]
fn columns_with_tables<R: Rows, T: Real, const N: usize, V: ValueStorage, S: LmStorage<T>>(
    fk: &ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    set: &Columns<'_, T>,
    weight: Option<Vector3<T>>,
    out: &mut NormalSums<'_, T, S>,
) -> usize {
    let Columns {
        params,
        scale,
        reach,
        active,
        full,
        tables_in_order,
        ..
    } = *set;
    let n = params.len();
    let s = out.stride;
    let mut k_nz = 0;
    // Column `k` is `c` (already scaled).
    let mut enter = |out: &mut NormalSums<'_, T, S>, k: usize, mut c: Vector3<T>| {
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
            if let Some(e) = table_run_at(robot, params, k, v, tables_in_order) {
                let (len, j) = (e.len as usize, e.joint as usize);
                out.cx[k..k + len].fill(T::zero());
                out.cy[k..k + len].fill(T::zero());
                out.cz[k..k + len].fill(T::zero());
                let (seg, w) = e.segment(fk.q[j]);
                let jc = R::reading(fk, robot, j);
                for (i, phi) in [(seg, T::one() - w), (seg + 1, w)] {
                    if phi != T::zero() && i < len {
                        enter(out, k + i, scaled(jc * phi, scale[k + i], reach));
                    }
                }
                k += len;
                continue;
            }
            if let Some((e, run)) = table_knots_at(robot, params, k, v) {
                // Some of the table's knots are held (not among `params`): the run holds the
                // others in increasing order, and only the two around the reading are non-zero.
                let j = e.joint as usize;
                out.cx[k..k + run].fill(T::zero());
                out.cy[k..k + run].fill(T::zero());
                out.cz[k..k + run].fill(T::zero());
                let (seg, w) = e.segment(fk.q[j]);
                let lower = e.first as usize + seg;
                let jc = R::reading(fk, robot, j);
                for i in k..k + run {
                    let Param::Effect(u) = params[i] else { break };
                    let phi = match (u as usize).checked_sub(lower) {
                        Some(0) => T::one() - w,
                        Some(1) => w,
                        Some(_) => break,
                        None => continue,
                    };
                    if phi != T::zero() {
                        enter(out, i, scaled(jc * phi, scale[i], reach));
                    }
                }
                k += run;
                continue;
            }
        }
        // Parameters were checked against the robot at construction: a column always exists.
        let c = match params[k] {
            Param::Effect(v) => tables.column::<R, N, V>(fk, robot, v),
            _ => None,
        };
        let c = c.unwrap_or_else(|| R::column(fk, robot, params[k]));
        enter(out, k, scaled(c, scale[k], reach));
        k += 1;
    }
    k_nz
}

/// The table whose first knot is effect value `v` = `params[k]`, when all its knots follow in
/// order from position `k` (and its joint exists). `in_order`: [`tables_in_order`] holds for
/// `robot` and `params`, so the knots after the first need no look.
#[inline]
fn table_run_at<'r, T: Real, const N: usize, V: ValueStorage>(
    robot: &'r Robot<T, N, V>,
    params: &[Param],
    k: usize,
    v: u16,
    in_order: bool,
) -> Option<&'r Effect<T>> {
    let e = robot
        .effects()
        .iter()
        .find(|e| e.kind == EffectKind::Table && e.first == v)?;
    let len = e.len as usize;
    let run = params.get(k..k + len)?;
    let consecutive = in_order
        || run
            .iter()
            .enumerate()
            .all(|(i, p)| *p == Param::Effect(v.wrapping_add(i as u16)));
    (consecutive && (e.joint as usize) < N && len >= 2).then_some(e)
}

/// The table holding effect value `v` = `params[k]` and how many positions from `k` on hold
/// its knots in increasing order (knots held out of `params` leave gaps in the values): what
/// [`table_run_at`] finds when the table's first knot is not at `k` or some knots are missing.
#[inline]
fn table_knots_at<'r, T: Real, const N: usize, V: ValueStorage>(
    robot: &'r Robot<T, N, V>,
    params: &[Param],
    k: usize,
    v: u16,
) -> Option<(&'r Effect<T>, usize)> {
    let end = |e: &Effect<T>| u32::from(e.first) + u32::from(e.len);
    let e = robot
        .effects()
        .iter()
        .find(|e| e.kind == EffectKind::Table && e.first <= v && u32::from(v) < end(e))?;
    if e.joint as usize >= N || e.len < 2 {
        return None;
    }
    let mut last = v;
    let mut run = 1;
    for p in params.get(k + 1..)? {
        match *p {
            Param::Effect(u) if u > last && u32::from(u) < end(e) => {
                last = u;
                run += 1;
            }
            _ => break,
        }
    }
    Some((e, run))
}

/// Whether every table of `robot` whose first knot is among `params` has all its knots follow
/// it in order (the usual parameter order), as [`table_run_at`] would check at each pose:
/// `O(params)` once for a pass instead of once per pose.
pub(super) fn tables_in_order<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    params: &[Param],
) -> bool {
    params.iter().enumerate().all(|(k, p)| {
        let Param::Effect(v) = *p else {
            return true;
        };
        let Some(e) = robot
            .effects()
            .iter()
            .find(|e| e.kind == EffectKind::Table && e.first == v)
        else {
            return true;
        };
        params.get(k..k + e.len as usize).is_some_and(|run| {
            run.iter()
                .enumerate()
                .all(|(i, p)| *p == Param::Effect(v.wrapping_add(i as u16)))
        })
    })
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
    fn column<R: Rows, const N: usize, V: ValueStorage>(
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
