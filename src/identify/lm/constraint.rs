//! One constraint group (a socket, a plane, a distance, a tracker point: [`crate::io::constraint`])
//! into the normal equations of a run, its unknown shape eliminated.
//!
//! A socket's centre and a plane's normal and offset are not parameters of the run: each pass
//! puts them where they fit the group best at the model it evaluates (the weighted mean of the
//! group's points; the plane through their weighted centroid across their least spread), and
//! the group's rows enter the normal equations with the shape's columns projected out (the
//! Schur complement of the shape's block), so a step of the model is the model's part of the
//! joint Gauss–Newton step of model and shapes. Per group, with `W_i = 1/σ_i²`, `c_i` the
//! scaled model columns of row `i` and `p_i` its point:
//!
//! - socket: residuals `p_i − p̄`, columns `c_i − c̄` (bars: weighted means);
//! - plane (normal `n`, in-plane axes `t₁`, `t₂`, spreads `λ₁`, `λ₂` along them): residuals
//!   `n·(p_i − p̄)`, columns `n·(c_i − c̄)`, less the tilts' couplings `b_t bₜᵀ/λ_t`,
//!   `b_t = Σ W_i (t·(p_i − p̄)) n·c_i`;
//! - distance: residual `|p_a − p_b| − L`, columns `u·(c_a − c_b)`, `u` from `p_b` to `p_a`;
//! - point: residual `p − x`, columns `c`.
//!
//! What a group's shape absorbs is no information about the model: a column whose projected
//! norm is below [`ABSORBED`] of its norm in the group's rows (the base and the first joint's
//! offset from a socket, the base from a distance; exactly or to the points' spread over the
//! reach) adds nothing from that group, so a direction no group sees stays at zero and the
//! run's analysis holds it (reported by
//! [`Levenberg::unidentifiable`](super::Levenberg::unidentifiable)).
//!
//! A group is summed in caller scratch of [`constraint_scratch_len`] numbers (its own normal
//! equations, so its shape can be projected out and its absorbed columns dropped) and then
//! added to the run's: `O(P²)` per row, `O(P²)` more per group.

use super::normal::{Columns, NormalSums};
use super::storage::LmStorage;
use crate::io::constraint::{ConstraintGroup, ConstraintKind, ConstraintRow};
use crate::num::linalg::symmetric_eigen;
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};
use nalgebra::Vector3;

/// A model column that a group's shape absorbs to within this fraction of its norm in the
/// group's rows adds nothing from that group (a base rotation seen by one socket: the spread of
/// its points over the reach, ~1e-3 at a nominal model, exactly zero at the true one).
pub const ABSORBED: f64 = 1e-2;

/// Numbers of caller scratch a constraint run with `params` parameters needs
/// ([`super::Levenberg::step_constraints`]): a group's `P × P` normal equations and a few
/// columns.
pub const fn constraint_scratch_len(params: usize) -> usize {
    params * params + 11 * params
}

