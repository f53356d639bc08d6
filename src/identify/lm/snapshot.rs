//! Snapshot and restore of a [`super::Levenberg`] run: everything except scratch that the
//! next phase rewrites.

use super::levenberg::{Levenberg, Phase};
use super::penalty::LmPenalty;
use super::status::LmStop;
use super::storage::LmStorage;
use crate::io::snapshot::{
    restore_with, save_with, Decoder, Encoder, Kind, Snapshot, SnapshotError,
};
use crate::model::effects::MAX_VALUES;
use crate::model::param::Param;
use crate::Frame;
use crate::ValueStorage;
use crate::{Real, Robot};
use embedded_io::{Read, Write};
use nalgebra::Vector3;

fn param_tag(p: Param) -> (u8, u16) {
    match p {
        Param::BaseX => (0, 0),
        Param::BaseY => (1, 0),
        Param::BaseZ => (2, 0),
        Param::BaseRx => (3, 0),
        Param::BaseRy => (4, 0),
        Param::BaseRz => (5, 0),
        Param::Alpha(i) => (6, i as u16),
        Param::A(i) => (7, i as u16),
        Param::Theta(i) => (8, i as u16),
        Param::D(i) => (9, i as u16),
        Param::Beta(i) => (10, i as u16),
        Param::ToolX => (11, 0),
        Param::ToolY => (12, 0),
        Param::ToolZ => (13, 0),
        Param::Effect(k) => (14, k),
        Param::ToolPoint(k, a) => (15, (k as u16) * 3 + a as u16),
        Param::ToolRx => (16, 0),
        Param::ToolRy => (17, 0),
        Param::ToolRz => (18, 0),
    }
}

fn put_robot<T: Real, W: Write, const N: usize, V: ValueStorage>(
    e: &mut Encoder<'_, W>,
    r: &Robot<T, N, V>,
) -> Result<(), SnapshotError> {
    let b = r.base();
    for v in [b.x, b.y, b.z, b.o] {
        e.reals(v.as_slice())?;
    }
    for j in r.joints() {
        e.reals(&[j.alpha, j.a, j.theta, j.d, j.beta, j.lower, j.upper])?;
    }
    e.reals(r.tool().as_slice())?;
    // The couplings are constant: stored so that a snapshot of another robot is refused.
    e.usize(r.couplings().len())?;
    for (joint, from, ratio) in r.couplings().iter() {
        e.usize(joint)?;
        e.usize(from)?;
        e.reals(&[ratio])?;
    }
    e.usize(r.effects().values().len())?;
    e.reals(r.effects().values())?;
    // The tool's further points (their number is constant) and the measured frame's axes.
    e.usize(r.tool_point_count())?;
    for k in 1..r.tool_point_count() {
        if let Some(p) = r.tool_point(k) {
            e.reals(p.as_slice())?;
        }
    }
    let a = r.tool_axes();
    for v in [a.x, a.y, a.z] {
        e.reals(v.as_slice())?;
    }
    Ok(())
}

