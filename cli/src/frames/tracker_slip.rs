//! Swept points the robot file's model cannot be placed onto rigidly, but can be mirrored or
//! scaled onto: the tracker's axes mirrored (an axis's sign flipped, two exchanged) or the
//! points in another length unit. Either turns a sweep's circle the wrong way or to the wrong
//! size, and [`super::axes_agree`] would blame a joint's sign or zero; the same tests as
//! `check`'s ([`crate::calibration::check`]: [`MIRRORED_SHARE`], [`SCALED_OFF`]) name the
//! cause instead.

use crate::calibration::check::{MIRRORED_FROM_MM, MIRRORED_SHARE, SCALED_OFF};
use crate::compute::registration::{fit_rigid, mirrored_rms, scaled_fit};
use crate::output::numfmt::sig;
use crate::simulation::sweeps::SweepSet;
use kinecal::{ForwardKinematics, Frame, Robot};
use nalgebra::Vector3;

/// Why every swept point is the robot file's model mirrored or scaled (`None` when a rigid
/// placement fits them, or neither explains them better).
pub fn slip<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    sweeps: &SweepSet<N>,
) -> Option<String> {
    let mut placed = robot.clone();
    placed.set_base(Frame::identity()).ok()?;
    let mut fk = ForwardKinematics::<f64, N>::new();
    let (mut model, mut measured): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = (vec![], vec![]);
    for (qs, ps) in sweeps.q.iter().zip(&sweeps.points) {
        for (q, p) in qs.iter().zip(ps) {
            let m = fk.compute(&placed, q);
            if m.iter().chain(p.iter()).all(|c| c.is_finite()) {
                model.push(m);
                measured.push(*p);
            }
        }
    }
    let rigid = fit_rigid(&model, &measured).ok()?;
    let n = model.len() as f64;
    let rigid_rms = (model
        .iter()
        .zip(&measured)
        .map(|(m, p)| (rigid.point(m) - p).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    if rigid_rms.is_nan() || rigid_rms <= MIRRORED_FROM_MM {
        return None;
    }
    // A joint's sign flipped (joint 1 above all) mirrors the arm too, and better: the joint's
    // sign is then the cause, which `axes_agree` names.
    let mut negated_rms = |j: usize| -> Option<f64> {
        let mut pts = Vec::with_capacity(model.len());
        for qs in &sweeps.q {
            for q in qs {
                let mut q = *q;
                q[j] = -q[j];
                pts.push(fk.compute(&placed, &q));
            }
        }
        let pts: Vec<Vector3<f64>> = pts
            .into_iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .collect();
        if pts.len() != measured.len() {
            return None;
        }
        let f = fit_rigid(&pts, &measured).ok()?;
        Some(
            (pts.iter()
                .zip(&measured)
                .map(|(m, p)| (f.point(m) - p).norm_squared())
                .sum::<f64>()
                / n)
                .sqrt(),
        )
    };
    let mirrored = mirrored_rms(&model, &measured).filter(|m| *m < MIRRORED_SHARE * rigid_rms);
    let negated = mirrored.map_or(f64::INFINITY, |_| {
        (0..N)
            .filter_map(&mut negated_rms)
            .fold(f64::INFINITY, f64::min)
    });
    let mirrored = mirrored.filter(|m| *m < negated);
    if let Some(m) = mirrored {
        return Some(format!(
            "the swept points are the robot file's model mirrored: no rigid placement fits \
             them ({} mm RMS), a mirrored one does ({} mm): one of the tracker's axes has its \
             sign flipped, or two are exchanged; correct x, y, z (or the map's columns)",
            sig(rigid_rms, 3),
            sig(m, 3)
        ));
    }
    let (s, rms) = scaled_fit(&model, &measured)?;
    ((s - 1.0).abs() > SCALED_OFF && rms / s < MIRRORED_SHARE * rigid_rms).then(|| {
        format!(
            "the swept points are {}× the robot file's model (a rigid placement leaves {} mm \
             RMS, scaled {} mm): {}",
            sig(s, 4),
            sig(rigid_rms, 3),
            sig(rms / s, 3),
            crate::formats::units::scale_cause(s)
        )
    })
}
