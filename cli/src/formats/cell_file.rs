//! The measurement-cell file (TOML) of `kinecal plan`, in the robot base frame:
//!
//! ```toml
//! [tracker]
//! xyz_mm = [900.0, -2600.0, 300.0]
//! max_incidence_deg = 30.0      # optional, default 30
//! beam_radius_mm = 5.0          # optional, default 5: the beam's capsule
//!
//! [floor]                       # optional
//! z_mm = -450.0
//!
//! [[link_capsules]]             # zero or more
//! frame = 2                     # 0 = robot base, i = joint i's frame (moves with joint i)
//! a_mm = [0.0, 0.0, 0.0]
//! b_mm = [780.0, 0.0, 0.0]
//! radius_mm = 130.0
//!
//! [[obstacles]]                 # zero or more, robot base frame
//! a_mm = [1900.0, -2000.0, 100.0]
//! b_mm = [1900.0, 2000.0, 100.0]
//! radius_mm = 800.0
//! ```
//!
//! Errors are one line `FILE:LINE:COLUMN: what is wrong`.

use crate::formats::robot_file::line_column;
use anyhow::anyhow;
use kinecal::planning::capsule::Capsule;
use kinecal::planning::cell::{Scene, Tracker};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// Capacity of host scenes: link capsules.
pub const LINK_CAPSULES: usize = 64;
/// Capacity of host scenes: obstacles.
pub const OBSTACLES: usize = 64;
/// The library scene the host uses.
pub type HostScene = Scene<f64, LINK_CAPSULES, OBSTACLES>;

fn default_incidence() -> f64 {
    30.0
}
fn default_beam() -> f64 {
    5.0
}

/// `[tracker]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerSpec {
    pub xyz_mm: [f64; 3],
    #[serde(default = "default_incidence")]
    pub max_incidence_deg: f64,
    #[serde(default = "default_beam")]
    pub beam_radius_mm: f64,
}

/// `[floor]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorSpec {
    pub z_mm: f64,
}

/// One `[[link_capsules]]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkCapsuleSpec {
    pub frame: usize,
    pub a_mm: [f64; 3],
    pub b_mm: [f64; 3],
    pub radius_mm: f64,
}

/// One `[[obstacles]]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    pub a_mm: [f64; 3],
    pub b_mm: [f64; 3],
    pub radius_mm: f64,
}

/// A whole scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub tracker: TrackerSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub floor: Option<FloorSpec>,
    #[serde(default)]
    pub link_capsules: Vec<LinkCapsuleSpec>,
    #[serde(default)]
    pub obstacles: Vec<ObstacleSpec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    tracker: Spanned<TrackerSpec>,
    #[serde(default)]
    floor: Option<Spanned<FloorSpec>>,
    #[serde(default)]
    link_capsules: Vec<Spanned<LinkCapsuleSpec>>,
    #[serde(default)]
    obstacles: Vec<Spanned<ObstacleSpec>>,
}

