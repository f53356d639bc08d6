//! Non-geometric joint corrections (`docs/formats.md#effects`): what a plain MDH model misses.
//!
//! Each effect adds `dq_j = Σ_k v_k · φ_k(q)` to a joint reading before the geometry is applied.
//! The model is linear in its values `v_k`, so identification needs only the basis `φ_k` (the
//! Jacobian column is `∂p/∂q_j · φ_k`), and compensation needs `∂dq_j/∂q_j`; both live here,
//! beside the correction itself. `axis-tilt` is geometric (the joint's `beta`), so it is not here.
//!
//! `thermal-expansion` is in the list but is no joint correction: it scales every length of the
//! model by `1 + c·(T − T0)` at the temperature `T` of an evaluation ([`Effects::expansion`];
//! forward kinematics applies it and gives its column).
//!
//! `base-drift` is in the list for the same reason: the base moves by `v·(t − t0)` at the time
//! `t` of an evaluation (a tracker that drifts during a session, [`Effects::drift`]); forward
//! kinematics applies it and gives its columns.

use crate::model::value_storage::{ValueBuffer, ValueStorage};
use crate::Real;
use heapless::Vec;

/// How many effects one model can carry.
pub const MAX_EFFECTS: usize = 32;

/// The kinds of joint correction (`docs/formats.md#effects`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EffectKind {
    /// `s · q_j`: a gear ratio or encoder scale that is slightly off.
    Scale,
    /// `a·sin(n q_j) + b·cos(n q_j)`: gear eccentricity, once (or n times) per turn.
    Cyclic,
    /// `k · τ_j(q)`: the joint deflects under the tool's weight; τ_j is the lever arm (m).
    Compliance,
    /// Piecewise-linear in `q_j` through equally spaced knots: any smooth repeatable error.
    Table,
    /// Every length (each row's `a`, `d`, the tool points) scales by `1 + c·(T − T0)`: the
    /// arm expands with its temperature `T` (°C). One value, `c` per kelvin; `T0` (°C) is
    /// kept in [`Effect::start`]; always on joint 0 (it acts on no joint).
    Thermal,
    /// The base translates by `v·(t − t0)` at the observation's time `t` (s): the measuring
    /// instrument drifting during a session. Three values, `v` in mm per second along the
    /// measurement frame's x, y, z; `t0` (s) is kept in [`Effect::start`]; always on joint 0.
    /// In `f32` give times from the session's start: a Unix time resolves only to 128 s there.
    Drift,
}

impl EffectKind {
    /// The identifier used in files and on the command line.
    pub const fn id(self) -> &'static str {
        match self {
            EffectKind::Scale => "joint-scale",
            EffectKind::Cyclic => "joint-cyclic",
            EffectKind::Compliance => "joint-compliance",
            EffectKind::Table => "joint-table",
            EffectKind::Thermal => "thermal-expansion",
            EffectKind::Drift => "base-drift",
        }
    }

    /// Parses an effect id of `docs/formats.md#effects` (`axis-tilt` is not a joint correction).
    pub fn from_id(s: &str) -> Option<Self> {
        Some(match s {
            "joint-scale" => EffectKind::Scale,
            "joint-cyclic" => EffectKind::Cyclic,
            "joint-compliance" => EffectKind::Compliance,
            "joint-table" => EffectKind::Table,
            "thermal-expansion" => EffectKind::Thermal,
            "base-drift" => EffectKind::Drift,
            _ => return None,
        })
    }
}

/// One correction on one joint; its values live in [`Effects::values`] from `first` on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Effect<T: Real> {
    /// What correction this is.
    pub kind: EffectKind,
    /// 0-based joint index.
    pub joint: u8,
    /// Harmonic order `n` (cyclic only, ≥ 1).
    pub order: u16,
    /// Position of the lowest knot, rad (table only); the reference temperature `T0`, °C
    /// (thermal-expansion only); the reference time `t0`, s (base-drift only).
    pub start: T,
    /// Knot spacing, rad (table only, > 0).
    pub step: T,
    /// Index of the first value in the list's values.
    pub first: u16,
    /// Number of values: 1 (scale, compliance, thermal), 2 (cyclic: a, b), 3 (drift: vx, vy,
    /// vz), knots (table).
    pub len: u16,
}