/// The scratch cut into its arrays (each `n` long; `jtj` `n × n`, row stride `n`).
struct Scratch<'a, T> {
    n: usize,
    jtj: &'a mut [T],
    jtr: &'a mut [T],
    /// The current row's scaled columns.
    cur: [&'a mut [T]; 3],
    /// The first row's columns (socket), a plane's first projected column and tilt couplings,
    /// a distance's first row.
    first: [&'a mut [T]; 3],
    /// Weighted sums of the shifted columns.
    sum: [&'a mut [T]; 3],
    /// Each column's squared norm in the group's rows, before the projection.
    raw: &'a mut [T],
}

fn cut<T: Real>(buf: &mut [T], n: usize) -> Option<Scratch<'_, T>> {
    if buf.len() < constraint_scratch_len(n) {
        return None;
    }
    let (jtj, rest) = buf.split_at_mut(n * n);
    let (jtr, rest) = rest.split_at_mut(n);
    let (c0, rest) = rest.split_at_mut(n);
    let (c1, rest) = rest.split_at_mut(n);
    let (c2, rest) = rest.split_at_mut(n);
    let (f0, rest) = rest.split_at_mut(n);
    let (f1, rest) = rest.split_at_mut(n);
    let (f2, rest) = rest.split_at_mut(n);
    let (s0, rest) = rest.split_at_mut(n);
    let (s1, rest) = rest.split_at_mut(n);
    let (s2, rest) = rest.split_at_mut(n);
    let (raw, _) = rest.split_at_mut(n);
    Some(Scratch {
        n,
        jtj,
        jtr,
        cur: [c0, c1, c2],
        first: [f0, f1, f2],
        sum: [s0, s1, s2],
        raw,
    })
}

impl<T: Real> Scratch<'_, T> {
    /// Adds the current row's squared column norms, weighted by `w2`, to `raw`.
    fn add_raw(&mut self, w2: T) {
        let [x, y, z] = &self.cur;
        let columns = x.iter().zip(y.iter()).zip(z.iter());
        for (r, ((a, b), c)) in self.raw.iter_mut().zip(columns) {
            *r += w2 * (*a * *a + *b * *b + *c * *c);
        }
    }

    fn clear(&mut self) {
        self.jtj.fill(T::zero());
        self.jtr.fill(T::zero());
        self.raw.fill(T::zero());
        for a in self.sum.iter_mut().chain(self.first.iter_mut()) {
            a.fill(T::zero());
        }
    }

    /// Adds three rows with columns `c` (weight `w2`, residuals `r`: `Jᵀr` takes
    /// `w2 · cᵀr`) to the lower triangle.
    #[inline(never)]
    fn add3(jtj: &mut [T], jtr: &mut [T], n: usize, c: [&[T]; 3], w2: T, r: [T; 3]) {
        let [cx, cy, cz] = c;
        for i in 0..n {
            let (xi, yi, zi) = (w2 * cx[i], w2 * cy[i], w2 * cz[i]);
            jtr[i] += xi * r[0] + yi * r[1] + zi * r[2];
            let row = &mut jtj[i * n..i * n + i + 1];
            let cols = cx[..=i].iter().zip(&cy[..=i]).zip(&cz[..=i]);
            for (v, ((x, y), z)) in row.iter_mut().zip(cols) {
                *v += xi * *x + yi * *y + zi * *z;
            }
        }
    }

    /// Adds `f · c cᵀ` to the lower triangle and `f · r · c` to `Jᵀr` (one row, or with a
    /// negative `f` and no residual, a downdate).
    #[inline(never)]
    fn add1(jtj: &mut [T], jtr: Option<&mut [T]>, n: usize, c: &[T], f: T, r: T) {
        if let Some(jtr) = jtr {
            for (g, ci) in jtr[..n].iter_mut().zip(c) {
                *g += f * r * *ci;
            }
        }
        for i in 0..n {
            let fi = f * c[i];
            let row = &mut jtj[i * n..i * n + i + 1];
            for (v, cj) in row.iter_mut().zip(&c[..=i]) {
                *v += fi * *cj;
            }
        }
    }
}

/// The model's scaled columns at the pose `fk` last computed, into `out`.
#[inline(never)]
fn columns_into<T: Real, const N: usize, V: ValueStorage>(
    fk: &ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    set: &Columns<'_, T>,
    out: &mut [&mut [T]; 3],
) {
    for (k, (&p, &s)) in set.params.iter().zip(set.scale).enumerate() {
        // The run checked the parameters against the robot: a column always exists.
        let c = fk.column(robot, p).unwrap_or_else(|_| Vector3::zeros()) / s;
        out[0][k] = c.x;
        out[1][k] = c.y;
        out[2][k] = c.z;
    }
}

/// The tool point of `row` (zero when the robot lacks it: the run checked that it has it).
fn point<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    row: &ConstraintRow<T, N>,
) -> Vector3<T> {
    fk.compute_at(robot, &row.q, row.tool as usize, row.temp_c)
        .unwrap_or_else(Vector3::zeros)
}

