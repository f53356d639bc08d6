//! The serial chain between a base link and a tip link of a URDF: which joints, in order,
//! and the refusals (prismatic, planar, floating or mimic joints in the chain, a branching
//! tree without a named tip, unknown links).

use super::parse::{Urdf, UrdfJoint};
use crate::refused;
use std::collections::HashMap;

/// The joints from the base link to the tip link, base first (fixed ones included: they are
/// folded into the neighbouring transforms by [`super::mdh`]).
#[derive(Clone, Debug)]
pub struct Chain<'a> {
    pub base: String,
    pub tip: String,
    pub joints: Vec<&'a UrdfJoint>,
}

impl Chain<'_> {
    /// The revolute (and continuous) joints of the chain, base first.
    pub fn revolute(&self) -> impl Iterator<Item = &UrdfJoint> + '_ {
        self.joints.iter().copied().filter(|j| j.is_revolute())
    }
}

/// Most joints of a robot file (docs/formats.md).
const MAX_JOINTS: usize = 8;

/// The root link: the one link that is no joint's child.
fn root_link(urdf: &Urdf, path: &str) -> anyhow::Result<String> {
    let mut roots: Vec<&str> = urdf
        .links
        .iter()
        .map(String::as_str)
        .filter(|l| urdf.parent_joint(l).is_none())
        .collect();
    roots.dedup();
    match roots.as_slice() {
        [one] => Ok(one.to_string()),
        [] => Err(refused(format!(
            "{path}: no root link (every link is a joint's child)"
        ))),
        many => Err(refused(format!(
            "{path}: several root links ({}); pass --base-link",
            many.join(", ")
        ))),
    }
}

/// Per link of the subtree below `base` (itself included): true when a joint below it is not
/// fixed. One pass over the subtree (the tree is checked acyclic by the parser).
fn moving_below<'a>(urdf: &'a Urdf, base: &'a str) -> HashMap<&'a str, bool> {
    let mut order: Vec<&str> = vec![base];
    let mut k = 0;
    while k < order.len() {
        let link = order[k];
        order.extend(urdf.child_joints(link).map(|j| j.child.as_str()));
        k += 1;
    }
    let mut moves: HashMap<&str, bool> = HashMap::with_capacity(order.len());
    for &link in order.iter().rev() {
        let m = urdf
            .child_joints(link)
            .any(|j| j.kind != "fixed" || moves.get(j.child.as_str()).copied().unwrap_or(false));
        moves.insert(link, m);
    }
    moves
}

/// The leaves of the subtree below `link`, in file order.
fn leaves(urdf: &Urdf, link: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![link];
    while let Some(l) = stack.pop() {
        let before = stack.len();
        stack.extend(urdf.child_joints(l).map(|j| j.child.as_str()));
        if stack.len() == before {
            out.push(l.to_string());
        } else {
            stack[before..].reverse();
        }
    }
    out
}

/// The default tip: below `base`, follow the one branch that still moves; the single leaf
/// after the last moving joint. A tree where two branches move, or with several leaves after
/// the last moving joint, is refused with the candidates named.
fn default_tip(urdf: &Urdf, base: &str, path: &str) -> anyhow::Result<String> {
    let moves = moving_below(urdf, base);
    let mut link = base.to_string();
    for _ in 0..=urdf.joints.len() {
        let moving: Vec<&UrdfJoint> = urdf
            .child_joints(&link)
            .filter(|j| j.kind != "fixed" || moves.get(j.child.as_str()) == Some(&true))
            .collect();
        match moving.as_slice() {
            [one] => link = one.child.clone(),
            [] => {
                let found = leaves(urdf, &link);
                return match found.as_slice() {
                    [one] => Ok(one.clone()),
                    many => Err(refused(format!(
                        "{path}: the chain from '{base}' ends in several links ({}); pass \
                         --tip-link with one of them",
                        many.join(", ")
                    ))),
                };
            }
            many => {
                let names: Vec<String> = many
                    .iter()
                    .map(|j| format!("joint '{}' to '{}'", j.name, j.child))
                    .collect();
                crate::refuse!(
                    "{path}: the chain branches at link '{link}' ({}); pass --tip-link to \
                     choose the branch",
                    names.join(", ")
                );
            }
        }
    }
    crate::refuse!("{path}: the joint tree from '{base}' is too deep or has a cycle")
}

/// The chain from `base` (default: the root link) to `tip` (default: see `default_tip`),
/// checked: every joint on it revolute, continuous or fixed, none mimicking another, at least
/// two and at most eight revolute joints, the tip rigidly after the last revolute joint.
pub fn find<'a>(
    urdf: &'a Urdf,
    base: Option<&str>,
    tip: Option<&str>,
    path: &str,
) -> anyhow::Result<Chain<'a>> {
    for (what, l) in [("--base-link", base), ("--tip-link", tip)] {
        if let Some(l) = l {
            if !urdf.has_link(l) {
                let mut known = urdf.links.clone();
                known.truncate(30);
                crate::refuse!(
                    "{path}: {what} '{l}' is not a link of the file (links: {})",
                    known.join(", ")
                );
            }
        }
    }
    let base = match base {
        Some(b) => b.to_string(),
        None => root_link(urdf, path)?,
    };
    let tip = match tip {
        Some(t) => t.to_string(),
        None => default_tip(urdf, &base, path)?,
    };
    let mut joints = Vec::new();
    let mut link = tip.clone();
    while link != base {
        let Some(j) = urdf.parent_joint(&link) else {
            crate::refuse!(
                "{path}: link '{tip}' is not below link '{base}'; check --base-link and --tip-link"
            );
        };
        if joints.len() > urdf.joints.len() {
            crate::refuse!("{path}: the joint tree has a cycle at link '{link}'");
        }
        joints.push(j);
        link = j.parent.clone();
    }
    joints.reverse();
    for j in &joints {
        if let Some(m) = &j.mimic {
            crate::refuse!(
                "{path}: joint '{}' mimics joint '{m}': a chain with mimic joints cannot be \
                 calibrated as a serial arm; choose --base-link/--tip-link around it",
                j.name
            );
        }
        match j.kind.as_str() {
            "revolute" | "continuous" | "fixed" => {}
            "prismatic" => crate::refuse!(
                "{path}: joint '{}' is prismatic: kinecal models revolute joints only; choose \
                 --base-link/--tip-link so the chain holds revolute and fixed joints only",
                j.name
            ),
            other => crate::refuse!(
                "{path}: joint '{}' is of type '{other}': only revolute, continuous and fixed \
                 joints can be in the chain; choose --base-link/--tip-link around it",
                j.name
            ),
        }
    }
    let n = joints.iter().filter(|j| j.is_revolute()).count();
    if !(2..=MAX_JOINTS).contains(&n) {
        crate::refuse!(
            "{path}: the chain from '{base}' to '{tip}' has {n} revolute joints; kinecal needs 2 \
             to {MAX_JOINTS}: choose --base-link/--tip-link"
        );
    }
    Ok(Chain { base, tip, joints })
}