impl<T: Real> Effect<T> {
    /// Indices of its values in [`Effects::values`] (computed in `usize`: no overflow).
    pub fn range(&self) -> core::ops::Range<usize> {
        self.first as usize..self.first as usize + self.len as usize
    }

    /// Knot position `k` of a table, rad.
    pub fn knot(&self, k: usize) -> T {
        self.start + self.step * T::of(k as f64)
    }

    /// Table segment of `q`: lower knot index and weight of the upper knot, clamped at the ends
    /// so that a reading outside the table gets the end value.
    #[inline]
    pub fn segment(&self, q: T) -> (usize, T) {
        let n = self.len as usize;
        if n < 2 || !(self.step > T::zero()) {
            return (0, T::zero());
        }
        let u = (q - self.start) / self.step;
        if !(u > T::zero()) {
            return (0, T::zero());
        }
        let last = T::of((n - 1) as f64);
        if u >= last {
            return (n - 2, T::one());
        }
        // Truncation of a positive value below n - 1: the floor.
        let k = (u.to_f64() as usize).min(n - 2);
        (k, u - T::of(k as f64))
    }
}

/// Largest magnitude of a base-drift velocity component, mm/s (a tracker that drifts 1 mm
/// per second measures nothing; real drifts are micrometres per minute).
pub const MAX_DRIFT_SPEED: f64 = 1.0;

/// Largest magnitude of a base-drift reference time, s (Unix times until the year 2286).
pub const MAX_DRIFT_TIME: f64 = 1e10;

/// Most values one effect list holds, whatever its storage's capacity (value indices are `u16`).
pub const MAX_VALUES: usize = u16::MAX as usize;

/// Error when building or changing the effect list.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EffectError {
    /// More effects than [`MAX_EFFECTS`], or more values than the model's storage holds
    /// ([`ValueStorage::CAPACITY`]) or than [`MAX_VALUES`].
    Capacity,
    /// Joint index outside the robot (the list's own robot, and the `n_joints` given).
    Joint,
    /// Wrong number of values, a zero order, a non-positive step, or a value, start or step
    /// that is not finite or beyond ±[`crate::model::bounds::MAX_ANGLE`].
    Shape,
}

/// The list of effects of a model and their values (kept in the storage `V`: at most its
/// [`ValueStorage::CAPACITY`] values in all, and at most [`MAX_VALUES`] whatever the storage).
///
/// A list belongs to a robot and accepts joints of that robot only: get it with
/// [`crate::Robot::effects_mut`]. A list made with [`Default`] belongs to no robot and refuses
/// every effect ([`EffectError::Joint`]); [`Effects::for_joints`] makes one for `n` joints.
#[derive(Clone, Debug, PartialEq)]
pub struct Effects<T: Real, V: ValueStorage> {
    list: Vec<Effect<T>, MAX_EFFECTS>,
    values: V::Buffer<T>,
    used: usize,
    joints: usize,
}

impl<T: Real, V: ValueStorage> Default for Effects<T, V> {
    fn default() -> Self {
        Self::for_joints(0)
    }
}

