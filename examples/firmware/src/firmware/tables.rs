//! The host's reference values as `f32` tables, and the simulated true robot built from them.

use super::fail;
use crate::reference as host;
use crate::scenario::{self, N, P, SOCKETS, SOCKET_ROWS, TICKS};
use kinecal::{Frame, Joint, Robot};
use nalgebra::Vector3;

/// Host reference values that are compared in `f32`, stored as `f32` (half the flash of the
/// `f64` tables in `reference.rs`; converted when the image is built).
pub(super) static NOMINAL_FK: [[f32; 3]; 4] = to_f32(&host::NOMINAL_FK);
pub(super) static COUPLED_FK: [[f32; 3]; 4] = to_f32(&host::COUPLED_FK);
pub(super) static JACOBIAN: [[f32; 3]; P] = to_f32(&host::JACOBIAN);
pub(super) static TRUE_ROWS: [[f32; 4]; N] = to_f32(&host::TRUE_ROWS);
pub(super) static COMMANDS: [[f32; N]; TICKS] = to_f32(&host::COMMANDS);
pub(super) static POSE6D_VALUES: [[f32; P]; 1] = to_f32(&[host::POSE6D_VALUES]);
pub(super) static POSE6D_AXES: [[f32; 3]; 3] = to_f32(&host::POSE6D_AXES);
pub(super) static SOCKET_Q: [[f32; N]; SOCKETS * SOCKET_ROWS] = to_f32(&host::SOCKET_Q);
pub(super) static SOCKET_VALUES: [[f32; P]; 1] = to_f32(&[host::SOCKET_VALUES]);

pub(super) const fn to_f32<const R: usize, const C: usize>(a: &[[f64; C]; R]) -> [[f32; C]; R] {
    let mut out = [[0.0; C]; R];
    let mut i = 0;
    while i < R {
        let mut j = 0;
        while j < C {
            out[i][j] = a[i][j] as f32;
            j += 1;
        }
        i += 1;
    }
    out
}

/// The simulated physical robot (the truth the measurements came from), with theta2 and
/// theta3 less `remastered` (rad): the model from before a re-mastering.
pub(super) fn true_robot(remastered: f32) -> Robot<f32, N> {
    let joints: [Joint<f32>; N] = core::array::from_fn(|j| {
        let r = TRUE_ROWS[j];
        let off = if j == 1 || j == 2 { remastered } else { 0.0 };
        Joint::mdh(r[0], r[1], r[2] - off, r[3])
    });
    let t = scenario::TOOL_MM;
    Robot::new(
        Frame::identity(),
        joints,
        Vector3::new(t[0] as f32, t[1] as f32, t[2] as f32),
    )
    .unwrap_or_else(|_| fail("true robot"))
}

pub(super) fn v3(a: &[f64; 3]) -> Vector3<f32> {
    Vector3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}
