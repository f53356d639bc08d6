//! The robot description file (docs/formats.md): TOML in, TOML out, and conversion to and
//! from the library's [`Robot`].
//!
//! Units in the file are degrees and millimetres; the library works in radians. Angles are
//! written as the shortest decimal that reads back as the *same* `f64` radians (see
//! [`deg_short`]): the user's `-60.0` comes back as `-60.0`, and an identified model survives a
//! write/read cycle bit for bit (the base orientation, stored as roll/pitch/yaw, to rounding).
//!
//! Every loading error is one line `FILE:LINE:COLUMN: what is wrong`, pointing at the offending
//! table when the problem is a value rather than the syntax; it makes the command line exit
//! with status 2 (input refused, [`crate::refused`]). Files are written atomically
//! ([`crate::output::atomic::write_atomic`]).

use crate::{refused, VCAP};
use anyhow::{anyhow, Context};
use kinecal::model::coupling::MAX_COUPLINGS;
use kinecal::model::effects::{EffectKind, MAX_EFFECTS};
use kinecal::model::tool::MAX_TOOL_POINTS;
use kinecal::{Frame, Joint, Robot};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// Effect id of the Hayati tilt: geometric, so it lives in the joint's `beta`, not in the
/// library's effect list.
pub const AXIS_TILT: &str = "axis-tilt";

/// The effect id of the thermal expansion of every length (`docs/formats.md#effects`).
pub const THERMAL: &str = "thermal-expansion";

/// Reference temperature (°C) of a thermal-expansion term whose file gives none and that no
/// data have set ([`RobotFile::with_thermal_reference`]).
pub const DEFAULT_REFERENCE_C: f64 = 20.0;

/// A whole robot file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotFile {
    #[serde(default)]
    pub name: String,
    pub joints: Vec<JointSpec>,
    /// `[tool]`, or the first of `[[tools]]` (its point; no orientation).
    pub tool: ToolSpec,
    /// `[[tools]]`: several named reflectors measured in the same pose (empty with `[tool]`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tools: Vec<NamedToolSpec>,
    /// Absent = the base pose is unknown and has to be estimated from data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base: Option<BaseSpec>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<EffectSpec>,
    /// `[[couplings]]`: joints read relative to another (docs/formats.md).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub couplings: Vec<CouplingSpec>,
    /// `[prior]`: the 1-σ of each kind of parameter's change that `identify` assumes
    /// (absent: the defaults of [`crate::formats::prior::PriorSpec`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<crate::formats::prior::PriorSpec>,
}

/// One `[[joints]]` table: the modified DH row of docs/formats.md "Kinematic model".
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    pub alpha_deg: f64,
    pub a_mm: f64,
    pub theta_deg: f64,
    pub d_mm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta_deg: Option<f64>,
    /// `[lower, upper]`; absent = ±180°.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits_deg: Option<[f64; 2]>,
}

/// `[tool]`: the measured point in the flange frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolSpec {
    pub xyz_mm: [f64; 3],
    /// Orientation of the measured frame in the flange frame (fixed-axis roll, pitch, yaw;
    /// docs/formats.md): what 6-D observations (`rx_deg`, `ry_deg`, `rz_deg`) measure, and
    /// what identification fits as `tool.rx`, `tool.ry`, `tool.rz` when they are present
    /// (`kinecal import --urdf` writes the tip link's orientation here).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rpy_deg: Option<[f64; 3]>,
    /// `xyz_mm = "unknown"` or a `[tool]` without `xyz_mm`: nobody measured the point; it is
    /// started from the data (`xyz_mm` then holds zeros) and not judged against a tolerance.
    #[serde(skip)]
    pub unknown: bool,
}

/// `[tool]` as written: `xyz_mm` a point in mm, the word `"unknown"`, or absent (unknown).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTool {
    #[serde(default)]
    xyz_mm: Option<RawXyz>,
    #[serde(default)]
    rpy_deg: Option<[f64; 3]>,
}

#[derive(Clone, Debug)]
enum RawXyz {
    Point([f64; 3]),
    Word(String),
}

impl<'de> Deserialize<'de> for RawXyz {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = RawXyz;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a point [x, y, z] in mm or \"unknown\"")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<RawXyz, E> {
                Ok(RawXyz::Word(v.to_string()))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<RawXyz, A::Error> {
                <[f64; 3]>::deserialize(serde::de::value::SeqAccessDeserializer::new(seq))
                    .map(RawXyz::Point)
            }
        }
        d.deserialize_any(Visit)
    }
}

/// One `[[tools]]` table: a named reflector (letters, digits, `_`) and its point in the flange
/// frame; the measurement file has `x_NAME`, `y_NAME`, `z_NAME` for it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NamedToolSpec {
    pub name: String,
    pub xyz_mm: [f64; 3],
}

