//! The URDF elements kinecal reads: links, joints (type, parent, child, origin, axis, limits,
//! mimic) and where each joint's `<origin>` is in the text, parsed with `roxmltree`.
//!
//! Lengths stay in metres and angles in radians here, as the file has them.

use crate::refused;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::ops::Range;

/// One `<joint>`.
#[derive(Clone, Debug)]
pub struct UrdfJoint {
    pub name: String,
    /// `revolute`, `continuous`, `prismatic`, `fixed`, `floating` or `planar`.
    pub kind: String,
    pub parent: String,
    pub child: String,
    /// `<origin xyz rpy>` (metres, radians; absent = zeros).
    pub xyz: [f64; 3],
    pub rpy: [f64; 3],
    /// `<axis xyz>` as written (default 1 0 0).
    pub axis: [f64; 3],
    /// `<limit lower upper>` (radians), when given.
    pub limits: Option<[f64; 2]>,
    /// Name of the joint this one mimics, when it has `<mimic>`.
    pub mimic: Option<String>,
    /// Byte range of the whole `<joint>` element, of its opening tag's `>` (for an inserted
    /// origin) and of the `<origin>` element with its `xyz`/`rpy` value ranges, when present.
    pub range: Range<usize>,
    pub tag_end: usize,
    pub origin: Option<OriginRanges>,
}

/// Where a joint's `<origin>` and its attribute values are in the text.
#[derive(Clone, Debug)]
pub struct OriginRanges {
    pub element: Range<usize>,
    pub xyz: Option<Range<usize>>,
    pub rpy: Option<Range<usize>>,
}

/// A parsed URDF: its name, its links in file order and its joints.
#[derive(Clone, Debug)]
pub struct Urdf {
    pub name: String,
    pub links: Vec<String>,
    pub joints: Vec<UrdfJoint>,
    /// Byte offset of the `</robot>` closing tag (where export appends the tool frame).
    pub robot_end: usize,
}

impl UrdfJoint {
    /// The joint's origin as a transform (parent link → joint frame at q = 0), metres.
    pub fn origin(&self) -> Isometry3<f64> {
        origin_transform(self.xyz, self.rpy)
    }

    /// The unit axis in the joint frame.
    pub fn unit_axis(&self) -> Vector3<f64> {
        Vector3::from(self.axis).normalize()
    }

    /// Revolute or continuous.
    pub fn is_revolute(&self) -> bool {
        self.kind == "revolute" || self.kind == "continuous"
    }
}

/// URDF `<origin xyz rpy>`: translation, then R = Rz(yaw)·Ry(pitch)·Rx(roll).
pub fn origin_transform(xyz: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// Roll, pitch, yaw of a rotation (R = Rz(yaw)·Ry(pitch)·Rx(roll)) that rebuild it to
/// rounding even next to pitch = ±90° (URDFs write `1.570796325`): roll from the last row,
/// then yaw from the second column of R·Rx(-roll) = Rz(yaw)·Ry(pitch), whose column is
/// (-sin yaw, cos yaw, 0), then pitch; each step is well conditioned, unlike the usual
/// formulas whose roll and yaw lose half the digits there.
pub fn rpy_of(q: &UnitQuaternion<f64>) -> [f64; 3] {
    let r = q.to_rotation_matrix().into_inner();
    let roll = if r[(2, 1)].abs() + r[(2, 2)].abs() > 1e-300 {
        r[(2, 1)].atan2(r[(2, 2)])
    } else {
        0.0
    };
    let m = r * nalgebra::Rotation3::from_euler_angles(-roll, 0.0, 0.0).into_inner();
    let yaw = (-m[(0, 1)]).atan2(m[(1, 1)]);
    let n = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, -yaw).into_inner() * m;
    let pitch = n[(0, 2)].atan2(n[(0, 0)]);
    [roll, pitch, yaw]
}

fn numbers(path: &str, what: &str, text: &str) -> anyhow::Result<[f64; 3]> {
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|t| t.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| refused(format!("{path}: {what} = \"{text}\" is not three numbers")))?;
    match <[f64; 3]>::try_from(v) {
        Ok(a) if a.iter().all(|x| x.is_finite()) => Ok(a),
        _ => Err(refused(format!(
            "{path}: {what} = \"{text}\" is not three finite numbers"
        ))),
    }
}

fn number(path: &str, what: &str, text: &str) -> anyhow::Result<f64> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(refused(format!(
            "{path}: {what} = \"{text}\" is not a number"
        ))),
    }
}

