//! The URDF elements kinecal reads: links, joints (type, parent, child, origin, axis, limits,
//! mimic) and where each joint's `<origin>` is in the text, parsed with `roxmltree`.
//!
//! Lengths stay in metres and angles in radians here, as the file has them.

use crate::refused;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::collections::{HashMap, HashSet};
use std::ops::Range;

/// Deepest element nesting accepted (a URDF nests a few levels; the XML parser recurses per
/// level, so a file nested thousands deep would overflow the stack).
const MAX_DEPTH: usize = 1000;

/// Most attributes on one element (the XML parser checks each new attribute against the
/// element's others: quadratic in their number).
const MAX_ATTRIBUTES: usize = 1000;

/// Most XML nodes in a file (a large robot description has a few tens of thousands).
const MAX_NODES: u32 = 5_000_000;

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
    /// Index into `joints` of the joint whose child is a link, per link (each link has at
    /// most one: checked by [`Urdf::parse`]).
    parent_of: HashMap<String, usize>,
    /// Indices into `joints` of the joints whose parent is a link, in file order.
    children_of: HashMap<String, Vec<usize>>,
}

/// Refuses, before the XML parser sees it, a text nested deeper than [`MAX_DEPTH`] or with an
/// element of more than [`MAX_ATTRIBUTES`] attributes. A linear scan of the tags (comments,
/// CDATA, processing instructions and declarations skipped; quotes respected); the parser
/// still judges well-formedness.
fn prescan(text: &str, path: &str) -> anyhow::Result<()> {
    let b = text.as_bytes();
    let skip_to = |from: usize, pat: &str| -> usize {
        text[from..]
            .find(pat)
            .map_or(b.len(), |k| from + k + pat.len())
    };
    let mut depth = 0usize;
    let mut i = 0usize;
    while let Some(k) = text[i..].find('<') {
        i += k;
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i = skip_to(i + 4, "-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = skip_to(i + 9, "]]>");
        } else if rest.starts_with(b"<?") {
            i = skip_to(i + 2, "?>");
        } else if rest.starts_with(b"<!") {
            i = skip_to(i + 2, ">");
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            i = skip_to(i + 2, ">");
        } else {
            let mut j = i + 1;
            let mut quote = None;
            let mut attributes = 0usize;
            while j < b.len() {
                let c = b[j];
                match quote {
                    Some(q) if c == q => quote = None,
                    Some(_) => {}
                    None => match c {
                        b'"' | b'\'' => quote = Some(c),
                        b'=' => attributes += 1,
                        b'>' => break,
                        _ => {}
                    },
                }
                j += 1;
            }
            if attributes > MAX_ATTRIBUTES {
                crate::refuse!(
                    "{path}: an element with more than {MAX_ATTRIBUTES} attributes: not a URDF \
                     (pass the robot's URDF file)"
                );
            }
            if b[j - 1] != b'/' {
                depth += 1;
                if depth > MAX_DEPTH {
                    crate::refuse!(
                        "{path}: elements nested more than {MAX_DEPTH} deep: not a URDF (a \
                         robot description nests a few levels; pass the robot's URDF file)"
                    );
                }
            }
            i = (j + 1).min(b.len());
        }
    }
    Ok(())
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