/// Reads a robot into `r`, whose effect list must have the same shape.
fn get_robot<T: Real, R: Read, const N: usize, V: ValueStorage>(
    d: &mut Decoder<'_, R>,
    r: &mut Robot<T, N, V>,
) -> Result<(), SnapshotError> {
    let mut axes = [Vector3::<T>::zeros(); 4];
    for a in axes.iter_mut() {
        let mut v = [T::zero(); 3];
        d.reals(&mut v)?;
        *a = Vector3::new(v[0], v[1], v[2]);
    }
    let base = Frame {
        x: axes[0],
        y: axes[1],
        z: axes[2],
        o: axes[3],
    };
    let mut joints = *r.joints();
    for j in joints.iter_mut() {
        let mut v = [T::zero(); 7];
        d.reals(&mut v)?;
        *j = crate::Joint {
            alpha: v[0],
            a: v[1],
            theta: v[2],
            d: v[3],
            beta: v[4],
            lower: v[5],
            upper: v[6],
        };
    }
    let mut t = [T::zero(); 3];
    d.reals(&mut t)?;
    d.expect_shape(r.couplings().len())?;
    for (joint, from, ratio) in r.couplings().iter() {
        d.expect_shape(joint)?;
        d.expect_shape(from)?;
        let mut v = [T::zero(); 1];
        d.reals(&mut v)?;
        if v[0] != ratio {
            return Err(SnapshotError::Shape);
        }
    }
    let nv = r.effects().values().len();
    d.expect_shape(nv)?;
    // Read in place: `r` is the caller's scratch copy (a snapshot restores all or nothing).
    let values = r.parts_mut().3.values_mut();
    if values.len() != nv {
        return Err(SnapshotError::Shape);
    }
    d.reals(values)?;
    let count = r.tool_point_count();
    d.expect_shape(count)?;
    let mut more = [Vector3::<T>::zeros(); crate::model::tool::MAX_TOOL_POINTS];
    for p in more.iter_mut().take(count).skip(1) {
        let mut v = [T::zero(); 3];
        d.reals(&mut v)?;
        *p = Vector3::new(v[0], v[1], v[2]);
    }
    let mut tool_axes = [Vector3::<T>::zeros(); 3];
    for a in tool_axes.iter_mut() {
        let mut v = [T::zero(); 3];
        d.reals(&mut v)?;
        *a = Vector3::new(v[0], v[1], v[2]);
    }
    let (b, js, tool, _) = r.parts_mut();
    *b = base;
    *js = joints;
    *tool = Vector3::new(t[0], t[1], t[2]);
    let extra = r.tool_extra_mut();
    // (`count` ≥ 1: a robot always has its first point.)
    extra.more[..count - 1].copy_from_slice(&more[1..count]);
    extra.axes = Frame {
        x: tool_axes[0],
        y: tool_axes[1],
        z: tool_axes[2],
        o: Vector3::zeros(),
    };
    r.refresh();
    // A model `Robot::new` would refuse (NaN, beyond the bounds, a base that is no rotation).
    r.check().map_err(|_| SnapshotError::Invalid)
}

/// True when every value is finite. Not inlined: the restore checks six arrays with one copy
/// of the loop.
#[inline(never)]
fn all_finite<T: Real>(v: &[T]) -> bool {
    v.iter().all(|x| x.finite())
}

/// True when the solver has state beyond the plain run's: a penalty or parameters the
/// caller holds. Its snapshot then carries a tail after the plain fields (the plain
/// layout is unchanged, so plain snapshots stay compatible); a snapshot restores only into
/// a solver with the same holds and penalty shape.
fn extended<T: Real, Storage: LmStorage<T>, Penalty: LmPenalty<T>>(
    st: &Storage,
    pen: &Penalty,
) -> bool {
    let p = st.parts_ref();
    pen.parts_ref().is_some() || p.held[..p.params.len()].iter().any(|h| *h)
}

