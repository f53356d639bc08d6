//! `kinecal export`: the original URDF text with the chain joints' `<origin>` values replaced
//! by the calibrated ones and the tool point appended as a fixed joint and link; every other
//! byte as it was.
//!
//! Joint i's new origin is P_i⁻¹·C_{i-1}⁻¹·T_i(0)·C_i: T_i the calibrated MDH row at q = 0,
//! C_i the constant pose of URDF link i in MDH frame i from importing the same file (so each
//! link keeps its relation to the kinematics, and `<axis>` stays as written), P_i the fixed
//! joints before joint i, and C_0 = B⁻¹ with B the *nominal* base of that import: the
//! calibrated `[base]` is where the tracker saw the robot, not part of the robot.

use super::mdh::{row_transform, Imported};
use super::parse::{rpy_of, Urdf};
use crate::formats::robot_file::RobotFile;
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

/// Name of the appended tool link and of its fixed joint.
pub const TOOL_LINK: &str = "kinecal_tool";
pub const TOOL_JOINT: &str = "kinecal_tool_joint";

/// A number for the URDF: 15 decimals (1e-15 m, 1e-12 mm; 1e-15 rad), trailing zeros
/// trimmed, so the last-bit noise of the frame algebra does not show (`1.49`, not
/// `1.4900000000000002`) and FK reproduces to far below 1e-9 mm.
fn num(v: f64) -> String {
    let t = format!("{v:.15}");
    let t = t.trim_end_matches('0').trim_end_matches('.');
    match t {
        "-0" | "" => "0".to_string(),
        t => t.to_string(),
    }
}

fn triple(v: [f64; 3]) -> String {
    format!("{} {} {}", num(v[0]), num(v[1]), num(v[2]))
}

/// `v` as the value of a double-quoted XML attribute (`tool&0` as `tool&amp;0`).
fn escape_attribute(v: &str) -> String {
    let mut out = String::with_capacity(v.len());
    for c in v.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// `xyz` (metres) and `rpy` (radians) of a transform in millimetres.
fn xyz_rpy(t: &Isometry3<f64>) -> (String, String) {
    let v = t.translation.vector / 1000.0;
    (triple([v.x, v.y, v.z]), triple(rpy_of(&t.rotation)))
}

/// The calibrated joint origins (millimetres), base first, for `model` on the chain that
/// `nominal` imported.
pub fn calibrated_origins(nominal: &Imported, model: &RobotFile) -> Vec<Isometry3<f64>> {
    let mut prev = nominal.base.inverse();
    let mut out = Vec::new();
    for (i, j) in model.joints.iter().enumerate() {
        let t = row_transform(
            j.alpha_deg.to_radians(),
            j.a_mm,
            j.beta_deg.unwrap_or(0.0).to_radians(),
            j.theta_deg.to_radians(),
            j.d_mm,
        );
        let c = nominal.link_in_frame[i];
        out.push(nominal.before[i].inverse() * prev.inverse() * t * c);
        prev = c;
    }
    out
}

/// The tool frame in the tip link: the model's tool point and orientation (the nominal
/// import's orientation when the model has none) seen from the tip link.
pub fn tool_in_tip(nominal: &Imported, model: &RobotFile) -> Isometry3<f64> {
    let rpy = model
        .tool
        .rpy_deg
        .or(nominal.file.tool.rpy_deg)
        .unwrap_or([0.0; 3])
        .map(f64::to_radians);
    let tool = Isometry3::from_parts(
        Translation3::from(nalgebra::Vector3::from(model.tool.xyz_mm)),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    );
    let last = nominal.link_in_frame[nominal.link_in_frame.len() - 1];
    (last * nominal.tip_in_last_link).inverse() * tool
}

/// The exported text (see the module documentation). `tip` is the chain's tip link; `path`
/// names the file in a refusal.
pub fn export(
    text: &str,
    urdf: &Urdf,
    nominal: &Imported,
    model: &RobotFile,
    tip: &str,
    path: &str,
) -> anyhow::Result<String> {
    let origins = calibrated_origins(nominal, model);
    // (range to replace, new text), applied from the end of the file backwards.
    let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    for (name, o) in nominal.joint_names.iter().zip(&origins) {
        let Some(j) = urdf.joints.iter().find(|j| &j.name == name) else {
            continue;
        };
        let (xyz, rpy) = xyz_rpy(o);
        match &j.origin {
            Some(or) => match (&or.xyz, &or.rpy) {
                (Some(x), Some(r)) => {
                    edits.push((x.clone(), xyz));
                    edits.push((r.clone(), rpy));
                }
                // The missing attribute goes after the closing quote of the present one,
                // whichever quote the file uses (`xyz='0 0 1'`).
                (Some(x), None) => {
                    edits.push((x.clone(), xyz));
                    edits.push((x.end + 1..x.end + 1, format!(" rpy=\"{rpy}\"")));
                }
                (None, Some(r)) => {
                    edits.push((r.clone(), rpy));
                    edits.push((r.end + 1..r.end + 1, format!(" xyz=\"{xyz}\"")));
                }
                (None, None) => {
                    let at = or.element.start + "<origin".len();
                    edits.push((at..at, format!(" xyz=\"{xyz}\" rpy=\"{rpy}\"")));
                }
            },
            None => {
                edits.push((
                    j.tag_end..j.tag_end,
                    format!("\n    <origin xyz=\"{xyz}\" rpy=\"{rpy}\"/>"),
                ));
            }
        }
    }
    let (xyz, rpy) = xyz_rpy(&tool_in_tip(nominal, model));
    let tip = escape_attribute(tip);
    let tool = format!(
        "  <!-- kinecal: the calibrated tool point (kinecal export) -->\n  <link name=\"{TOOL_LINK}\"/>\n  <joint name=\"{TOOL_JOINT}\" type=\"fixed\">\n    <parent link=\"{tip}\"/>\n    <child link=\"{TOOL_LINK}\"/>\n    <origin xyz=\"{xyz}\" rpy=\"{rpy}\"/>\n  </joint>\n"
    );
    edits.push((urdf.robot_end..urdf.robot_end, tool));
    edits.sort_by_key(|(r, _)| std::cmp::Reverse(r.start));
    let mut out = text.to_string();
    let mut limit = text.len();
    for (r, s) in edits {
        // Edits apart from each other and on character boundaries, else refused (two joints
        // sharing an element would otherwise be edited twice, or a multibyte character cut).
        if r.start > r.end
            || r.end > limit
            || !text.is_char_boundary(r.start)
            || !text.is_char_boundary(r.end)
        {
            crate::refuse!(
                "{path}: cannot rewrite the origin of the chain's joints in place (overlapping \
                 elements): write each chain joint with its own <origin xyz=\"…\" rpy=\"…\"/>"
            );
        }
        limit = r.start;
        out.replace_range(r, &s);
    }
    Ok(out)
}
