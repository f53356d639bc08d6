//! Named model parameters, the identified subset, and the updates identification applies.
//!
//! Layout (`docs/formats.md#kinematic-model`): `base.x base.y base.z base.rx base.ry base.rz`,
//! then per joint `alphaI aI thetaI dI betaI`, then `tool.x tool.y tool.z`, then the effect
//! values. Angles are rad and lengths mm inside the library. A [`ParamSet`] is the ordered
//! subset being identified.

use crate::model::bounds::{MAX_ANGLE, MAX_LENGTH};
use crate::model::effects::EffectKind;
use crate::ValueStorage;
use crate::{Real, Robot};
use core::fmt;
use heapless::Vec;
use nalgebra::Vector3;

/// One model parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Param {
    /// Base origin x in the measurement frame, mm.
    BaseX,
    /// Base origin y in the measurement frame, mm.
    BaseY,
    /// Base origin z in the measurement frame, mm.
    BaseZ,
    /// Base rotation about the measurement frame's x axis (identification updates it as a
    /// small rotation about the base origin; the model file stores roll/pitch/yaw).
    BaseRx,
    /// Base rotation about the measurement frame's y axis (as [`Param::BaseRx`]).
    BaseRy,
    /// Base rotation about the measurement frame's z axis (as [`Param::BaseRx`]).
    BaseRz,
    /// `alpha` of joint `i` (0-based, as in every row parameter), rad.
    Alpha(u8),
    /// `a` of joint `i`, mm.
    A(u8),
    /// `theta` (angle offset) of joint `i`, rad.
    Theta(u8),
    /// `d` of joint `i`, mm.
    D(u8),
    /// `beta` (Hayati tilt) of joint `i`, rad.
    Beta(u8),
    /// Tool point x in the flange frame, mm.
    ToolX,
    /// Tool point y in the flange frame, mm.
    ToolY,
    /// Tool point z in the flange frame, mm.
    ToolZ,
    /// Coordinate `axis` (0 x, 1 y, 2 z) of tool point `k` ≥ 1 (a further reflector; point 0
    /// is [`Param::ToolX`]…), flange frame, mm.
    ToolPoint(u8, u8),
    /// Rotation of the measured frame about the flange's x axis (identification updates it as
    /// a small rotation in the flange frame; the model file stores roll/pitch/yaw), rad.
    ToolRx,
    /// Rotation of the measured frame about the flange's y axis (as [`Param::ToolRx`]).
    ToolRy,
    /// Rotation of the measured frame about the flange's z axis (as [`Param::ToolRx`]).
    ToolRz,
    /// Value `k` of the model's effect list (see [`crate::Effects::values`]).
    Effect(u16),
}

impl Param {
    /// The six parameters of the base pose: origin x, y, z, then rotations about x, y, z.
    pub const BASE: [Param; 6] = [
        Param::BaseX,
        Param::BaseY,
        Param::BaseZ,
        Param::BaseRx,
        Param::BaseRy,
        Param::BaseRz,
    ];

    /// True for parameters measured in millimetres (the rest are radians or per-radian).
    pub fn is_length(self) -> bool {
        matches!(
            self,
            Param::BaseX
                | Param::BaseY
                | Param::BaseZ
                | Param::A(_)
                | Param::D(_)
                | Param::ToolX
                | Param::ToolY
                | Param::ToolZ
                | Param::ToolPoint(..)
        )
    }

    /// True for the three parameters of the measured frame's orientation (seen only by 6-D
    /// observations).
    pub fn is_tool_rotation(self) -> bool {
        matches!(self, Param::ToolRx | Param::ToolRy | Param::ToolRz)
    }

    /// True for the six parameters of the base pose.
    pub fn is_base(self) -> bool {
        matches!(
            self,
            Param::BaseX
                | Param::BaseY
                | Param::BaseZ
                | Param::BaseRx
                | Param::BaseRy
                | Param::BaseRz
        )
    }

    /// True for the coordinates of a tool point (any of them).
    pub fn is_tool(self) -> bool {
        matches!(
            self,
            Param::ToolX | Param::ToolY | Param::ToolZ | Param::ToolPoint(..)
        )
    }

    /// Tool point `k` and axis of a point coordinate.
    pub fn tool_point(self) -> Option<(usize, usize)> {
        match self {
            Param::ToolX => Some((0, 0)),
            Param::ToolY => Some((0, 1)),
            Param::ToolZ => Some((0, 2)),
            Param::ToolPoint(k, a) => Some((k as usize, a as usize)),
            _ => None,
        }
    }

    /// Scale that makes a unit step comparable to 1 mm at the tool: 1 for lengths, the robot's
    /// reach (mm per rad) for angles and effect values.
    pub fn scale<T: Real>(self, reach: T) -> T {
        if self.is_length() {
            T::one()
        } else {
            reach
        }
    }

