//! What an export that cannot hold a model's effects or couplings gives up: how far the tool
//! point moves when they are left out, over poses spread over the joint limits. A URDF or a
//! DH table keeps the geometry only; a joint table of gear errors or a coupled wrist left out
//! can cost more than the whole calibration gained, and the user deciding between the URDF and
//! the firmware model needs that figure, not only the effect's name.

use crate::formats::robot_file::RobotFile;
use crate::simulation::random_configurations;
use kinecal::ForwardKinematics;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Poses the shift is measured over, uniform within the joint limits (the same poses for
/// every part of one model: a fixed seed).
pub const POSES: usize = 1_000;
const SEED: u64 = 0x6b63_6578;
/// The temperature difference a thermal-expansion term is judged at (K from its reference).
pub const THERMAL_SPAN_K: f64 = 10.0;

/// How far the tool point moves between two models over [`POSES`] poses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shift {
    pub rms_mm: f64,
    pub max_mm: f64,
    /// The temperature (°C) both were evaluated at when the thermal-expansion term was left
    /// out: [`THERMAL_SPAN_K`] above its reference; `None`: at the reference.
    pub temp_c: Option<f64>,
}

impl Shift {
    /// `without it the tool point moves …`, for a dropped part's description.
    pub fn sentence(&self) -> String {
        let at = self.temp_c.map_or(String::new(), |t| {
            format!(" at {t} °C ({THERMAL_SPAN_K} K above the model's reference temperature)")
        });
        format!(
            "without it the tool point moves {:.3} mm RMS, up to {:.3} mm, over {POSES} poses within the joint limits{at}",
            self.rms_mm, self.max_mm
        )
    }
}

/// What leaving out the parts `keep` rejects costs: `model` with its effects kept only where
/// `keep_effect(index)` and its couplings where `keep_coupling(index)`, against `model` itself.
/// When the thermal-expansion term is among the parts left out, both are evaluated
/// [`THERMAL_SPAN_K`] above its reference temperature (a model without the term ignores the
/// temperature); otherwise at the reference. `None` when the model cannot be evaluated.
pub fn shift(
    model: &RobotFile,
    keep_effect: impl Fn(usize) -> bool,
    keep_coupling: impl Fn(usize) -> bool,
) -> Option<Shift> {
    let mut without = model.clone();
    without.effects = keep(&model.effects, keep_effect);
    without.couplings = keep(&model.couplings, keep_coupling);
    // At the reference temperature a thermal-expansion term does nothing: left out, it is
    // judged THERMAL_SPAN_K above it (and so is everything left out with it).
    let temp_c = match (model.thermal_reference_c(), without.thermal_reference_c()) {
        (Some(t0), None) => Some(t0 + THERMAL_SPAN_K),
        _ => None,
    };
    crate::with_joints!(model.joints.len(), N => shift_with::<N>(model, &without, temp_c))
        .ok()
        .flatten()
}

fn keep<T: Clone>(items: &[T], keep: impl Fn(usize) -> bool) -> Vec<T> {
    items
        .iter()
        .enumerate()
        .filter(|(i, _)| keep(*i))
        .map(|(_, x)| x.clone())
        .collect()
}

fn shift_with<const N: usize>(
    model: &RobotFile,
    without: &RobotFile,
    temp_c: Option<f64>,
) -> anyhow::Result<Option<Shift>> {
    let (with, without) = (model.to_robot::<N>()?, without.to_robot::<N>()?);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(SEED);
    let poses = random_configurations(&with, POSES, &mut rng);
    let (mut a, mut b) = (ForwardKinematics::new(), ForwardKinematics::new());
    let (mut sum, mut max) = (0.0, 0.0_f64);
    for q in &poses {
        let (Some(p), Some(r)) = (
            a.compute_at(&with, q, 0, temp_c),
            b.compute_at(&without, q, 0, temp_c),
        ) else {
            return Ok(None);
        };
        let d = (p - r).norm();
        sum += d * d;
        max = max.max(d);
    }
    let shift = Shift {
        rms_mm: (sum / poses.len() as f64).sqrt(),
        max_mm: max,
        temp_c,
    };
    Ok((shift.rms_mm.is_finite() && shift.max_mm.is_finite()).then_some(shift))
}