/// What [`RobotFile::to_toml`] writes: `[tool]` or `[[tools]]`, never both.
#[derive(Serialize)]
struct OutFile<'a> {
    name: &'a str,
    joints: &'a [JointSpec],
    #[serde(skip_serializing_if = "Option::is_none")]
    tool: Option<OutTool>,
    #[serde(skip_serializing_if = "<[NamedToolSpec]>::is_empty")]
    tools: &'a [NamedToolSpec],
    #[serde(skip_serializing_if = "Option::is_none")]
    base: Option<&'a BaseSpec>,
    #[serde(skip_serializing_if = "<[EffectSpec]>::is_empty")]
    effects: &'a [EffectSpec],
    #[serde(skip_serializing_if = "<[CouplingSpec]>::is_empty")]
    couplings: &'a [CouplingSpec],
    #[serde(skip_serializing_if = "Option::is_none")]
    prior: Option<&'a crate::formats::prior::PriorSpec>,
}

/// `[tool]` as written: an unknown point stays `xyz_mm = "unknown"` (the zeros it holds in
/// memory would read back as a measured point at the flange).
#[derive(Serialize)]
struct OutTool {
    xyz_mm: OutXyz,
    #[serde(skip_serializing_if = "Option::is_none")]
    rpy_deg: Option<[f64; 3]>,
}

#[derive(Serialize)]
#[serde(untagged)]
enum OutXyz {
    Point([f64; 3]),
    Word(&'static str),
}

impl OutTool {
    fn of(t: &ToolSpec) -> Self {
        OutTool {
            xyz_mm: if t.unknown {
                OutXyz::Word("unknown")
            } else {
                OutXyz::Point(t.xyz_mm)
            },
            rpy_deg: t.rpy_deg,
        }
    }
}

/// `[base]`: the robot base in the measurement frame (fixed-axis roll, pitch, yaw).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseSpec {
    pub xyz_mm: [f64; 3],
    #[serde(default)]
    pub rpy_deg: [f64; 3],
}

/// One `[[effects]]` table (docs/formats.md "Effects").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    /// `joint-scale`, `joint-cyclic`, `joint-compliance`, `joint-table`, `axis-tilt` or
    /// `thermal-expansion`.
    pub kind: String,
    /// 1-based joint number (0 for thermal-expansion, which acts on no joint).
    #[serde(default)]
    pub joint: usize,
    /// scale: `[s]`; cyclic: `[a, b]` (rad); compliance: `[k]` (rad per m); table: knot values
    /// (rad), lowest knot first; axis-tilt: `[]` or `[beta]` (rad, overrides `beta_deg`);
    /// thermal-expansion: `[c]` (per kelvin).
    #[serde(default)]
    pub values: Vec<f64>,
    /// Harmonic order (joint-cyclic only, default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<u16>,
    /// Knot spacing (joint-table only, required there).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step_deg: Option<f64>,
    /// Position of the lowest knot (joint-table only; default: the joint's lower limit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_deg: Option<f64>,
    /// Reference temperature T0, °C (thermal-expansion only; default: the identification
    /// data's mean `temp_c`, [`RobotFile::with_thermal_reference`], or 20 °C without data).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_c: Option<f64>,
}

/// One `[[couplings]]` table: the model angle of `joint` is its reading plus `ratio` times the
/// reading of `from` (FANUC J3 measured from the horizontal: `joint = 3, from = 2, ratio = 1`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingSpec {
    /// 1-based joint whose reading is relative.
    pub joint: usize,
    /// 1-based joint whose reading it is relative to.
    pub from: usize,
    /// `q_joint = reading_joint + ratio · reading_from` (degrees per degree).
    pub ratio: f64,
}

/// The same file with the position of every table, for error messages. Unknown keys are
/// refused everywhere: a misspelt `[[joints]]` must not silently drop a joint.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    #[serde(default)]
    name: String,
    joints: Spanned<Vec<Spanned<JointSpec>>>,
    #[serde(default)]
    tool: Option<Spanned<RawTool>>,
    #[serde(default)]
    tools: Vec<Spanned<NamedToolSpec>>,
    #[serde(default)]
    base: Option<Spanned<BaseSpec>>,
    #[serde(default)]
    effects: Vec<Spanned<EffectSpec>>,
    #[serde(default)]
    couplings: Vec<Spanned<CouplingSpec>>,
    #[serde(default)]
    prior: Option<crate::formats::prior::PriorSpec>,
}

/// Where a validation problem is (indices are 0-based positions in the file's lists).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    File,
    Joints,
    Joint(usize),
    Tool,
    Tools(usize),
    Base,
    Effect(usize),
    Coupling(usize),
}

/// A value problem found by [`RobotFile::validate`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Issue {
    pub place: Place,
    pub message: String,
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let mut cut = offset;
    while !text.is_char_boundary(cut) {
        cut -= 1;
    }
    let before = &text[..cut];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

/// Degrees of an angle in radians, chosen among the nearest `f64`s so that
/// `deg_exact(r).to_radians() == r` whenever such a value exists (it almost always does).
pub fn deg_exact(rad: f64) -> f64 {
    let d0 = rad.to_degrees();
    if !d0.is_finite() || d0.to_radians() == rad {
        return d0;
    }
    let step = |x: f64, up: bool| -> f64 {
        // Next representable value towards +inf (up) or -inf.
        if x == 0.0 {
            return if up {
                f64::from_bits(1)
            } else {
                -f64::from_bits(1)
            };
        }
        let b = x.to_bits();
        let away = (x > 0.0) == up;
        f64::from_bits(if away { b + 1 } else { b - 1 })
    };
    let (mut lo, mut hi) = (d0, d0);
    for _ in 0..8 {
        lo = step(lo, false);
        hi = step(hi, true);
        if lo.to_radians() == rad {
            return lo;
        }
        if hi.to_radians() == rad {
            return hi;
        }
    }
    d0
}