    /// Joint the parameter belongs to (0-based), if any.
    pub fn joint(self) -> Option<usize> {
        match self {
            Param::Alpha(i) | Param::A(i) | Param::Theta(i) | Param::D(i) | Param::Beta(i) => {
                Some(i as usize)
            }
            _ => None,
        }
    }

    /// A displayable name (`d2`, `base.rz`, `joint-table3[12]`); effect names need the robot.
    pub fn name<'a, T: Real, const N: usize, V: ValueStorage>(
        self,
        robot: &'a Robot<T, N, V>,
    ) -> ParamName<'a, T, N, V> {
        ParamName {
            p: self,
            robot: Some(robot),
        }
    }

    /// Parses a name written by [`Param::name`] for geometric parameters (not effects).
    pub fn parse(s: &str) -> Option<Param> {
        Some(match s {
            "base.x" => Param::BaseX,
            "base.y" => Param::BaseY,
            "base.z" => Param::BaseZ,
            "base.rx" => Param::BaseRx,
            "base.ry" => Param::BaseRy,
            "base.rz" => Param::BaseRz,
            "tool.x" => Param::ToolX,
            "tool.y" => Param::ToolY,
            "tool.z" => Param::ToolZ,
            "tool.rx" => Param::ToolRx,
            "tool.ry" => Param::ToolRy,
            "tool.rz" => Param::ToolRz,
            _ if s.starts_with("tool") => {
                let (k, axis) = s[4..].split_once('.')?;
                let k: u8 = k.parse().ok()?;
                let axis = ["x", "y", "z"].iter().position(|a| *a == axis)? as u8;
                if k < 2 {
                    return None;
                }
                Param::ToolPoint(k - 1, axis)
            }
            _ => {
                let split = s.find(|c: char| c.is_ascii_digit())?;
                let (head, num) = s.split_at(split);
                let i: u8 = num.parse().ok()?;
                if i == 0 {
                    return None;
                }
                let i = i - 1;
                match head {
                    "alpha" => Param::Alpha(i),
                    "a" => Param::A(i),
                    "theta" => Param::Theta(i),
                    "d" => Param::D(i),
                    "beta" => Param::Beta(i),
                    _ => return None,
                }
            }
        })
    }
}

/// [`fmt::Display`] of a parameter's name.
#[derive(Debug)]
pub struct ParamName<'a, T: Real, const N: usize, V: ValueStorage> {
    p: Param,
    robot: Option<&'a Robot<T, N, V>>,
}

impl<T: Real, const N: usize, V: ValueStorage> fmt::Display for ParamName<'_, T, N, V> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.p {
            Param::BaseX => f.write_str("base.x"),
            Param::BaseY => f.write_str("base.y"),
            Param::BaseZ => f.write_str("base.z"),
            Param::BaseRx => f.write_str("base.rx"),
            Param::BaseRy => f.write_str("base.ry"),
            Param::BaseRz => f.write_str("base.rz"),
            Param::Alpha(i) => write!(f, "alpha{}", i + 1),
            Param::A(i) => write!(f, "a{}", i + 1),
            Param::Theta(i) => write!(f, "theta{}", i + 1),
            Param::D(i) => write!(f, "d{}", i + 1),
            Param::Beta(i) => write!(f, "beta{}", i + 1),
            Param::ToolX => f.write_str("tool.x"),
            Param::ToolY => f.write_str("tool.y"),
            Param::ToolZ => f.write_str("tool.z"),
            Param::ToolPoint(k, a) => write!(
                f,
                "tool{}.{}",
                k as usize + 1,
                ["x", "y", "z"].get(a as usize).unwrap_or(&"?")
            ),
            Param::ToolRx => f.write_str("tool.rx"),
            Param::ToolRy => f.write_str("tool.ry"),
            Param::ToolRz => f.write_str("tool.rz"),
            Param::Effect(k) => {
                let k = k as usize;
                let eff = self
                    .robot
                    .and_then(|r| r.effects().iter().find(|e| e.range().contains(&k)));
                match eff {
                    None => write!(f, "effect[{k}]"),
                    Some(e) => {
                        let i = k - e.first as usize;
                        let j = e.joint as usize + 1;
                        match e.kind {
                            EffectKind::Cyclic => write!(
                                f,
                                "joint-cyclic{j}.n{}.{}",
                                e.order,
                                if i == 0 { 'a' } else { 'b' }
                            ),
                            EffectKind::Table => write!(f, "joint-table{j}[{i}]"),
                            EffectKind::Drift => {
                                write!(f, "base-drift.v{}", ["x", "y", "z"].get(i).unwrap_or(&"?"))
                            }
                            kind => write!(f, "{}{j}", kind.id()),
                        }
                    }
                }
            }
        }
    }
}