impl<T: Real, V: ValueStorage> Effects<T, V> {
    /// An empty list for a robot of `n` joints (at most 256 are addressable).
    pub fn for_joints(n: usize) -> Self {
        Self {
            list: Vec::new(),
            values: V::Buffer::<T>::empty(),
            used: 0,
            joints: n,
        }
    }
    pub(crate) fn set_joints(&mut self, n: usize) {
        self.joints = n;
    }
    /// The effects, in the order they were added.
    pub fn iter(&self) -> impl Iterator<Item = &Effect<T>> {
        self.list.iter()
    }
    /// Number of effects (not values).
    pub fn len(&self) -> usize {
        self.list.len()
    }
    /// True when the model has no joint correction.
    pub fn is_empty(&self) -> bool {
        // Without value capacity nothing is ever stored (every effect has a value): saying so
        // at compile time drops the effect handling (corrections, lever arms, the joint
        // Jacobian's chain rule) from a model with `Inline<0>`: the M4F firmware's flash 3.8 KB
        // smaller, its forward kinematics 19 instructions faster.
        V::CAPACITY == 0 || self.list.is_empty()
    }
    /// Effect `i`, `None` beyond the last.
    pub fn get(&self, i: usize) -> Option<&Effect<T>> {
        self.list.get(i)
    }
    /// All values in use, effect by effect.
    pub fn values(&self) -> &[T] {
        self.values.slots().get(..self.used).unwrap_or(&[])
    }
    /// Values of effect `i`.
    pub fn values_of(&self, i: usize) -> &[T] {
        match self.list.get(i) {
            Some(e) => self.values_in(e).unwrap_or(&[]),
            None => &[],
        }
    }
    pub(crate) fn values_mut(&mut self) -> &mut [T] {
        let used = self.used;
        self.values.slots_mut().get_mut(..used).unwrap_or(&mut [])
    }
    /// The thermal-expansion term, if any: the index of its value `c` (per kelvin) in
    /// [`Self::values`], `c` and the reference temperature `T0` (°C).
    #[inline]
    pub fn thermal(&self) -> Option<(usize, T, T)> {
        let e = self.list.iter().find(|e| e.kind == EffectKind::Thermal)?;
        let v = self.values_in(e)?;
        Some((e.first as usize, v[0], e.start))
    }

    /// The length scale `1 + c·(T − T0)` at temperature `temp_c` (°C) and `T − T0`; `None`
    /// without a thermal-expansion term.
    #[inline]
    pub fn expansion(&self, temp_c: T) -> Option<(T, T)> {
        let (_, c, t0) = self.thermal()?;
        let dt = temp_c - t0;
        Some((T::one() + c * dt, dt))
    }

    /// The base-drift term, if any: the index of its first value in [`Self::values`], the
    /// drift velocity `v` (mm/s, measurement frame) and the reference time `t0` (s).
    #[inline]
    pub fn drift(&self) -> Option<(usize, [T; 3], T)> {
        let e = self.list.iter().find(|e| e.kind == EffectKind::Drift)?;
        let v = self.values_in(e)?;
        match v {
            [x, y, z] => Some((e.first as usize, [*x, *y, *z], e.start)),
            _ => None,
        }
    }

    /// True when some effect needs the lever arms τ (a compliance term).
    pub fn needs_lever_arms(&self) -> bool {
        self.list.iter().any(|e| e.kind == EffectKind::Compliance)
    }
    /// Index of the effect of this kind on this joint (and order, for cyclic), if present.
    pub fn find(&self, kind: EffectKind, joint: usize, order: u16) -> Option<usize> {
        self.list.iter().position(|e| {
            e.kind == kind
                && e.joint as usize == joint
                && (kind != EffectKind::Cyclic || e.order == order)
        })
    }

    /// Values of `e` ([`Effect::range`]); `None` when they are not all in the list or there are
    /// none ([`Effects::push`] never stores an effect without values). Sliced in two steps
    /// rather than with the range, and never empty: the compiler then sees that a list without
    /// value capacity (`Inline<0>`) has no effect to evaluate and drops that code (about 1.8 KB of
    /// the M4F firmware's flash, in forward kinematics and compensation).
    #[inline(always)]
    fn values_in(&self, e: &Effect<T>) -> Option<&[T]> {
        let v = self
            .values
            .slots()
            .get(e.first as usize..)?
            .get(..e.len as usize)?;
        (!v.is_empty()).then_some(v)
    }