impl Urdf {
    /// Parses the text of a URDF file (`path` names it in messages). A file with `xacro:`
    /// elements is refused: it has to be expanded first.
    pub fn parse(text: &str, path: &str) -> anyhow::Result<Urdf> {
        let stem = path.strip_suffix(".xacro").unwrap_or(path);
        let stem = stem.strip_suffix(".urdf").unwrap_or(stem);
        let expand = format!("expand it first: xacro {stem}.urdf.xacro > {stem}.urdf");
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            if text.contains("<xacro:") || text.contains("${") {
                // An undeclared `xacro:` prefix is an XML error: still a xacro file.
                refused(format!("{path}: this is a xacro file ({e}); {expand}"))
            } else {
                refused(format!("{path}: not well-formed XML: {e}"))
            }
        })?;
        if let Some(x) = doc.descendants().find(|n| {
            n.is_element()
                && n.tag_name()
                    .namespace()
                    .is_some_and(|ns| ns.contains("xacro"))
        }) {
            crate::refuse!(
                "{path}: xacro element <xacro:{}> found: this is a xacro file; {expand}",
                x.tag_name().name()
            );
        }
        let root = doc.root_element();
        if root.tag_name().name() != "robot" {
            crate::refuse!(
                "{path}: the root element is <{}>, not <robot>",
                root.tag_name().name()
            );
        }
        let mut links = Vec::new();
        let mut joints = Vec::new();
        for n in root.children().filter(|n| n.is_element()) {
            match n.tag_name().name() {
                "link" => links.push(n.attribute("name").unwrap_or_default().to_string()),
                "joint" => joints.push(Self::joint(&n, path)?),
                _ => {}
            }
        }
        let robot_end = text[..root.range().end]
            .rfind("</robot")
            .unwrap_or(root.range().end);
        Ok(Urdf {
            name: root.attribute("name").unwrap_or_default().to_string(),
            links,
            joints,
            robot_end,
        })
    }

    fn joint(n: &roxmltree::Node, path: &str) -> anyhow::Result<UrdfJoint> {
        let name = n.attribute("name").unwrap_or_default().to_string();
        let what = |k: &str| format!("joint '{name}' {k}");
        let child_el = |tag: &str| {
            n.children()
                .find(|c| c.is_element() && c.tag_name().name() == tag)
        };
        let link_of = |tag: &str| -> anyhow::Result<String> {
            child_el(tag)
                .and_then(|c| c.attribute("link"))
                .map(str::to_string)
                .ok_or_else(|| refused(format!("{path}: joint '{name}' has no <{tag} link=…>")))
        };
        let origin = child_el("origin");
        let xyz = match origin.and_then(|o| o.attribute("xyz")) {
            Some(t) => numbers(path, &what("origin xyz"), t)?,
            None => [0.0; 3],
        };
        let rpy = match origin.and_then(|o| o.attribute("rpy")) {
            Some(t) => numbers(path, &what("origin rpy"), t)?,
            None => [0.0; 3],
        };
        let axis = match child_el("axis").and_then(|a| a.attribute("xyz")) {
            Some(t) => numbers(path, &what("axis xyz"), t)?,
            None => [1.0, 0.0, 0.0],
        };
        let kind = n.attribute("type").unwrap_or_default().to_string();
        if (kind == "revolute" || kind == "continuous") && Vector3::from(axis).norm() < 1e-9 {
            crate::refuse!("{path}: joint '{name}' has a zero axis");
        }
        let limits = match child_el("limit") {
            Some(l) if kind == "revolute" => {
                let lo = l
                    .attribute("lower")
                    .map_or(Ok(0.0), |t| number(path, &what("limit lower"), t))?;
                let hi = l
                    .attribute("upper")
                    .map_or(Ok(0.0), |t| number(path, &what("limit upper"), t))?;
                Some([lo, hi])
            }
            _ => None,
        };
        let attr_range = |o: &roxmltree::Node, k: &str| {
            o.attributes()
                .find(|a| a.name() == k)
                .map(|a| a.range_value())
        };
        let tag_end = match n.first_child() {
            Some(c) => c.range().start,
            None => n.range().end,
        };
        Ok(UrdfJoint {
            kind,
            parent: link_of("parent")?,
            child: link_of("child")?,
            xyz,
            rpy,
            axis,
            limits,
            mimic: child_el("mimic").map(|m| m.attribute("joint").unwrap_or_default().to_string()),
            range: n.range(),
            tag_end,
            origin: origin.map(|o| OriginRanges {
                element: o.range(),
                xyz: attr_range(&o, "xyz"),
                rpy: attr_range(&o, "rpy"),
            }),
            name,
        })
    }

    /// The joint whose child is `link`, if any.
    pub fn parent_joint(&self, link: &str) -> Option<&UrdfJoint> {
        self.joints.iter().find(|j| j.child == link)
    }

    /// The joints whose parent is `link`.
    pub fn child_joints<'a>(&'a self, link: &'a str) -> impl Iterator<Item = &'a UrdfJoint> + 'a {
        self.joints.iter().filter(move |j| j.parent == link)
    }
}
