//! Stage 3b: the tool as a 6-DoF probe with further reflectors, identified from 6-D observations.

use super::checks::{fx, Checks};
use super::identify::{lm_idle, lm_per_pose, new_probe_lm, NewLm};
use super::kernels::lm_step;
use super::scheduler::Servo;
use super::tables::{POSE6D_AXES, POSE6D_VALUES};
use super::{place, Lm, Stateful};
use crate::bench::Counter;
use crate::reference as host;
use crate::scenario::{self, N, VAL_POSES};
use core::mem::MaybeUninit;
use cortex_m_semihosting::hprintln;
use heapless::Vec;
use kinecal::identify::lm::LmError;
use kinecal::model::frame::orientation_error;
use kinecal::{Frame, Measurement, Param, Robot};
use nalgebra::Vector3;

/// Stage 3b: the tool as a 6-DoF probe with two further reflectors. Observations of
/// a known error of the probe and the wrist (weighted 6-D observations of reflector 1, position
/// observations of reflectors 2 and 3, computed here from the truth at the first
/// identification poses) in the held-out poses' storage; LM from the nominal probe must find
/// the host's `f64` values, the probe's orientation included.
#[inline(never)]
pub(super) fn probe(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    lm_slot: &mut MaybeUninit<Result<Lm, LmError>>,
    id: &[Measurement<f32, N>],
    data: &mut Vec<Measurement<f32, N>, VAL_POSES>,
) {
    const SIX_D: usize = scenario::POSE6D_POSES;
    const ALL: usize = SIX_D + scenario::POINT_OBS;
    const _: () = assert!(ALL <= VAL_POSES);
    data.clear();
    scenario::pose6d_observations(
        &scenario::probe_truth(),
        |i| id[i].q,
        |m| {
            let _ = data.push(m);
        },
    );
    let lm = place(lm_slot, new_probe_lm as NewLm);
    // Accumulation pass at the nominal probe: 6-D observations 2..=8, then reflector
    // observations 9..=19 (the first call also validates the data, the last also analyses
    // identifiability). The run continues from here.
    let _ = lm_step(lm, data, 1);
    bench.lm_pose6d = lm_per_pose(counter, lm, data, SIX_D as u32 - 1);
    bench.lm_point_multi = lm_per_pose(counter, lm, data, (ALL - SIX_D) as u32 - 1);
    // The rest in idle slices while the servo holds its pose.
    let (idle, end) = lm_idle(counter, servo, lm, data);
    // Largest differences from the host's values: lengths (mm), angles (rad), and the angle
    // between the identified probe frames (rad).
    let robot = lm.robot();
    let (mut mm, mut rad) = (0.0f32, 0.0f32);
    for (p, want) in scenario::pose6d_params()
        .iter()
        .zip(POSE6D_VALUES[0].iter())
    {
        let Some(got) = stored_value(robot, *p) else {
            continue;
        };
        let e = (got - want).abs();
        if p.is_length() {
            mm = mm.max(e);
        } else {
            rad = rad.max(e);
        }
    }
    let [x, y, z] = POSE6D_AXES.map(Vector3::from);
    let want = Frame {
        x,
        y,
        z,
        o: Vector3::zeros(),
    };
    let axes = orientation_error(robot.tool_axes(), &want).norm();
    let p = end.unwrap_or_else(|| lm.progress());
    hprintln!(
        "probe: LM {:?} after {} iterations (host f64: {}), {} 6-D and {} reflector observations",
        p.stopped,
        p.iteration,
        host::POSE6D_ITERATIONS,
        SIX_D,
        ALL - SIX_D
    );
    idle.report("probe", checks);
    checks.check(
        "lm.probe_6d",
        end.is_some() && mm <= 2e-3 && rad <= 2e-6 && axes <= 2e-6,
        format_args!(
            "24 parameters from the nominal probe vs host f64: within {} µm, {} µrad, probe frame (tool.rx/ry/rz) within {} µrad",
            fx(mm * 1e3, 3),
            fx(rad * 1e6, 3),
            fx(axes * 1e6, 3)
        ),
    );
}

/// A reflector coordinate or row value of `robot` (`None` for the probe frame's angles, which
/// are compared as a frame: their roll/pitch/yaw would link 6 KB of inverse trigonometry).
pub(super) fn stored_value(robot: &Robot<f32, N>, p: Param) -> Option<f32> {
    if let Some((k, axis)) = p.tool_point() {
        return robot.tool_point(k).map(|v| v[axis]);
    }
    let j = robot.joints().get(p.joint()?)?;
    match p {
        Param::Alpha(_) => Some(j.alpha),
        Param::A(_) => Some(j.a),
        Param::Theta(_) => Some(j.theta),
        Param::D(_) => Some(j.d),
        _ => None,
    }
}
