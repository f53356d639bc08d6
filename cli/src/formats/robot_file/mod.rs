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

mod conversion;
mod degrees;
mod validate;

pub use conversion::load_robot;
pub use degrees::{deg_exact, deg_short, rpy_deg_short};
pub use validate::METRES_SUSPECT_MM;

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

impl RobotFile {
    /// Number of joints (rows).
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// True when the file has a `[base]` table (otherwise the base must be estimated).
    pub fn base_known(&self) -> bool {
        self.base.is_some()
    }

    /// The reference temperature T0 (°C) of the file's thermal expansion, `None` without one:
    /// what the expansion is evaluated at where no temperature is given.
    pub fn thermal_reference_c(&self) -> Option<f64> {
        let e = self.effects.iter().find(|e| e.kind == THERMAL)?;
        Some(e.reference_c.unwrap_or(DEFAULT_REFERENCE_C))
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
}
