//! The start of a tool point nobody measured (`[tool] xyz_mm = "unknown"`): the point in the
//! flange frame that best explains the measured points, found with the base (estimated too
//! when the robot file has none) by alternating the two least-squares fits.

use super::registration::place_base;
use kinecal::forward::ForwardKinematics;
use kinecal::{Measurement, Robot};
use nalgebra::Vector3;

/// Rounds of base and tool fits: each halves or better what the other leaves, and a round
/// costs one pass over the data.
const ROUNDS: usize = 40;

/// The tool point (flange frame, mm) nearest in the least-squares sense to `data`'s points of
/// the first reflector with `robot`'s base: the mean of `R_flangeᵀ · (p − o_flange)`. `None`
/// when no observation of it computes.
pub fn fit_tool_point<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
) -> Option<Vector3<f64>> {
    let mut flange = robot.clone();
    flange.set_tool(Vector3::zeros()).ok()?;
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut sum = Vector3::zeros();
    let mut n = 0usize;
    for m in data.iter().filter(|m| m.tool == 0) {
        let o = fk.compute_at(&flange, &m.q, 0, m.conditions())?;
        sum += fk.flange_pose().rotation().transpose() * (m.point - o);
        n += 1;
    }
    let t = sum / n as f64;
    (n > 0 && t.iter().all(|v| v.is_finite())).then_some(t)
}

/// Places `robot` on `data`: the base fitted when `base` (the file has none), the tool point
/// started from the data when `tool` (the file says it is unknown), the two in turn.
pub fn place<const N: usize, V: kinecal::ValueStorage>(
    robot: &mut Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    base: bool,
    tool: bool,
) -> anyhow::Result<()> {
    let set_base = |r: &mut Robot<f64, N, V>| place_base(r, data);
    if !tool {
        return if base { set_base(robot) } else { Ok(()) };
    }
    robot
        .set_tool(Vector3::zeros())
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    // With the base known, the tool point's fit is linear and done in one pass.
    let rounds = if base { ROUNDS } else { 1 };
    for _ in 0..rounds {
        if base {
            set_base(robot)?;
        }
        let t = fit_tool_point(robot, data)
            .ok_or_else(|| anyhow::anyhow!("no observation places the unknown tool point"))?;
        robot
            .set_tool(t)
            .map_err(|e| anyhow::anyhow!("estimated tool point is invalid: {e:?}"))?;
    }
    if base {
        set_base(robot)?;
    }
    Ok(())
}