/// Why a parameter set or update was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamError {
    /// More parameters than the set's capacity.
    Capacity,
    /// A parameter refers to a joint or effect value the robot does not have.
    OutOfRange,
    /// The update vector's length differs from the set's, holds NaN/inf, or would take a
    /// value beyond the robot's bounds ([`crate::model::bounds::MAX_LENGTH`],
    /// [`crate::model::bounds::MAX_ANGLE`]).
    Shape,
}

/// An ordered set of at most `P` parameters: the columns being identified.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ParamSet<const P: usize> {
    items: Vec<Param, P>,
}

impl<const P: usize> ParamSet<P> {
    /// An empty set.
    pub fn new() -> Self {
        Self { items: Vec::new() }
    }
    /// The parameters in column order.
    pub fn as_slice(&self) -> &[Param] {
        &self.items
    }
    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.items.len()
    }
    /// True when the set has no parameter.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
    /// True when `p` is in the set.
    pub fn contains(&self, p: Param) -> bool {
        self.items.contains(&p)
    }
    /// Column index of `p`, if it is in the set.
    pub fn position(&self, p: Param) -> Option<usize> {
        self.items.iter().position(|x| *x == p)
    }
    /// Adds a parameter (ignored if already present).
    pub fn push(&mut self, p: Param) -> Result<(), ParamError> {
        if self.contains(p) {
            return Ok(());
        }
        self.items.push(p).map_err(|_| ParamError::Capacity)
    }
    /// Removes a parameter, keeping the order of the rest.
    pub fn remove(&mut self, p: Param) {
        if let Some(i) = self.position(p) {
            self.items.remove(i);
        }
    }

    /// The BPNN-PSO paper's 24-style set: alpha, a, theta, d of every joint (base and tool fixed).
    /// More than 255 joints is [`ParamError::OutOfRange`].
    pub fn mdh(n: usize) -> Result<Self, ParamError> {
        let mut s = Self::new();
        // Joint indices are `u8`: more joints cannot be named (not truncated).
        let n = u8::try_from(n).map_err(|_| ParamError::OutOfRange)?;
        for i in 0..n {
            for p in [Param::Alpha(i), Param::A(i), Param::Theta(i), Param::D(i)] {
                s.push(p)?;
            }
        }
        Ok(s)
    }

    /// The default full set: base pose (when `base_unknown`), alpha, a, theta, d per joint, tool.
    pub fn full(n: usize, base_unknown: bool) -> Result<Self, ParamError> {
        let mut s = Self::new();
        if base_unknown {
            for p in [
                Param::BaseX,
                Param::BaseY,
                Param::BaseZ,
                Param::BaseRx,
                Param::BaseRy,
                Param::BaseRz,
            ] {
                s.push(p)?;
            }
        }
        for p in Self::mdh(n)?.as_slice() {
            s.push(*p)?;
        }
        for p in [Param::ToolX, Param::ToolY, Param::ToolZ] {
            s.push(p)?;
        }
        Ok(s)
    }

    /// Adds every value of every effect of `robot`.
    pub fn with_effects<T: Real, const N: usize, V: ValueStorage>(
        mut self,
        robot: &Robot<T, N, V>,
    ) -> Result<Self, ParamError> {
        for k in 0..robot.effects().values().len() {
            self.push(Param::Effect(k as u16))?;
        }
        Ok(self)
    }

    /// Checks that every parameter exists in `robot`.
    pub fn check<T: Real, const N: usize, V: ValueStorage>(
        &self,
        robot: &Robot<T, N, V>,
    ) -> Result<(), ParamError> {
        check_params(self.as_slice(), robot)
    }
}

impl<const P: usize> core::ops::Deref for ParamSet<P> {
    type Target = [Param];
    fn deref(&self) -> &[Param] {
        self.as_slice()
    }
}

/// Checks that every parameter of `params` exists in `robot`.
pub fn check_params<T: Real, const N: usize, V: ValueStorage>(
    params: &[Param],
    robot: &Robot<T, N, V>,
) -> Result<(), ParamError> {
    let nv = robot.effects().values().len();
    for p in params {
        let ok = match *p {
            Param::Effect(k) => (k as usize) < nv,
            Param::ToolPoint(k, a) => k >= 1 && (k as usize) < robot.tool_point_count() && a < 3,
            p => p.joint().is_none_or(|j| j < N),
        };
        if !ok {
            return Err(ParamError::OutOfRange);
        }
    }
    Ok(())
}