/// A snapshot holds the parameter list, not the storage's capacity: it restores into any
/// storage with room for the same parameters (fixed arrays or a host's heap).
impl<
        T: Real,
        const N: usize,
        V: ValueStorage,
        Storage: LmStorage<T> + Clone,
        Penalty: LmPenalty<T> + Clone,
    > Snapshot for Levenberg<T, N, V, Storage, Penalty>
{
    fn save<W: Write>(&self, w: &mut W) -> Result<(), SnapshotError> {
        let p = self.st.parts_ref();
        let s = p.stride;
        save_with::<T, W, _>(w, Kind::Levenberg, |e| {
            e.usize(N)?;
            e.usize(V::CAPACITY.min(MAX_VALUES))?;
            let n = p.params.len();
            e.usize(n)?;
            for q in p.params {
                let (t, i) = param_tag(*q);
                e.u8(t)?;
                e.u16(i)?;
            }
            put_robot(e, &self.robot)?;
            put_robot(e, &self.candidate)?;
            for k in 0..n {
                e.bool(p.active[k])?;
            }
            e.bool(self.analysed)?;
            e.u8(self.analyses)?;
            e.reals(&p.analysed_diag[..n])?;
            e.reals(&p.scale[..n])?;
            e.reals(&p.total[..n])?;
            for i in 0..n {
                e.reals(&p.jtj[i * s..i * s + n])?;
            }
            e.reals(&p.jtr[..n])?;
            e.reals(&p.step[..n])?;
            e.reals(&[
                self.cost,
                self.acc_cost,
                self.cand_cost,
                self.lambda,
                self.nu,
                self.predicted,
            ])?;
            e.usize(self.next)?;
            e.usize(self.n_poses)?;
            let (ph, stop) = match self.phase {
                Phase::Accumulate => (0, 0),
                Phase::Solve => (1, 0),
                Phase::Evaluate => (2, 0),
                Phase::Done(s) => (3, s as u8),
                Phase::Confirm(s) => (4, s as u8),
                Phase::Reanalyse => (5, 0),
            };
            e.u8(ph)?;
            e.u8(stop)?;
            e.u32(self.iteration)?;
            e.u32(self.evaluations)?;
            if extended(&self.st, &self.pen) {
                for k in 0..n {
                    e.bool(p.held[k])?;
                }
                if let Some(q) = self.pen.parts_ref() {
                    e.usize(q.terms.len())?;
                    e.reals(&q.weights[..q.terms.len()])?;
                    e.reals(&q.offset[..n])?;
                }
            }
            Ok(())
        })
    }

    fn restore<R: Read>(&mut self, r: &mut R) -> Result<(), SnapshotError> {
        let restored = restore_with::<T, R, _, _>(r, Kind::Levenberg, |d| {
            d.expect_shape(N)?;
            d.expect_shape(V::CAPACITY.min(MAX_VALUES))?;
            let n = self.st.params().len();
            d.expect_shape(n)?;
            for q in self.st.params() {
                let (t, i) = param_tag(*q);
                if d.u8()? != t || d.u16()? != i {
                    return Err(SnapshotError::Shape);
                }
            }
            let mut s = self.clone();
            get_robot(d, &mut s.robot)?;
            get_robot(d, &mut s.candidate)?;
            let p = s.st.parts();
            let st = p.stride;
            for k in 0..n {
                p.active[k] = d.bool()?;
            }
            s.analysed = d.bool()?;
            s.analyses = d.u8()?;
            d.reals(&mut p.analysed_diag[..n])?;
            d.reals(&mut p.scale[..n])?;
            d.reals(&mut p.total[..n])?;
            for i in 0..n {
                d.reals(&mut p.jtj[i * st..i * st + n])?;
            }
            d.reals(&mut p.jtr[..n])?;
            d.reals(&mut p.step[..n])?;
            let mut v = [T::zero(); 6];
            d.reals(&mut v)?;
            [s.cost, s.acc_cost, s.cand_cost, s.lambda, s.nu, s.predicted] = v;
            s.next = d.usize()?;
            s.n_poses = d.usize()?;
            let ph = d.u8()?;
            let stop = d.u8()?;
            let reason = match stop {
                0 => LmStop::Converged,
                1 => LmStop::SmallStep,
                2 => LmStop::MaxIterations,
                3 => LmStop::NoProgress,
                _ => return Err(SnapshotError::Invalid),
            };
            s.phase = match ph {
                0 => Phase::Accumulate,
                1 => Phase::Solve,
                2 => Phase::Evaluate,
                3 => Phase::Done(reason),
                4 => Phase::Confirm(reason),
                5 => Phase::Reanalyse,
                _ => return Err(SnapshotError::Invalid),
            };
            s.iteration = d.u32()?;
            s.evaluations = d.u32()?;
            s.factored = false;
            // Costs may be +∞ (a candidate off the data) but not NaN or negative; the damping
            // must be one the solver can reach (> 0, finite), the arrays finite, the scales
            // also > 0.
            let p = s.st.parts_ref();
            let ok = s.next <= s.n_poses
                && [s.cost, s.acc_cost, s.cand_cost]
                    .iter()
                    .all(|c| *c >= T::zero())
                && s.lambda > T::zero()
                && s.lambda.finite()
                && s.nu >= T::one()
                && s.nu.finite()
                && !s.predicted.to_f64().is_nan()
                && all_finite(&p.analysed_diag[..n])
                && all_finite(&p.scale[..n])
                && all_finite(&p.total[..n])
                && all_finite(&p.jtr[..n])
                && all_finite(&p.step[..n])
                && (0..n).all(|i| all_finite(&p.jtj[i * st..i * st + n]))
                && p.scale[..n].iter().all(|x| *x > T::zero());
            if !ok {
                return Err(SnapshotError::Invalid);
            }
            if extended(&s.st, &s.pen) {
                let p = s.st.parts();
                for k in 0..n {
                    if d.bool()? != p.held[k] {
                        return Err(SnapshotError::Shape);
                    }
                }
                if let Some(q) = s.pen.parts() {
                    let terms = q.terms.len();
                    d.expect_shape(terms)?;
                    d.reals(&mut q.weights[..terms])?;
                    d.reals(&mut q.offset[..n])?;
                    let ok = |x: &T| x.finite() && !(*x < T::zero());
                    if !q.weights[..terms].iter().all(ok)
                        || !q.offset[..n].iter().all(|x| x.finite())
                    {
                        return Err(SnapshotError::Invalid);
                    }
                }
            }
            Ok(s)
        })?;
        *self = restored;
        Ok(())
    }
}
