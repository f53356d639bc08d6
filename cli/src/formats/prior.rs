//! `[prior]` of a robot file and `--prior` of `identify`: the 1-σ of each kind of parameter's
//! change from its file value (docs/formats.md "The prior"), used by
//! `crate::calibration::prior`.
//!
//! ```toml
//! [prior]              # every key optional; 0 turns that kind's prior off
//! length_mm = 5.0      # a, d of the joint rows
//! angle_deg = 0.5      # alpha, theta, beta
//! tool_mm = 10.0       # tool point(s)
//! tool_deg = 2.0       # tool orientation (when [tool] rpy_deg is given)
//! base_mm = 10.0       # a [base] given in the file and estimated (--free base)
//! base_deg = 1.0
//! effect = 0.0         # effect values (rad), off by default
//! ```

use kinecal::model::param::Param;
use serde::{Deserialize, Serialize};

/// 1-σ of each kind of parameter's change (file units); `0` turns a kind's prior off.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorSpec {
    /// Link lengths and offsets of the joint rows (`a`, `d`), mm.
    #[serde(default = "defaults::length_mm")]
    pub length_mm: f64,
    /// Joint row angles (`alpha`, `theta`, `beta`), degrees.
    #[serde(default = "defaults::angle_deg")]
    pub angle_deg: f64,
    /// Tool point coordinates, mm (a tool written in the file is a measured or drawn value).
    #[serde(default = "defaults::tool_mm")]
    pub tool_mm: f64,
    /// Tool orientation, degrees (only when the file gives `[tool] rpy_deg`).
    #[serde(default = "defaults::tool_deg")]
    pub tool_deg: f64,
    /// Base position when the file gives `[base]` and it is estimated (`--free base`), mm.
    #[serde(default = "defaults::base_mm")]
    pub base_mm: f64,
    /// Base rotation in the same case, degrees.
    #[serde(default = "defaults::base_deg")]
    pub base_deg: f64,
    /// Effect values (rad, or per radian), when they start from the file's values; off by default.
    #[serde(default)]
    pub effect: f64,
}

/// The defaults: a well-built industrial arm's kinematic tolerances (links and offsets within a
/// millimetre or two, joint zeros and axis alignment within a few tenths of a degree), widened
/// to cover a nominal model taken from a datasheet or a URDF rather than from the robot's own
/// drawing: 5 mm, 0.5°; the tool point as a user measures it by hand, 10 mm and 2°; a base
/// written in the file, 10 mm and 1°.
mod defaults {
    pub fn length_mm() -> f64 {
        5.0
    }
    pub fn angle_deg() -> f64 {
        0.5
    }
    pub fn tool_mm() -> f64 {
        10.0
    }
    pub fn tool_deg() -> f64 {
        2.0
    }
    pub fn base_mm() -> f64 {
        10.0
    }
    pub fn base_deg() -> f64 {
        1.0
    }
}

impl Default for PriorSpec {
    fn default() -> Self {
        Self {
            length_mm: defaults::length_mm(),
            angle_deg: defaults::angle_deg(),
            tool_mm: defaults::tool_mm(),
            tool_deg: defaults::tool_deg(),
            base_mm: defaults::base_mm(),
            base_deg: defaults::base_deg(),
            effect: 0.0,
        }
    }
}

impl PriorSpec {
    /// No prior on anything (`--prior off`).
    pub fn off() -> Self {
        Self {
            length_mm: 0.0,
            angle_deg: 0.0,
            tool_mm: 0.0,
            tool_deg: 0.0,
            base_mm: 0.0,
            base_deg: 0.0,
            effect: 0.0,
        }
    }

    /// Refused (exit 2) when a σ is negative or not finite.
    pub fn check(&self, origin: &str) -> anyhow::Result<()> {
        for (k, v) in self.entries() {
            if !(v.is_finite() && v >= 0.0) {
                crate::refuse!(
                    "{origin}: prior {k} = {v}: give a 1-σ ≥ 0 (0 turns that kind's prior off)"
                );
            }
        }
        Ok(())
    }

    fn entries(&self) -> [(&'static str, f64); 7] {
        [
            ("length_mm", self.length_mm),
            ("angle_deg", self.angle_deg),
            ("tool_mm", self.tool_mm),
            ("tool_deg", self.tool_deg),
            ("base_mm", self.base_mm),
            ("base_deg", self.base_deg),
            ("effect", self.effect),
        ]
    }

    /// `--prior off` or `--prior KIND=SIGMA[,KIND=SIGMA…]` over `self` (the robot file's or
    /// the defaults).
    pub fn with_overrides(mut self, given: &[String]) -> anyhow::Result<Self> {
        for g in given {
            let g = g.trim();
            if g == "off" || g == "none" {
                self = Self::off();
                continue;
            }
            let parsed = g
                .split_once('=')
                .and_then(|(k, v)| Some((k.trim(), v.trim().parse::<f64>().ok()?)));
            let slot = parsed.and_then(|(k, v)| {
                let slot = match k {
                    "length_mm" => &mut self.length_mm,
                    "angle_deg" => &mut self.angle_deg,
                    "tool_mm" => &mut self.tool_mm,
                    "tool_deg" => &mut self.tool_deg,
                    "base_mm" => &mut self.base_mm,
                    "base_deg" => &mut self.base_deg,
                    "effect" => &mut self.effect,
                    _ => return None,
                };
                Some((slot, v))
            });
            match slot {
                Some((slot, v)) => *slot = v,
                None => crate::refuse!(
                    "--prior {g}: give off, or KIND=SIGMA with KIND one of length_mm, \
                     angle_deg, tool_mm, tool_deg, base_mm, base_deg, effect"
                ),
            }
        }
        self.check("--prior")?;
        Ok(self)
    }

    /// The 1-σ of parameter `p` in the library's units (mm, rad), `None` without a prior:
    /// its kind's is 0, or its start is not a file value (`free_start`).
    pub fn sigma(&self, p: Param, free_start: bool) -> Option<f64> {
        let deg = |v: f64| v.to_radians();
        let s = match p {
            Param::A(_) | Param::D(_) => self.length_mm,
            Param::Alpha(_) | Param::Theta(_) | Param::Beta(_) => deg(self.angle_deg),
            Param::ToolX | Param::ToolY | Param::ToolZ | Param::ToolPoint(..) => self.tool_mm,
            Param::ToolRx | Param::ToolRy | Param::ToolRz => deg(self.tool_deg),
            Param::BaseX | Param::BaseY | Param::BaseZ => self.base_mm,
            Param::BaseRx | Param::BaseRy | Param::BaseRz => deg(self.base_deg),
            Param::Effect(_) => self.effect,
        };
        (s > 0.0 && !free_start).then_some(s)
    }
}