fn weight<T: Real, const N: usize>(row: &ConstraintRow<T, N>) -> T {
    T::one() / (row.sigma_mm * row.sigma_mm)
}

/// Adds group `g` of `rows` to `out` (its `Jᵀr`, and its `JᵀJ` unless the pass is
/// gradient-only) and returns its weighted squared residual. `buf` holds at least
/// [`constraint_scratch_len`] numbers (the run checked it, and the group).
pub(super) fn accumulate_group<T: Real, const N: usize, V: ValueStorage, S: LmStorage<T>>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
    g: &ConstraintGroup<T>,
    set: &Columns<'_, T>,
    out: &mut NormalSums<'_, T, S>,
    buf: &mut [T],
) -> T {
    let n = set.params.len();
    let (Some(mut sc), Some(rows)) = (cut(buf, n), g.rows(rows)) else {
        return T::zero();
    };
    sc.clear();
    let cost = match g.kind {
        ConstraintKind::Socket => socket(fk, robot, rows, set, &mut sc),
        ConstraintKind::Plane => plane(fk, robot, rows, set, &mut sc),
        ConstraintKind::Distance { length_mm } => {
            distance(fk, robot, rows, length_mm, set, &mut sc)
        }
        ConstraintKind::Point { at } => tracker_point(fk, robot, rows, at, set, &mut sc),
    };
    // Columns the group's shape absorbs add nothing from this group.
    let absorbed = T::of(ABSORBED * ABSORBED);
    for k in 0..n {
        let d = sc.jtj[k * n + k];
        if !(d > absorbed * sc.raw[k]) {
            sc.jtr[k] = T::zero();
            for j in 0..n {
                sc.jtj[k.max(j) * n + k.min(j)] = T::zero();
            }
        }
    }
    let s = out.stride;
    for i in 0..n {
        out.jtr[i] += sc.jtr[i];
        if !set.gradient_only {
            let dst = &mut out.jtj[i * s..i * s + i + 1];
            for (v, w) in dst.iter_mut().zip(&sc.jtj[i * n..i * n + i + 1]) {
                *v += *w;
            }
        }
    }
    cost
}

/// A socket: one sweep, columns and points taken relative to the first row's (the
/// projection is invariant to the shift, and the sums stay small).
#[inline(never)]
fn socket<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
    set: &Columns<'_, T>,
    sc: &mut Scratch<'_, T>,
) -> T {
    let n = sc.n;
    let (mut w_sum, mut e_sum, mut cost) = (T::zero(), Vector3::zeros(), T::zero());
    let mut p0 = Vector3::zeros();
    for (i, row) in rows.iter().enumerate() {
        let p = point(fk, robot, row);
        columns_into(fk, robot, set, &mut sc.cur);
        let w2 = weight(row);
        sc.add_raw(w2);
        if i == 0 {
            p0 = p;
            for a in 0..3 {
                sc.first[a][..n].copy_from_slice(&sc.cur[a][..n]);
            }
        }
        for a in 0..3 {
            for k in 0..n {
                sc.cur[a][k] -= sc.first[a][k];
                sc.sum[a][k] += w2 * sc.cur[a][k];
            }
        }
        let e = p - p0;
        let cols = [&*sc.cur[0], &*sc.cur[1], &*sc.cur[2]];
        Scratch::add3(sc.jtj, sc.jtr, n, cols, w2, [-e.x, -e.y, -e.z]);
        w_sum += w2;
        e_sum += e * w2;
        cost += w2 * e.norm_squared();
    }
    if !(w_sum > T::zero()) {
        return T::zero();
    }
    let inv = T::one() / w_sum;
    let sums = [&*sc.sum[0], &*sc.sum[1], &*sc.sum[2]];
    for c in sums {
        Scratch::add1(sc.jtj, None, n, c, -inv, T::zero());
    }
    for k in 0..n {
        sc.jtr[k] += inv * (sums[0][k] * e_sum.x + sums[1][k] * e_sum.y + sums[2][k] * e_sum.z);
    }
    (cost - e_sum.norm_squared() * inv).max(T::zero())
}