/// Degrees of an angle in radians as the user would write them: the `f64` with the shortest
/// decimal form among those `d` with `d.to_radians() == rad` (so `(-60f64).to_radians()` gives
/// back `-60.0`, not `-59.99999999999999`), trying increasing precision. Keeps the guarantee of
/// [`deg_exact`] (which it falls back on): the value reads back as the same radians.
pub fn deg_short(rad: f64) -> f64 {
    let d0 = deg_exact(rad);
    if !d0.is_finite() || d0 == 0.0 {
        return d0;
    }
    for digits in 1..=17usize {
        // The nearest `digits`-significant-digit decimal, and its neighbours one unit of the
        // last digit either side (the set of exact values is a few ulps wide, so the shortest
        // decimal in it is one of these).
        let text = format!("{:.*e}", digits - 1, d0);
        let Some((mantissa, exp)) = text.split_once('e') else {
            continue;
        };
        let (Ok(m), Ok(e)) = (mantissa.parse::<f64>(), exp.parse::<i32>()) else {
            continue;
        };
        let unit = 10f64.powi(digits as i32 - 1);
        let m_int = (m * unit).round();
        let mut best: Option<f64> = None;
        for k in [0.0, -1.0, 1.0] {
            let cand: Option<f64> = format!("{}e{}", m_int + k, e - (digits as i32 - 1))
                .parse()
                .ok();
            if let Some(c) = cand {
                if c.to_radians() == rad && best.is_none_or(|b| (c - d0).abs() < (b - d0).abs()) {
                    best = Some(c);
                }
            }
        }
        if let Some(b) = best {
            return b;
        }
    }
    d0
}

/// Roll, pitch, yaw (degrees) of a base pose as the user would write them: the shortest
/// decimals (same number of significant digits for the three) from which
/// [`Frame::from_xyz_rpy`] rebuilds exactly this rotation, so a `[base]` read from a file is
/// written back as given (`1.0`, not `0.9999999999999998`). Falls back on [`deg_short`] of
/// each angle (an identified base's rotation, which no short decimals reproduce).
pub fn rpy_deg_short(base: &Frame<f64>) -> [f64; 3] {
    let rpy = base.rpy();
    let fallback = rpy.map(deg_short);
    if !fallback.iter().all(|v| v.is_finite()) {
        return fallback;
    }
    let xyz = [base.o.x, base.o.y, base.o.z];
    let same = |deg: [f64; 3]| {
        let f = Frame::from_xyz_rpy(xyz, deg.map(f64::to_radians));
        f.x == base.x && f.y == base.y && f.z == base.z
    };
    for digits in 1..=17usize {
        let cand = fallback.map(|d| {
            if d == 0.0 {
                0.0
            } else {
                format!("{:.*e}", digits - 1, d).parse().unwrap_or(d)
            }
        });
        if same(cand) {
            return cand;
        }
    }
    fallback
}

/// A robot file whose every length is below this (mm) is refused as one written in metres: the
/// smallest arms calibrated with a tracker have links of tens of millimetres.
pub const METRES_SUSPECT_MM: f64 = 10.0;