/// The joint tree's indices (parent joint per link, child joints per link), after refusing
/// what makes it no tree: a link or joint name declared twice, a joint naming a link the file
/// does not declare, a link that is the child of several joints, joints that form a cycle.
#[allow(clippy::type_complexity)]
fn tree(
    links: &[String],
    joints: &[UrdfJoint],
    path: &str,
) -> anyhow::Result<(HashMap<String, usize>, HashMap<String, Vec<usize>>)> {
    let mut declared = HashSet::new();
    for l in links {
        if !declared.insert(l.as_str()) {
            crate::refuse!(
                "{path}: link '{l}' is declared twice: link names must be unique; fix the file"
            );
        }
    }
    let mut names = HashSet::new();
    for j in joints {
        if !names.insert(j.name.as_str()) {
            crate::refuse!(
                "{path}: joint '{}' is declared twice: joint names must be unique; fix the file",
                j.name
            );
        }
    }
    let mut parent_of: HashMap<String, usize> = HashMap::new();
    let mut children_of: HashMap<String, Vec<usize>> = HashMap::new();
    for (k, j) in joints.iter().enumerate() {
        for (role, l) in [("parent", &j.parent), ("child", &j.child)] {
            if !declared.contains(l.as_str()) {
                crate::refuse!(
                    "{path}: joint '{}' has {role} link '{l}', which the file does not declare \
                     (no <link name=\"{l}\">): fix the link name",
                    j.name
                );
            }
        }
        if let Some(&other) = parent_of.get(&j.child) {
            crate::refuse!(
                "{path}: link '{}' has several parents (joints '{}' and '{}'): a URDF is a \
                 tree, each link the child of one joint at most; fix the file",
                j.child,
                joints[other].name,
                j.name
            );
        }
        parent_of.insert(j.child.clone(), k);
        children_of.entry(j.parent.clone()).or_default().push(k);
    }
    // With one parent per link, a cycle is a walk up the parents that comes back: each link is
    // visited once (`state`: 1 on the current walk, 2 known to reach a root).
    let mut state: HashMap<&str, u8> = HashMap::new();
    for start in links {
        let mut walk: Vec<&str> = Vec::new();
        let mut link = start.as_str();
        loop {
            match state.get(link) {
                Some(2) => break,
                Some(_) => {
                    crate::refuse!(
                        "{path}: the joints form a cycle through link '{link}' (joint '{}'): a \
                         URDF is a tree; fix the parent and child links",
                        joints[parent_of[link]].name
                    );
                }
                None => {}
            }
            state.insert(link, 1);
            walk.push(link);
            match parent_of.get(link) {
                Some(&k) => link = joints[k].parent.as_str(),
                None => break,
            }
        }
        for l in walk {
            state.insert(l, 2);
        }
    }
    Ok((parent_of, children_of))
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
        // The expanded file beside it, never over it (`arm.urdf` holding xacro: `arm.expanded.urdf`).
        let stem = path.strip_suffix(".xacro").unwrap_or(path);
        let out = match stem.strip_suffix(".urdf") {
            Some(base) if stem.len() < path.len() => format!("{base}.urdf"),
            Some(base) => format!("{base}.expanded.urdf"),
            None => format!("{stem}.urdf"),
        };
        let expand = format!("expand it first: xacro {path} > {out}");
        prescan(text, path)?;
        let options = roxmltree::ParsingOptions {
            nodes_limit: MAX_NODES,
            ..roxmltree::ParsingOptions::default()
        };
        let doc = roxmltree::Document::parse_with_options(text, options).map_err(|e| {
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
        let (parent_of, children_of) = tree(&links, &joints, path)?;
        Ok(Urdf {
            name: root.attribute("name").unwrap_or_default().to_string(),
            links,
            joints,
            robot_end,
            parent_of,
            children_of,
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
        // Beyond the library's angle bound an angle is no rotation in radians (1e308 would
        // lose every digit in the range reduction).
        if rpy
            .iter()
            .any(|a| a.abs() > kinecal::model::bounds::MAX_ANGLE)
        {
            crate::refuse!(
                "{path}: joint '{name}' origin rpy = {rpy:?} is no rotation in radians: give \
                 roll, pitch and yaw in radians"
            );
        }
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
                // Equal limits (both absent: 0 and 0) leave the range to the robot file's
                // default; crossed ones are a mistake.
                if lo > hi {
                    crate::refuse!(
                        "{path}: joint '{name}' limit lower = {lo} is above upper = {hi}: swap \
                         them"
                    );
                }
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
        self.parent_of.get(link).map(|&k| &self.joints[k])
    }

    /// The joints whose parent is `link`, in file order.
    pub fn child_joints<'a>(&'a self, link: &'a str) -> impl Iterator<Item = &'a UrdfJoint> + 'a {
        self.children_of
            .get(link)
            .into_iter()
            .flatten()
            .map(move |&k| &self.joints[k])
    }

    /// True when the file declares `<link name="link">`.
    pub fn has_link(&self, link: &str) -> bool {
        self.parent_of.contains_key(link)
            || self.children_of.contains_key(link)
            || self.links.iter().any(|l| l == link)
    }
}