/// The plane through a group's points (relative to the first): the weight, centroid, normal,
/// in-plane axes and the spreads along the three (ascending: the normal's is the residual).
struct PlaneFit<T: Real> {
    p0: Vector3<T>,
    w_sum: T,
    centroid: Vector3<T>,
    axes: [Vector3<T>; 3],
    spread: [T; 3],
}

#[inline(never)]
fn fit_plane<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
) -> Option<PlaneFit<T>> {
    let mut p0 = Vector3::zeros();
    let (mut w_sum, mut e_sum) = (T::zero(), Vector3::<T>::zeros());
    let mut m = [[T::zero(); 3]; 3];
    for (i, row) in rows.iter().enumerate() {
        let p = point(fk, robot, row);
        if i == 0 {
            p0 = p;
        }
        let e = p - p0;
        let w2 = weight(row);
        w_sum += w2;
        e_sum += e * w2;
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] += w2 * e[a] * e[b];
            }
        }
    }
    if !(w_sum > T::zero()) {
        return None;
    }
    let centroid = e_sum / w_sum;
    for a in 0..3 {
        for b in 0..3 {
            m[a][b] -= w_sum * centroid[a] * centroid[b];
        }
    }
    let mut values = [T::zero(); 3];
    let mut vectors = [[T::zero(); 3]; 3];
    symmetric_eigen::<T, 3>(&mut m, 3, &mut values, &mut vectors).ok()?;
    let axis = |k: usize| Vector3::new(vectors[0][k], vectors[1][k], vectors[2][k]);
    Some(PlaneFit {
        p0,
        w_sum,
        centroid,
        axes: [axis(0), axis(1), axis(2)],
        spread: values,
    })
}

/// A plane: a sweep of points for the plane, then one of columns.
#[inline(never)]
fn plane<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
    set: &Columns<'_, T>,
    sc: &mut Scratch<'_, T>,
) -> T {
    let n = sc.n;
    let Some(fit) = fit_plane(fk, robot, rows) else {
        return T::zero();
    };
    let [normal, t1, t2] = fit.axes;
    for (i, row) in rows.iter().enumerate() {
        let e = point(fk, robot, row) - fit.p0 - fit.centroid;
        columns_into(fk, robot, set, &mut sc.cur);
        let w2 = weight(row);
        let (rho, tau1, tau2) = (normal.dot(&e), t1.dot(&e), t2.dot(&e));
        // The row's projected column, into cur[0], shifted by the first row's.
        for k in 0..n {
            let a = normal.x * sc.cur[0][k] + normal.y * sc.cur[1][k] + normal.z * sc.cur[2][k];
            sc.raw[k] += w2 * a * a;
            if i == 0 {
                sc.first[0][k] = a;
            }
            let d = a - sc.first[0][k];
            sc.cur[0][k] = d;
            sc.sum[0][k] += w2 * d;
            sc.first[1][k] += w2 * tau1 * d;
            sc.first[2][k] += w2 * tau2 * d;
        }
        Scratch::add1(sc.jtj, Some(&mut *sc.jtr), n, sc.cur[0], w2, -rho);
    }
    Scratch::add1(sc.jtj, None, n, sc.sum[0], -T::one() / fit.w_sum, T::zero());
    // A tilt the points do not spread along (collinear points) is not projected out: its
    // coupling is as small as its spread.
    let floor = T::EPS * (fit.spread[1] + fit.spread[2]).abs();
    for (t, spread) in [(1, fit.spread[1]), (2, fit.spread[2])] {
        if spread > floor && spread > T::zero() {
            Scratch::add1(sc.jtj, None, n, sc.first[t], -T::one() / spread, T::zero());
        }
    }
    fit.spread[0].max(T::zero())
}