/// Value of a parameter in `robot` (rad or mm; the base rotation as fixed-axis roll/pitch/yaw).
pub fn value<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    p: Param,
) -> Option<T> {
    match p {
        Param::BaseRx => Some(robot.base().rpy()[0]),
        Param::BaseRy => Some(robot.base().rpy()[1]),
        Param::BaseRz => Some(robot.base().rpy()[2]),
        Param::ToolRx => Some(robot.tool_axes().rpy()[0]),
        Param::ToolRy => Some(robot.tool_axes().rpy()[1]),
        Param::ToolRz => Some(robot.tool_axes().rpy()[2]),
        p => stored(robot, p),
    }
}

/// Value of a parameter stored as such in `robot` (every one but the base rotation, `None`
/// for those and for a joint or effect value the robot does not have).
fn stored<T: Real, const N: usize, V: ValueStorage>(robot: &Robot<T, N, V>, p: Param) -> Option<T> {
    let j = |i: u8| robot.joint(i as usize);
    Some(match p {
        Param::BaseX => robot.base().o.x,
        Param::BaseY => robot.base().o.y,
        Param::BaseZ => robot.base().o.z,
        Param::BaseRx | Param::BaseRy | Param::BaseRz => return None,
        Param::ToolRx | Param::ToolRy | Param::ToolRz => return None,
        Param::ToolPoint(k, a) => *robot.tool_point(k as usize)?.get(a as usize)?,
        Param::Alpha(i) => j(i)?.alpha,
        Param::A(i) => j(i)?.a,
        Param::Theta(i) => j(i)?.theta,
        Param::D(i) => j(i)?.d,
        Param::Beta(i) => j(i)?.beta,
        Param::ToolX => robot.tool().x,
        Param::ToolY => robot.tool().y,
        Param::ToolZ => robot.tool().z,
        Param::Effect(k) => *robot.effects().values().get(k as usize)?,
    })
}

/// Applies an update `delta` (one entry per parameter of `set`) to `robot`: lengths and angles
/// are added, the base rotation entries form a rotation vector applied about the base origin.
/// On error the robot is unchanged.
pub fn apply_delta<T: Real, const N: usize, V: ValueStorage>(
    robot: &mut Robot<T, N, V>,
    set: &[Param],
    delta: &[T],
) -> Result<(), ParamError> {
    if delta.len() != set.len() || delta.iter().any(|d| !d.finite()) {
        return Err(ParamError::Shape);
    }
    check_params(set, robot)?;
    // Every updated value must stay one the robot accepts (the base rotation stays a rotation
    // by construction): checked before anything changes.
    // (`check_params` passed: every parameter but the base rotation has a stored value.)
    for (p, d) in set.iter().zip(delta) {
        let Some(v) = stored(robot, *p) else {
            continue;
        };
        let bound = if p.is_length() { MAX_LENGTH } else { MAX_ANGLE };
        if !((v + *d).abs() <= T::of(bound)) {
            return Err(ParamError::Shape);
        }
    }
    let mut w = Vector3::zeros();
    let mut wt = Vector3::zeros();
    let mut dt = Vector3::zeros();
    {
        let (base, joints, tool, effects) = robot.parts_mut();
        for (p, d) in set.iter().zip(delta) {
            let d = *d;
            match *p {
                Param::BaseX => dt.x += d,
                Param::BaseY => dt.y += d,
                Param::BaseZ => dt.z += d,
                Param::BaseRx => w.x += d,
                Param::BaseRy => w.y += d,
                Param::BaseRz => w.z += d,
                Param::Alpha(i) => joints[i as usize].alpha += d,
                Param::A(i) => joints[i as usize].a += d,
                Param::Theta(i) => joints[i as usize].theta += d,
                Param::D(i) => joints[i as usize].d += d,
                Param::Beta(i) => joints[i as usize].beta += d,
                Param::ToolX => tool.x += d,
                Param::ToolY => tool.y += d,
                Param::ToolZ => tool.z += d,
                Param::ToolRx => wt.x += d,
                Param::ToolRy => wt.y += d,
                Param::ToolRz => wt.z += d,
                // Checked above: the point exists, the axis is 0..3.
                Param::ToolPoint(..) => {}
                // Checked above (`check_params`); `get_mut` rather than an index all the same: a
                // caller's value buffer might hand out fewer writable than readable slots.
                Param::Effect(k) => {
                    if let Some(v) = effects.values_mut().get_mut(k as usize) {
                        *v += d;
                    }
                }
            }
        }
        base.o += dt;
        base.rotate_in_parent(&w);
    }
    {
        let extra = robot.tool_extra_mut();
        for (p, d) in set.iter().zip(delta) {
            if let Param::ToolPoint(k, a) = *p {
                extra.more[k as usize - 1][a as usize] += *d;
            }
        }
        extra.axes.rotate_in_parent(&wt);
    }
    robot.refresh();
    Ok(())
}