fn finite(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

fn capsule(a: [f64; 3], b: [f64; 3], r: f64) -> Capsule<f64> {
    Capsule::new(Vector3::from(a), Vector3::from(b), r)
}

impl SceneFile {
    /// Parses and validates the text of a scene for a robot with `joints` joints; `origin`
    /// names the file in error messages.
    /// Every error is refused input (exit status 2).
    pub fn parse(text: &str, origin: &str, joints: usize) -> anyhow::Result<SceneFile> {
        Self::parse_checked(text, origin, joints).map_err(|e| crate::refused(format!("{e:#}")))
    }

    fn parse_checked(text: &str, origin: &str, joints: usize) -> anyhow::Result<SceneFile> {
        let at = |span: Option<Range<usize>>| {
            let (l, c) = span.map_or((1, 1), |s| line_column(text, s.start));
            format!("{origin}:{l}:{c}")
        };
        let raw: RawScene = toml::from_str(text).map_err(|e| {
            anyhow!(
                "{}: {}",
                at(e.span()),
                e.message().trim().replace('\n', " ")
            )
        })?;
        let t = raw.tracker.get_ref();
        let bad = |span: Range<usize>, msg: String| Err(anyhow!("{}: {msg}", at(Some(span))));
        if !finite(&t.xyz_mm) || !finite(&[t.max_incidence_deg, t.beam_radius_mm]) {
            return bad(raw.tracker.span(), "tracker: numbers must be finite".into());
        }
        if !(t.max_incidence_deg > 0.0 && t.max_incidence_deg <= 180.0) {
            return bad(
                raw.tracker.span(),
                format!(
                    "tracker: max_incidence_deg must be in (0, 180], got {}",
                    t.max_incidence_deg
                ),
            );
        }
        if t.beam_radius_mm < 0.0 {
            return bad(
                raw.tracker.span(),
                format!(
                    "tracker: beam_radius_mm must be ≥ 0, got {}",
                    t.beam_radius_mm
                ),
            );
        }
        if let Some(f) = &raw.floor {
            if !f.get_ref().z_mm.is_finite() {
                return bad(f.span(), "floor: z_mm must be finite".into());
            }
        }
        if raw.link_capsules.len() > LINK_CAPSULES || raw.obstacles.len() > OBSTACLES {
            return Err(anyhow!(
                "{}: too many capsules ({} link capsules, {} obstacles; at most {LINK_CAPSULES} and {OBSTACLES})",
                at(None),
                raw.link_capsules.len(),
                raw.obstacles.len()
            ));
        }
        for (i, c) in raw.link_capsules.iter().enumerate() {
            let s = c.get_ref();
            if s.frame > joints {
                return bad(
                    c.span(),
                    format!(
                        "link_capsules[{}]: frame {} does not exist (0 to {joints})",
                        i + 1,
                        s.frame
                    ),
                );
            }
            if !(finite(&s.a_mm)
                && finite(&s.b_mm)
                && s.radius_mm.is_finite()
                && s.radius_mm >= 0.0)
            {
                return bad(
                    c.span(),
                    format!(
                        "link_capsules[{}]: end points must be finite and radius_mm ≥ 0",
                        i + 1
                    ),
                );
            }
        }
        for (i, c) in raw.obstacles.iter().enumerate() {
            let s = c.get_ref();
            if !(finite(&s.a_mm)
                && finite(&s.b_mm)
                && s.radius_mm.is_finite()
                && s.radius_mm >= 0.0)
            {
                return bad(
                    c.span(),
                    format!(
                        "obstacles[{}]: end points must be finite and radius_mm ≥ 0",
                        i + 1
                    ),
                );
            }
        }
        Ok(SceneFile {
            tracker: t.clone(),
            floor: raw.floor.map(|f| f.into_inner()),
            link_capsules: raw
                .link_capsules
                .into_iter()
                .map(|c| c.into_inner())
                .collect(),
            obstacles: raw.obstacles.into_iter().map(|c| c.into_inner()).collect(),
        })
    }

    /// Reads and validates a scene file for a robot with `joints` joints.
    pub fn load(path: &Path, joints: usize) -> anyhow::Result<SceneFile> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| crate::refused(crate::formats::cannot_read(&origin, &e)))?;
        Self::parse(&text, &origin, joints)
    }

    /// The TOML text.
    pub fn to_toml(&self) -> anyhow::Result<String> {
        toml::to_string(self).map_err(|e| anyhow!("cannot format the scene: {e}"))
    }

    /// The library scene.
    /// Errors are refused input (exit status 2): the file describes no valid cell.
    pub fn to_scene(&self) -> anyhow::Result<HostScene> {
        self.build_scene()
            .map_err(|e| crate::refused(format!("{e:#}")))
    }

    fn build_scene(&self) -> anyhow::Result<HostScene> {
        let t = &self.tracker;
        let tracker = Tracker {
            position: Vector3::from(t.xyz_mm),
            max_incidence: t.max_incidence_deg.to_radians(),
            beam_radius: t.beam_radius_mm,
        };
        let mut scene = HostScene::new(tracker, self.floor.as_ref().map(|f| f.z_mm))
            .map_err(|e| anyhow!("invalid scene: {e:?}"))?;
        for (i, c) in self.link_capsules.iter().enumerate() {
            let frame = u8::try_from(c.frame)
                .map_err(|_| anyhow!("link_capsules[{}]: frame out of range", i + 1))?;
            scene
                .add_link_capsule(frame, capsule(c.a_mm, c.b_mm, c.radius_mm))
                .map_err(|e| anyhow!("link_capsules[{}]: {e:?}", i + 1))?;
        }
        for (i, c) in self.obstacles.iter().enumerate() {
            scene
                .add_obstacle(capsule(c.a_mm, c.b_mm, c.radius_mm))
                .map_err(|e| anyhow!("obstacles[{}]: {e:?}", i + 1))?;
        }
        Ok(scene)
    }
}