fn finite(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

/// Why a length of the file (mm) is implausible, if it is: beyond ±[`crate::MAX_LENGTH_MM`]
/// no robot cell is (a file in micrometres or a typo).
fn implausible_length(key: &str, v: f64) -> Option<String> {
    (v.abs() > crate::MAX_LENGTH_MM).then(|| {
        format!(
            "{key} = {} is implausible: lengths are millimetres within ±{} (100 m)",
            crate::number_text(v),
            crate::MAX_LENGTH_MM
        )
    })
}

/// Why an angle of the file (degrees) is implausible, if it is: beyond ±`max`.
fn implausible_angle(key: &str, v: f64, max: f64) -> Option<String> {
    (v.abs() > max).then(|| {
        format!(
            "{key} = {} is implausible: angles are degrees within ±{max}",
            crate::number_text(v)
        )
    })
}

impl RobotFile {
    /// Number of joints (rows).
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// True when the file has a `[base]` table (otherwise the base must be estimated).
    pub fn base_known(&self) -> bool {
        self.base.is_some()
    }

    /// The file says the tool point is unknown (`[tool] xyz_mm = "unknown"`, or a `[tool]`
    /// without `xyz_mm`): it is started from the data, as an unknown base is.
    pub fn tool_unknown(&self) -> bool {
        self.tool.unknown && self.tools.is_empty()
    }

    /// Joints (0-based) marked `axis-tilt` in `[[effects]]`: their `beta` is a free parameter.
    pub fn tilt_joints(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self
            .effects
            .iter()
            .filter(|e| e.kind == AXIS_TILT)
            .map(|e| e.joint.saturating_sub(1))
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Joint limits in degrees (±180 when the file gives none).
    pub fn limits_deg(&self, joint: usize) -> [f64; 2] {
        self.joints
            .get(joint)
            .and_then(|j| j.limits_deg)
            .unwrap_or([-180.0, 180.0])
    }

    /// Why the file's lengths read as metres, if they do: the largest link length, offset and
    /// tool coordinate below [`METRES_SUSPECT_MM`] (a 0.612 that should be 612 mm) is no arm
    /// measured with a tracker, and fitting it to millimetre data is no calibration (the units
    /// door of the measurement files, for robot files).
    fn lengths_in_metres(&self) -> Option<String> {
        let mut largest: Option<(String, f64)> = None;
        let mut see = |key: String, v: f64| {
            if v.is_finite() && largest.as_ref().is_none_or(|(_, m)| v.abs() > *m) {
                largest = Some((key, v.abs()));
            }
        };
        for (i, j) in self.joints.iter().enumerate() {
            see(format!("a{}", i + 1), j.a_mm);
            see(format!("d{}", i + 1), j.d_mm);
        }
        if !self.tool.unknown {
            for (a, v) in ["x", "y", "z"].iter().zip(self.tool.xyz_mm) {
                see(format!("tool {a}"), v);
            }
        }
        for t in &self.tools {
            for (a, v) in ["x", "y", "z"].iter().zip(t.xyz_mm) {
                see(format!("{} {a}", t.name), v);
            }
        }
        let (key, v) = largest?;
        (v > 0.0 && v < METRES_SUSPECT_MM).then(|| {
            format!(
                "every length is below {METRES_SUSPECT_MM} mm (the largest, {key}, is {}): robot files are in millimetres and this one reads as metres; multiply its lengths (a_mm, d_mm, xyz_mm) by 1000",
                crate::number_text(v)
            )
        })
    }

    /// Checks every value: finite numbers, `lower < upper`, 2 to 8 joints, effects on existing
    /// joints with the right number of values.
    pub fn validate(&self) -> Result<(), Issue> {
        let issue = |place, message: String| Err(Issue { place, message });
        let n = self.joints.len();
        if !(2..=8).contains(&n) {
            return issue(
                Place::Joints,
                format!("the robot has {n} joints; 2 to 8 are supported"),
            );
        }
        for (i, j) in self.joints.iter().enumerate() {
            let p = Place::Joint(i);
            if !finite(&[
                j.alpha_deg,
                j.a_mm,
                j.theta_deg,
                j.d_mm,
                j.beta_deg.unwrap_or(0.0),
            ]) {
                return issue(
                    p,
                    format!("joint {}: parameters must be finite numbers", i + 1),
                );
            }
            for (key, v) in [("a_mm", j.a_mm), ("d_mm", j.d_mm)] {
                if let Some(m) = implausible_length(key, v) {
                    return issue(p, format!("joint {}: {m}", i + 1));
                }
            }
            for (key, v) in [
                ("alpha_deg", j.alpha_deg),
                ("theta_deg", j.theta_deg),
                ("beta_deg", j.beta_deg.unwrap_or(0.0)),
            ] {
                if let Some(m) = implausible_angle(key, v, crate::MAX_ANGLE_DEG) {
                    return issue(p, format!("joint {}: {m}", i + 1));
                }
            }
            if let Some([lo, hi]) = j.limits_deg {
                if !finite(&[lo, hi]) || lo >= hi {
                    return issue(p, format!("joint {}: limits_deg must be finite with lower < upper, got [{lo}, {hi}]", i + 1));
                }
                for v in [lo, hi] {
                    if let Some(m) = implausible_angle("limits_deg", v, crate::MAX_JOINT_LIMIT_DEG)
                    {
                        return issue(p, format!("joint {}: {m}", i + 1));
                    }
                }
            }
        }
        if let Some(m) = self.lengths_in_metres() {
            return issue(Place::Joints, m);
        }
        if !self.tool.rpy_deg.is_none_or(|r| finite(&r)) {
            return issue(Place::Tool, "tool: rpy_deg must be finite numbers".into());
        }
        if let Some(m) = self
            .tool
            .rpy_deg
            .iter()
            .flatten()
            .find_map(|v| implausible_angle("rpy_deg", *v, crate::MAX_ANGLE_DEG))
        {
            return issue(Place::Tool, format!("tool: {m}"));
        }
        if !finite(&self.tool.xyz_mm) {
            return issue(Place::Tool, "tool: xyz_mm must be finite numbers".into());
        }
        if let Some(m) = self
            .tool
            .xyz_mm
            .iter()
            .find_map(|v| implausible_length("xyz_mm", *v))
        {
            return issue(Place::Tool, format!("tool: {m}"));
        }
        if self.tools.len() > MAX_TOOL_POINTS {
            return issue(
                Place::Tools(MAX_TOOL_POINTS),
                format!(
                    "{} [[tools]]: at most {MAX_TOOL_POINTS} reflectors per tool are supported",
                    self.tools.len()
                ),
            );
        }
        for (i, t) in self.tools.iter().enumerate() {
            let p = Place::Tools(i);
            let name_ok = !t.name.is_empty()
                && t.name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !name_ok {
                return issue(
                    p,
                    format!("tools: name `{}` must be letters, digits or `_`", t.name),
                );
            }
            if self.tools[..i].iter().any(|o| o.name == t.name) {
                return issue(p, format!("tools: name `{}` is given twice", t.name));
            }
            if !finite(&t.xyz_mm) {
                return issue(
                    p,
                    format!("tools `{}`: xyz_mm must be finite numbers", t.name),
                );
            }
            if let Some(m) = t
                .xyz_mm
                .iter()
                .find_map(|v| implausible_length("xyz_mm", *v))
            {
                return issue(p, format!("tools `{}`: {m}", t.name));
            }
        }
        if let Some(b) = &self.base {
            if !finite(&b.xyz_mm) || !finite(&b.rpy_deg) {
                return issue(
                    Place::Base,
                    "base: xyz_mm and rpy_deg must be finite numbers".into(),
                );
            }
            let bad = b
                .xyz_mm
                .iter()
                .find_map(|v| implausible_length("xyz_mm", *v))
                .or_else(|| {
                    b.rpy_deg
                        .iter()
                        .find_map(|v| implausible_angle("rpy_deg", *v, crate::MAX_ANGLE_DEG))
                });
            if let Some(m) = bad {
                return issue(Place::Base, format!("base: {m}"));
            }
        }
        let mut total = 0usize;
        let mut seen: Vec<(String, usize, u16)> = Vec::new();
        for (i, e) in self.effects.iter().enumerate() {
            let p = Place::Effect(i);
            let what = format!("effect `{}` on joint {}", e.kind, e.joint);
            let thermal = e.kind == THERMAL;
            if thermal {
                if e.joint != 0 {
                    return issue(
                        p,
                        format!("{what}: thermal-expansion acts on no joint: give joint = 0"),
                    );
                }
                if e.values.len() != 1 || !finite(&e.values) || e.values[0].abs() >= 1e-2 {
                    return issue(
                        p,
                        format!("{what}: expected 1 value [c], a finite expansion per kelvin below 1e-2 in magnitude (steel ≈ 1.2e-5)"),
                    );
                }
                if e.reference_c
                    .is_some_and(|t| !(t.is_finite() && t.abs() <= 1e3))
                {
                    return issue(
                        p,
                        format!("{what}: reference_c must be a temperature in °C"),
                    );
                }
            } else if e.reference_c.is_some() {
                return issue(
                    p,
                    format!("{what}: reference_c applies to thermal-expansion only"),
                );
            }
            if !thermal && (e.joint < 1 || e.joint > n) {
                return issue(p, format!("{what}: joint must be 1 to {n}"));
            }
            if !finite(&e.values) {
                return issue(p, format!("{what}: values must be finite numbers"));
            }
            if let Some(v) = e.values.iter().find(|v| v.abs() > crate::MAX_EFFECT_VALUE) {
                return issue(
                    p,
                    format!(
                        "{what}: value {} is implausible (effect values are at most {} in magnitude: a scale, radians, or radians per metre)",
                        crate::number_text(*v),
                        crate::MAX_EFFECT_VALUE
                    ),
                );
            }
            if e.kind == "joint-table" && e.values.len() > crate::MAX_TABLE_KNOTS {
                return issue(
                    p,
                    format!("{what}: at most {} knots", crate::MAX_TABLE_KNOTS),
                );
            }
            if e.order.is_some_and(|o| o > crate::MAX_CYCLIC_ORDER) {
                return issue(
                    p,
                    format!("{what}: order must be at most {}", crate::MAX_CYCLIC_ORDER),
                );
            }
            let count_ok = match e.kind.as_str() {
                "joint-scale" | "joint-compliance" => e.values.len() == 1,
                "joint-cyclic" => e.values.len() == 2,
                "joint-table" => e.values.len() >= 2,
                AXIS_TILT => e.values.len() <= 1,
                THERMAL => e.values.len() == 1,
                other => {
                    return issue(
                        p,
                        format!(
                            "unknown effect kind `{other}` (expected joint-scale, joint-cyclic, joint-compliance, joint-table, axis-tilt or thermal-expansion)"
                        ),
                    )
                }
            };
            if !count_ok {
                let want = match e.kind.as_str() {
                    "joint-cyclic" => "2 values [a, b]",
                    "joint-table" => "at least 2 knot values",
                    AXIS_TILT => "no value or 1 value [beta]",
                    _ => "1 value",
                };
                return issue(
                    p,
                    format!("{what}: expected {want}, got {}", e.values.len()),
                );
            }
            if e.order.is_some() && e.kind != "joint-cyclic" {
                return issue(p, format!("{what}: `order` applies to joint-cyclic only"));
            }
            if e.order == Some(0) {
                return issue(p, format!("{what}: order must be at least 1"));
            }
            if e.kind == "joint-table" {
                match e.step_deg {
                    Some(s)
                        if s.is_finite() && (crate::MIN_TABLE_STEP_DEG..=360.0).contains(&s) => {}
                    Some(s) => {
                        return issue(
                            p,
                            format!(
                                "{what}: step_deg must be {} to 360 degrees, got {s}",
                                crate::MIN_TABLE_STEP_DEG
                            ),
                        )
                    }
                    None => {
                        return issue(p, format!("{what}: step_deg is required for joint-table"))
                    }
                }
                if e.start_deg
                    .is_some_and(|s| !(s.is_finite() && s.abs() <= crate::MAX_JOINT_LIMIT_DEG))
                {
                    return issue(
                        p,
                        format!(
                            "{what}: start_deg must be a finite angle within ±{} degrees",
                            crate::MAX_JOINT_LIMIT_DEG
                        ),
                    );
                }
            } else if e.step_deg.is_some() || e.start_deg.is_some() {
                return issue(
                    p,
                    format!("{what}: step_deg/start_deg apply to joint-table only"),
                );
            }
            let key = (e.kind.clone(), e.joint, e.order.unwrap_or(1));
            if seen.contains(&key) {
                return issue(p, format!("{what}: the same effect is given twice"));
            }
            seen.push(key);
            if e.kind != AXIS_TILT {
                total += e.values.len();
            }
        }
        for (i, c) in self.couplings.iter().enumerate() {
            let p = Place::Coupling(i);
            let what = format!("coupling of joint {} from joint {}", c.joint, c.from);
            if i >= MAX_COUPLINGS {
                return issue(
                    p,
                    format!("{what}: at most {MAX_COUPLINGS} couplings are supported"),
                );
            }
            if c.joint < 1 || c.joint > n || c.from < 1 || c.from > n {
                return issue(p, format!("{what}: joint and from must be 1 to {n}"));
            }
            if c.joint == c.from {
                return issue(p, format!("{what}: a joint cannot be coupled to itself"));
            }
            if !(c.ratio.is_finite() && c.ratio.abs() <= crate::MAX_COUPLING_RATIO) {
                return issue(
                    p,
                    format!(
                        "{what}: ratio must be a finite number within ±{}, got {}",
                        crate::MAX_COUPLING_RATIO,
                        c.ratio
                    ),
                );
            }
            let earlier = &self.couplings[..i];
            if earlier.iter().any(|o| o.joint == c.joint) {
                return issue(p, format!("{what}: joint {} is coupled twice", c.joint));
            }
            let chained = self
                .couplings
                .iter()
                .enumerate()
                .any(|(k, o)| k != i && (o.joint == c.from || o.from == c.joint));
            if chained {
                return issue(
                    p,
                    format!("{what}: chained couplings are not supported (a coupled joint cannot be the `from` of another coupling)"),
                );
            }
        }
        let n_eff = self.effects.iter().filter(|e| e.kind != AXIS_TILT).count();
        if n_eff > MAX_EFFECTS || total > VCAP {
            return issue(
                Place::File,
                format!("too many effects: {n_eff} effects with {total} values (at most {MAX_EFFECTS} and {VCAP})"),
            );
        }
        Ok(())
    }

    /// Parses and validates the text of a robot file; `origin` names it in error messages.
    pub fn parse(text: &str, origin: &str) -> anyhow::Result<RobotFile> {
        let at = |span: Option<Range<usize>>| match span {
            Some(s) => {
                let (l, c) = line_column(text, s.start);
                format!("{origin}:{l}:{c}")
            }
            None => format!("{origin}:1:1"),
        };
        let raw: RawFile = toml::from_str(text).map_err(|e| {
            refused(format!(
                "{}: {}",
                at(e.span()),
                e.message().trim().replace('\n', " ")
            ))
        })?;
        let tool = match (&raw.tool, raw.tools.first()) {
            (Some(_), Some(t)) => {
                return Err(refused(format!(
                    "{}: give either [tool] or [[tools]], not both",
                    at(Some(t.span()))
                )))
            }
            (None, None) => {
                return Err(refused(format!(
                    "{}: missing [tool] (or [[tools]] for several reflectors)",
                    at(None)
                )))
            }
            (Some(t), None) => {
                let raw = t.get_ref();
                let (xyz_mm, unknown) = match &raw.xyz_mm {
                    Some(RawXyz::Point(p)) => (*p, false),
                    None => ([0.0; 3], true),
                    Some(RawXyz::Word(w)) if w == "unknown" => ([0.0; 3], true),
                    Some(RawXyz::Word(w)) => {
                        return Err(refused(format!(
                            "{}: [tool] xyz_mm = \"{w}\": give the point as [x, y, z] in mm, \
                             or \"unknown\" to have it estimated from the data",
                            at(Some(t.span()))
                        )))
                    }
                };
                ToolSpec {
                    xyz_mm,
                    rpy_deg: raw.rpy_deg,
                    unknown,
                }
            }
            (None, Some(t)) => ToolSpec {
                xyz_mm: t.get_ref().xyz_mm,
                rpy_deg: None,
                unknown: false,
            },
        };
        let file = RobotFile {
            name: raw.name,
            joints: raw
                .joints
                .get_ref()
                .iter()
                .map(|j| j.get_ref().clone())
                .collect(),
            tool,
            tools: raw.tools.iter().map(|t| t.get_ref().clone()).collect(),
            base: raw.base.as_ref().map(|b| b.get_ref().clone()),
            effects: raw.effects.iter().map(|e| e.get_ref().clone()).collect(),
            couplings: raw.couplings.iter().map(|c| c.get_ref().clone()).collect(),
            prior: raw.prior,
        };
        if let Some(p) = &file.prior {
            p.check(&format!("{} [prior]", at(None)))?;
        }
        if let Err(issue) = file.validate() {
            let span = match issue.place {
                Place::File => None,
                Place::Joints => Some(raw.joints.span()),
                Place::Joint(i) => raw.joints.get_ref().get(i).map(|j| j.span()),
                Place::Tool => raw
                    .tool
                    .as_ref()
                    .map(|t| t.span())
                    .or_else(|| raw.tools.first().map(|t| t.span())),
                Place::Tools(i) => raw.tools.get(i).map(|t| t.span()),
                Place::Base => raw.base.as_ref().map(|b| b.span()),
                Place::Effect(i) => raw.effects.get(i).map(|e| e.span()),
                Place::Coupling(i) => raw.couplings.get(i).map(|c| c.span()),
            };
            return Err(refused(format!("{}: {}", at(span), issue.message)));
        }
        Ok(file)
    }

    /// Reads, parses and validates a robot file.
    pub fn load(path: &Path) -> anyhow::Result<RobotFile> {
        let origin = path.display().to_string();
        let bytes = super::read_limited(path, super::MAX_SMALL_FILE, "a robot file")?;
        let text = match std::str::from_utf8(&bytes) {
            Ok(t) => t,
            Err(e) => {
                let valid = std::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or("");
                let (l, c) = line_column(valid, valid.len());
                return Err(refused(format!("{origin}:{l}:{c}: not UTF-8 text")));
            }
        };
        Self::parse(text, &origin)
    }

    /// The TOML text of this file.
    pub fn to_toml(&self) -> anyhow::Result<String> {
        let out = OutFile {
            name: &self.name,
            joints: &self.joints,
            tool: self.tools.is_empty().then(|| OutTool::of(&self.tool)),
            tools: &self.tools,
            base: self.base.as_ref(),
            effects: &self.effects,
            couplings: &self.couplings,
            prior: self.prior.as_ref(),
        };
        toml::to_string(&out).context("cannot format the robot file")
    }

    /// Names of the measured points: the `[[tools]]` names, or none for one `[tool]`.
    pub fn tool_names(&self) -> Vec<String> {
        self.tools.iter().map(|t| t.name.clone()).collect()
    }

    /// This file's tool names put on a model file written from a robot with as many points
    /// (identify's output keeps the input's `[[tools]]`).
    pub fn with_tool_names(mut self, names: &[String]) -> RobotFile {
        if names.len() > 1 && names.len() == self.tools.len().max(1) {
            if self.tools.is_empty() {
                self.tools = vec![NamedToolSpec {
                    name: names[0].clone(),
                    xyz_mm: self.tool.xyz_mm,
                }];
            }
            for (t, n) in self.tools.iter_mut().zip(names) {
                t.name = n.clone();
            }
        }
        self
    }

    /// Writes the file atomically: a reader (or a crash) sees the old file or the whole new one.
    pub fn save(&self, path: &Path) -> anyhow::Result<()> {
        let text = self.to_toml()?;
        crate::output::atomic::write_atomic(path, text.as_bytes())
            .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))
    }

    /// The library model (base = identity when the file has no `[base]`; see [`Self::base_known`]).
    pub fn to_robot<const N: usize>(&self) -> anyhow::Result<Robot<f64, N, VCAP>> {
        self.validate().map_err(|i| anyhow!("{}", i.message))?;
        if self.joints.len() != N {
            return Err(anyhow!(
                "the robot file has {} joints, expected {N}",
                self.joints.len()
            ));
        }
        let mut tilt = [None; N];
        for e in self.effects.iter().filter(|e| e.kind == AXIS_TILT) {
            if let Some(v) = e.values.first() {
                tilt[e.joint - 1] = Some(*v);
            }
        }
        let joints: [Joint<f64>; N] = std::array::from_fn(|i| {
            let j = &self.joints[i];
            let [lo, hi] = j.limits_deg.unwrap_or([-180.0, 180.0]);
            Joint {
                alpha: j.alpha_deg.to_radians(),
                a: j.a_mm,
                theta: j.theta_deg.to_radians(),
                d: j.d_mm,
                beta: tilt[i].unwrap_or_else(|| j.beta_deg.unwrap_or(0.0).to_radians()),
                lower: lo.to_radians(),
                upper: hi.to_radians(),
            }
        });
        let base = match &self.base {
            Some(b) => Frame::from_xyz_rpy(b.xyz_mm, b.rpy_deg.map(f64::to_radians)),
            None => Frame::identity(),
        };
        let tool = Vector3::from(self.tool.xyz_mm);
        let mut robot =
            Robot::new(base, joints, tool).map_err(|e| anyhow!("invalid robot: {e:?}"))?;
        for (k, t) in self.tools.iter().enumerate().skip(1) {
            robot
                .set_tool_point(k, Vector3::from(t.xyz_mm))
                .map_err(|e| anyhow!("tools `{}`: {e:?}", t.name))?;
        }
        if let Some(rpy) = self.tool.rpy_deg {
            robot
                .set_tool_axes(Frame::from_xyz_rpy([0.0; 3], rpy.map(f64::to_radians)))
                .map_err(|e| anyhow!("tool rpy_deg: {e:?}"))?;
        }
        for e in self.effects.iter().filter(|e| e.kind != AXIS_TILT) {
            let kind = EffectKind::from_id(&e.kind)
                .ok_or_else(|| anyhow!("unknown effect kind `{}`", e.kind))?;
            let j = e.joint.saturating_sub(1);
            let (start, step) = if kind == EffectKind::Thermal {
                (e.reference_c.unwrap_or(DEFAULT_REFERENCE_C), 0.0)
            } else if kind == EffectKind::Table {
                let start = e.start_deg.unwrap_or(self.limits_deg(j)[0]);
                (start.to_radians(), e.step_deg.unwrap_or(0.0).to_radians())
            } else {
                (0.0, 0.0)
            };
            robot
                .effects_mut()
                .push(kind, j, N, e.order.unwrap_or(1), start, step, &e.values)
                .map_err(|err| anyhow!("effect `{}` on joint {}: {err:?}", e.kind, e.joint))?;
        }
        for c in &self.couplings {
            robot
                .set_coupling(c.joint - 1, c.from - 1, c.ratio)
                .map_err(|err| {
                    anyhow!(
                        "coupling of joint {} from joint {}: {err:?}",
                        c.joint,
                        c.from
                    )
                })?;
        }
        Ok(robot)
    }

    /// The file of a library model. `base_known` = write `[base]`; `tilt` (0-based joints) are
    /// written as `axis-tilt` effects carrying their `beta` in rad, so a re-identification
    /// knows to free them. Angles are written with [`deg_short`], so they read back exactly.
    /// The robot's couplings become `[[couplings]]`.
    pub fn from_robot<const N: usize, const V: usize>(
        name: &str,
        robot: &Robot<f64, N, V>,
        base_known: bool,
        tilt: &[usize],
    ) -> RobotFile {
        let joints = robot
            .joints()
            .iter()
            .map(|j| JointSpec {
                alpha_deg: deg_short(j.alpha),
                a_mm: j.a,
                theta_deg: deg_short(j.theta),
                d_mm: j.d,
                beta_deg: if j.beta != 0.0 {
                    Some(deg_short(j.beta))
                } else {
                    None
                },
                limits_deg: Some([deg_short(j.lower), deg_short(j.upper)]),
            })
            .collect();
        let base = base_known.then(|| {
            let b = robot.base();
            BaseSpec {
                xyz_mm: [b.o.x, b.o.y, b.o.z],
                rpy_deg: rpy_deg_short(b),
            }
        });
        let mut effects: Vec<EffectSpec> = Vec::new();
        for (i, e) in robot.effects().iter().enumerate() {
            let table = e.kind == EffectKind::Table;
            let thermal = e.kind == EffectKind::Thermal;
            effects.push(EffectSpec {
                kind: e.kind.id().to_string(),
                joint: if thermal { 0 } else { e.joint as usize + 1 },
                reference_c: thermal.then_some(e.start),
                values: robot.effects().values_of(i).to_vec(),
                order: (e.kind == EffectKind::Cyclic).then_some(e.order),
                step_deg: table.then(|| deg_short(e.step)),
                start_deg: table.then(|| deg_short(e.start)),
            });
        }
        let mut tilt: Vec<usize> = tilt.iter().copied().filter(|j| *j < N).collect();
        tilt.sort_unstable();
        tilt.dedup();
        for j in tilt {
            effects.push(EffectSpec {
                kind: AXIS_TILT.to_string(),
                joint: j + 1,
                values: vec![robot.joints()[j].beta],
                order: None,
                step_deg: None,
                start_deg: None,
                reference_c: None,
            });
        }
        let points: Vec<[f64; 3]> = (0..robot.tool_point_count())
            .filter_map(|k| robot.tool_point(k).map(|p| [p.x, p.y, p.z]))
            .collect();
        // Points beyond the first are named `p2`, `p3`, … unless the caller names them
        // ([`RobotFile::with_tool_names`]).
        let tools = if points.len() > 1 {
            points
                .iter()
                .enumerate()
                .map(|(k, p)| NamedToolSpec {
                    name: format!("p{}", k + 1),
                    xyz_mm: *p,
                })
                .collect()
        } else {
            Vec::new()
        };
        RobotFile {
            name: name.to_string(),
            joints,
            tool: ToolSpec {
                xyz_mm: [robot.tool().x, robot.tool().y, robot.tool().z],
                rpy_deg: (!robot.tool_axes_identity()).then(|| rpy_deg_short(robot.tool_axes())),
                unknown: false,
            },
            tools,
            base,
            effects,
            couplings: robot
                .couplings()
                .iter()
                .map(|(joint, from, ratio)| CouplingSpec {
                    joint: joint + 1,
                    from: from + 1,
                    ratio,
                })
                .collect(),
            prior: None,
        }
    }
}

/// Loads a robot file and builds the `N`-joint model; also says whether `[base]` was given.
pub fn load_robot<const N: usize>(path: &Path) -> anyhow::Result<(RobotFile, Robot<f64, N, VCAP>)> {
    let file = RobotFile::load(path)?;
    let robot = file
        .to_robot::<N>()
        .map_err(|e| refused(format!("{}: {e}", path.display())))?;
    Ok((file, robot))
}