/// A distance: both rows' columns, then the one residual.
#[inline(never)]
fn distance<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
    length: T,
    set: &Columns<'_, T>,
    sc: &mut Scratch<'_, T>,
) -> T {
    let n = sc.n;
    let [a, b] = rows else {
        return T::zero();
    };
    let pa = point(fk, robot, a);
    columns_into(fk, robot, set, &mut sc.first);
    let pb = point(fk, robot, b);
    columns_into(fk, robot, set, &mut sc.cur);
    let v = pa - pb;
    let len = v.norm();
    if !(len > T::zero()) {
        return T::zero();
    }
    let u = v / len;
    let w2 = weight(a);
    let rho = len - length;
    for k in 0..n {
        let ua = u.x * sc.first[0][k] + u.y * sc.first[1][k] + u.z * sc.first[2][k];
        let ub = u.x * sc.cur[0][k] + u.y * sc.cur[1][k] + u.z * sc.cur[2][k];
        sc.raw[k] += w2 * (ua * ua + ub * ub);
        sc.sum[0][k] = ua - ub;
    }
    Scratch::add1(sc.jtj, Some(&mut *sc.jtr), n, sc.sum[0], w2, -rho);
    w2 * rho * rho
}

/// A tracker point: the ordinary three rows.
#[inline(never)]
fn tracker_point<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
    at: Vector3<T>,
    set: &Columns<'_, T>,
    sc: &mut Scratch<'_, T>,
) -> T {
    let n = sc.n;
    let [row] = rows else {
        return T::zero();
    };
    let r = at - point(fk, robot, row);
    columns_into(fk, robot, set, &mut sc.cur);
    let w2 = weight(row);
    sc.add_raw(w2);
    let cols = [&*sc.cur[0], &*sc.cur[1], &*sc.cur[2]];
    Scratch::add3(sc.jtj, sc.jtr, n, cols, w2, [r.x, r.y, r.z]);
    w2 * r.norm_squared()
}

/// A group's fitted shape at a model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConstraintShape<T: Real> {
    /// A socket's centre (mm, measurement frame).
    Centre(Vector3<T>),
    /// A plane `normal · x = offset` (unit normal, offset in mm).
    Plane {
        /// Unit normal.
        normal: Vector3<T>,
        /// `normal · x` of the plane's points, mm.
        offset: T,
    },
    /// A distance or tracker point: no shape of its own.
    None,
}

/// The shape group `g` of `rows` fits best at `robot` (what a constraint run estimates with
/// the model, for the report): `None` when the group does not fit `rows` or the robot lacks a
/// row's tool point.
pub fn constraint_shape<T: Real, const N: usize, V: ValueStorage>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    rows: &[ConstraintRow<T, N>],
    g: &ConstraintGroup<T>,
) -> Option<ConstraintShape<T>> {
    let rows = g.rows(rows)?;
    if !g.is_valid()
        || rows
            .iter()
            .any(|r| !r.is_valid() || r.tool as usize >= robot.tool_point_count())
    {
        return None;
    }
    match g.kind {
        ConstraintKind::Socket => {
            let (mut w_sum, mut sum) = (T::zero(), Vector3::zeros());
            for row in rows {
                let w2 = weight(row);
                w_sum += w2;
                sum += point(fk, robot, row) * w2;
            }
            Some(ConstraintShape::Centre(sum / w_sum))
        }
        ConstraintKind::Plane => {
            let fit = fit_plane(fk, robot, rows)?;
            let normal = fit.axes[0];
            Some(ConstraintShape::Plane {
                normal,
                offset: normal.dot(&(fit.p0 + fit.centroid)),
            })
        }
        ConstraintKind::Distance { .. } | ConstraintKind::Point { .. } => {
            Some(ConstraintShape::None)
        }
    }
}
