//! `kinecal plan --estimate NAMES`: the parameters a plan is designed for, by name.
//!
//! A quick re-calibration (after a motor swap or re-mastering) re-identifies a few parameters
//! and holds the rest at their calibrated values; with the others fixed, the information about
//! the subset is simply the subset's columns of the Jacobian, so the plan is made for those
//! parameters alone.

use kinecal::Param;

/// The groups `--estimate` accepts besides single names.
pub const GROUPS: &str = "base, tool, geometry, theta";

/// The parameters named by `names` (each a group or a single name as `identify` prints it:
/// `theta2`, `base.x`, `tool.z`, `d6`, `beta3`), in the order given, each once. Groups: `base`
/// (`base.x` … `base.rz`), `tool` (`tool.x`, `tool.y`, `tool.z`), `geometry` (alpha, a, theta,
/// d of every joint), `theta` (`theta1` … `thetaN`). A name that is neither, or a joint beyond
/// `n_joints`, is refused (exit status 2).
pub fn estimate_params(names: &[String], n_joints: usize) -> anyhow::Result<Vec<Param>> {
    let joints = || (0..n_joints).map(|j| j as u8);
    let mut out: Vec<Param> = Vec::new();
    for raw in names {
        let name = raw.trim();
        let group: Vec<Param> = match name {
            "base" => vec![
                Param::BaseX,
                Param::BaseY,
                Param::BaseZ,
                Param::BaseRx,
                Param::BaseRy,
                Param::BaseRz,
            ],
            "tool" => vec![Param::ToolX, Param::ToolY, Param::ToolZ],
            "geometry" => joints()
                .flat_map(|j| [Param::Alpha(j), Param::A(j), Param::Theta(j), Param::D(j)])
                .collect(),
            "theta" => joints().map(Param::Theta).collect(),
            _ => match Param::parse(name).filter(|p| p.joint().is_none_or(|j| j < n_joints)) {
                Some(p) => vec![p],
                None => crate::refuse!(
                    "--estimate {name}: not a parameter or group of this {n_joints}-joint robot \
                     (groups: {GROUPS}; names: base.x … base.rz, alpha1, a1, theta1, d1, beta1 \
                     … d{n_joints}, tool.x, tool.y, tool.z)"
                ),
            },
        };
        for p in group {
            if !out.contains(&p) {
                out.push(p);
            }
        }
    }
    Ok(out)
}