    /// Appends an effect with its values; the joint must be below `n_joints` and below the
    /// list's own robot's joint count. Every value, `start` and `step` must be finite and within
    /// ±[`crate::model::bounds::MAX_ANGLE`]. On error nothing changes. `start`/`step` matter for
    /// tables only, `order` for cyclic only; a thermal-expansion term is on joint 0, one per
    /// list, its `start` the reference temperature (°C) and its value `c` (per kelvin) below
    /// 1e-2 in magnitude; a base-drift term is on joint 0, one per list, its `start` the
    /// reference time (s, within ±[`MAX_DRIFT_TIME`]) and its three values (mm/s) below
    /// [`MAX_DRIFT_SPEED`] in magnitude.
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        kind: EffectKind,
        joint: usize,
        n_joints: usize,
        order: u16,
        start: T,
        step: T,
        values: &[T],
    ) -> Result<usize, EffectError> {
        if joint >= n_joints.min(self.joints) || joint > u8::MAX as usize {
            return Err(EffectError::Joint);
        }
        self.check_shape(kind, joint, order, start, step, values)?;
        let end = self.used + values.len();
        if self.list.is_full() || end > V::CAPACITY.min(MAX_VALUES) {
            return Err(EffectError::Capacity);
        }
        let Some(slot) = self.slot(end) else {
            return Err(EffectError::Capacity);
        };
        slot.copy_from_slice(values);
        let e = Effect {
            kind,
            joint: joint as u8,
            order,
            start,
            step,
            first: self.used as u16,
            len: values.len() as u16,
        };
        self.used = end;
        // Cannot fail: checked `is_full` above.
        let _ = self.list.push(e);
        Ok(self.list.len() - 1)
    }

    /// As [`Effects::push`] with `len` values that `fill` writes in place (a decoder reads them
    /// straight into the list: no buffer of the list's size). On any error, `fill`'s included,
    /// the list is unchanged.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn push_with<E: From<EffectError>>(
        &mut self,
        kind: EffectKind,
        joint: usize,
        n_joints: usize,
        order: u16,
        start: T,
        step: T,
        len: usize,
        fill: impl FnOnce(&mut [T]) -> Result<(), E>,
    ) -> Result<usize, E> {
        if joint >= n_joints.min(self.joints) || joint > u8::MAX as usize {
            return Err(EffectError::Joint.into());
        }
        let end = self.used.saturating_add(len);
        if self.list.is_full() || end > V::CAPACITY.min(MAX_VALUES) {
            return Err(EffectError::Capacity.into());
        }
        let Some(slot) = self.slot(end) else {
            return Err(EffectError::Capacity.into());
        };
        // The values stay beyond `used` until the shape is accepted (zeroed again if not).
        let r = fill(slot).and_then(|()| {
            let vals = self.values.slots().get(self.used..end).unwrap_or(&[]);
            self.check_shape(kind, joint, order, start, step, vals)
                .map_err(E::from)
        });
        match r {
            Ok(()) => {
                let e = Effect {
                    kind,
                    joint: joint as u8,
                    order,
                    start,
                    step,
                    first: self.used as u16,
                    len: len as u16,
                };
                self.used = end;
                // Cannot fail: checked `is_full` above.
                let _ = self.list.push(e);
                Ok(self.list.len() - 1)
            }
            Err(e) => {
                if let Some(v) = self.values.slots_mut().get_mut(self.used..end) {
                    v.fill(T::zero());
                }
                self.values.release_slots(self.used);
                Err(e)
            }
        }
    }

    /// The slots `used..end` for new values, after making room for them (`None` when the
    /// storage cannot hold them; nothing changes then).
    fn slot(&mut self, end: usize) -> Option<&mut [T]> {
        if !self.values.reserve_slots(end) {
            return None;
        }
        let used = self.used;
        if used > end || self.values.slots().len() < end || self.values.slots_mut().len() < end {
            self.values.release_slots(used);
            return None;
        }
        self.values.slots_mut().get_mut(used..end)
    }

    /// The shape checks of [`Effects::push`]: the value count of the kind, order and step (a
    /// thermal-expansion term on joint 0, once per list, `|c| < 1e-2`; a base-drift term on
    /// joint 0, once per list, `|v| <` [`MAX_DRIFT_SPEED`]), and every number finite and within
    /// ±[`crate::model::bounds::MAX_ANGLE`] (a drift's reference time within
    /// ±[`MAX_DRIFT_TIME`]: a Unix time in seconds fits).
    fn check_shape(
        &self,
        kind: EffectKind,
        joint: usize,
        order: u16,
        start: T,
        step: T,
        values: &[T],
    ) -> Result<(), EffectError> {
        let ok_len = match kind {
            EffectKind::Scale | EffectKind::Compliance => values.len() == 1,
            EffectKind::Cyclic => values.len() == 2 && order >= 1,
            EffectKind::Table => values.len() >= 2 && step > T::zero(),
            EffectKind::Thermal => {
                values.len() == 1
                    && joint == 0
                    && values[0].abs() < T::of(1e-2)
                    && self.thermal().is_none()
            }
            EffectKind::Drift => {
                values.len() == 3
                    && joint == 0
                    && values.iter().all(|v| v.abs() < T::of(MAX_DRIFT_SPEED))
                    && self.drift().is_none()
            }
        };
        let bound = T::of(crate::model::bounds::MAX_ANGLE);
        let start_bound = if kind == EffectKind::Drift {
            T::of(MAX_DRIFT_TIME)
        } else {
            bound
        };
        // `!(|v| <= bound)`: NaN fails too.
        if !ok_len
            || !(start.abs() <= start_bound)
            || [step].iter().chain(values).any(|v| !(v.abs() <= bound))
        {
            return Err(EffectError::Shape);
        }
        Ok(())
    }

    /// Joint corrections `dq` for readings `q`; `tau` are the lever arms (m), used only by
    /// compliance terms.
    pub fn correction<const N: usize>(&self, q: &[T; N], tau: &[T; N]) -> [T; N] {
        let mut dq = [T::zero(); N];
        for e in self.list.iter() {
            let j = e.joint as usize;
            if j >= N {
                continue;
            }
            let Some(v) = self.values_in(e) else {
                continue;
            };
            dq[j] += match e.kind {
                EffectKind::Scale => v[0] * q[j],
                EffectKind::Compliance => v[0] * tau[j],
                EffectKind::Cyclic => {
                    let (s, c) = (q[j] * T::of(e.order as f64)).sincos();
                    v[0] * s + v[1] * c
                }
                EffectKind::Table => {
                    let (k, w) = e.segment(q[j]);
                    v[k] * (T::one() - w) + v[k + 1] * w
                }
                EffectKind::Thermal | EffectKind::Drift => T::zero(),
            };
        }
        dq
    }

    /// `∂dq_j/∂q_j` for each joint (compliance's dependence on the pose is second order and
    /// left out): what compensation's Newton steps need.
    pub fn correction_slope<const N: usize>(&self, q: &[T; N]) -> [T; N] {
        let mut g = [T::zero(); N];
        for e in self.list.iter() {
            let j = e.joint as usize;
            if j >= N {
                continue;
            }
            let Some(v) = self.values_in(e) else {
                continue;
            };
            g[j] += match e.kind {
                EffectKind::Scale => v[0],
                EffectKind::Compliance | EffectKind::Thermal | EffectKind::Drift => T::zero(),
                EffectKind::Cyclic => {
                    let n = T::of(e.order as f64);
                    let (s, c) = (q[j] * n).sincos();
                    n * (v[0] * c - v[1] * s)
                }
                EffectKind::Table => {
                    let (k, _) = e.segment(q[j]);
                    let u = (q[j] - e.start) / e.step;
                    let inside = u > T::zero() && u < T::of((e.len - 1) as f64);
                    if inside {
                        (v[k + 1] - v[k]) / e.step
                    } else {
                        T::zero()
                    }
                }
            };
        }
        g
    }

    /// Basis function `φ` of value `k` (global value index) at readings `q`, lever arms `tau`:
    /// `∂dq_joint/∂v_k`. Returns the joint it acts on; `None` for a thermal-expansion or
    /// base-drift value (no joint correction: its column is
    /// [`crate::ForwardKinematics::column`]'s).
    pub fn basis<const N: usize>(&self, k: usize, q: &[T; N], tau: &[T; N]) -> Option<(usize, T)> {
        let e = self.list.iter().find(|e| e.range().contains(&k))?;
        let j = e.joint as usize;
        if j >= N {
            return None;
        }
        let i = k - e.first as usize;
        let phi = match e.kind {
            EffectKind::Thermal | EffectKind::Drift => return None,
            EffectKind::Scale => q[j],
            EffectKind::Compliance => tau[j],
            EffectKind::Cyclic => {
                let (s, c) = (q[j] * T::of(e.order as f64)).sincos();
                if i == 0 {
                    s
                } else {
                    c
                }
            }
            EffectKind::Table => {
                let (seg, w) = e.segment(q[j]);
                if i == seg {
                    T::one() - w
                } else if i == seg + 1 {
                    w
                } else {
                    T::zero()
                }
            }
        };
        Some((j, phi))
    }
}
