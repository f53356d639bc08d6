//! Stage 2: `f32` forward kinematics and the identification Jacobian against the host's `f64`.

use super::checks::{fx, Checks};
use super::kernels::fk_f32;
use super::tables::{COUPLED_FK, JACOBIAN, NOMINAL_FK};
use crate::reference as host;
use crate::scenario::{self, N, P};
use kinecal::identify::lm::rms_error;
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::Vector3;

/// Stage 2: f32 kinematics against the host's f64.
#[inline(never)]
pub(super) fn kinematics(checks: &mut Checks, id: &[Measurement<f32, N>]) {
    let nominal = scenario::nominal::<f32>();
    let mut fk = ForwardKinematics::<f32, N>::new();
    let worst = fk_worst(&mut fk, &nominal, id, &NOMINAL_FK);
    checks.check(
        "fk.f32",
        worst < 2e-3,
        format_args!("max |p_f32 - p_f64| = {} µm", fx(worst * 1e3, 3)),
    );
    // The FANUC way of reading J3 (from the horizontal, q3 = J3 + J2): same readings, other
    // points.
    let worst = fk_worst(&mut fk, &scenario::coupled(), id, &COUPLED_FK);
    checks.check(
        "fk.coupled_f32",
        worst < 2e-3,
        format_args!("max |p_f32 - p_f64| = {} µm", fx(worst * 1e3, 3)),
    );

    fk_f32(&mut fk, &nominal, &id[0].q);
    let mut cols = [Vector3::zeros(); P];
    let ok = fk
        .identification_jacobian(&nominal, scenario::params().as_slice(), &mut cols)
        .is_ok();
    let mut worst = 0.0f32;
    for (c, want) in cols.iter().zip(JACOBIAN.iter()) {
        let w = Vector3::from(*want);
        worst = worst.max((c - w).norm() / w.norm().max(1.0));
    }
    checks.check(
        "jacobian.f32",
        ok && worst < 1e-5,
        format_args!("max relative column error {} ppm", fx(worst * 1e6, 3)),
    );
    checks.close(
        "fk.nominal_rms_mm",
        rms_error(&nominal, id) as f64,
        host::NOMINAL_RMS_MM,
        1e-4,
    );
}

/// Largest distance (mm) of `robot`'s f32 points at the first poses of `id` from the host's.
#[inline(never)]
pub(super) fn fk_worst(
    fk: &mut ForwardKinematics<f32, N>,
    robot: &Robot<f32, N>,
    id: &[Measurement<f32, N>],
    want: &[[f32; 3]],
) -> f32 {
    let mut worst = 0.0f32;
    for (m, w) in id.iter().zip(want.iter()) {
        let p = fk_f32(fk, robot, &m.q);
        worst = worst.max((p - Vector3::from(*w)).norm());
    }
    worst
}
