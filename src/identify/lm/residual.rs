//! The model's errors against observations: the weighted residual of one observation, its
//! share of the cost, the RMS errors over a data set, and the check a run makes of its data.

use super::status::LmError;
use crate::io::measurement::Observation;
use crate::model::frame::orientation_error;
use crate::ValueStorage;
use crate::{ForwardKinematics, Real, Robot};
use nalgebra::Vector3;

/// The weighted residual of one observation at `robot` and its squared norm (the observation's
/// share of the cost): the point's `w ⊙ (p_m − p)` and, for a 6-D observation, the orientation
/// error's rotation vector times its weight. `fk` holds the pose afterwards. `None` when the
/// robot has no tool point `m.tool`.
#[inline(always)]
pub(super) fn residual<T: Real, const N: usize, V: ValueStorage, M: Observation<T, N>>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    m: &M,
) -> Option<(Vector3<T>, Option<Vector3<T>>)> {
    // Only a model with value capacity can have a thermal-expansion or base-drift term (the
    // firmware's has none: no instruction here).
    if V::CAPACITY > 0 {
        fk.temp_c = m.temperature();
        fk.time_s = m.time();
    }
    let p = if m.tool() == 0 {
        fk.compute(robot, m.q())
    } else {
        fk.compute_point(robot, m.q(), m.tool())?
    };
    let mut r = m.point() - p;
    if let Some(w) = m.weight() {
        r = r.component_mul(&w);
    }
    let rot = m
        .orientation()
        .map(|(o, w)| orientation_error(o, &fk.tool_pose(robot)) * w);
    Some((r, rot))
}

/// The weighted squared residual of one observation (the module documentation of
/// [`crate::io::measurement`] gives it); `None` when the
/// robot has no tool point `m.tool`.
pub fn observation_cost<T: Real, const N: usize, V: ValueStorage, M: Observation<T, N>>(
    fk: &mut ForwardKinematics<T, N>,
    robot: &Robot<T, N, V>,
    m: &M,
) -> Option<T> {
    let (r, rot) = residual(fk, robot, m)?;
    Some(r.norm_squared() + rot.map_or(T::zero(), |v| v.norm_squared()))
}

/// `Ok` when every observation is finite and names a tool point of `robot`.
pub(super) fn check_observations<T: Real, const N: usize, V: ValueStorage, M: Observation<T, N>>(
    robot: &Robot<T, N, V>,
    data: &[M],
) -> Result<(), LmError> {
    if data.iter().any(|m| !m.is_valid()) {
        return Err(LmError::NonFiniteMeasurement);
    }
    if data.iter().any(|m| m.tool() >= robot.tool_point_count()) {
        return Err(LmError::UnknownToolPoint);
    }
    Ok(())
}

/// Root-mean-square position error (mm) of `robot` over `data` (3-D distance per pose).
pub fn rms_error<T: Real, const N: usize, V: ValueStorage, M: Observation<T, N>>(
    robot: &Robot<T, N, V>,
    data: &[M],
) -> T {
    if data.is_empty() {
        return T::zero();
    }
    let mut fk = ForwardKinematics::new();
    let mut s = T::zero();
    for m in data {
        // An observation of a point the robot does not have has no error: NaN, not a number.
        let p = fk
            .compute_at(robot, m.q(), m.tool(), m.conditions())
            .unwrap_or(Vector3::repeat(T::of(f64::NAN)));
        s += (m.point() - p).norm_squared();
    }
    (s / T::of(data.len() as f64)).sqrt()
}

/// Root-mean-square orientation error (rad, the angle between measured and model tool frame)
/// of `robot` over the 6-D observations in `data`; `None` when there are none.
pub fn rms_orientation_error<T: Real, const N: usize, V: ValueStorage, M: Observation<T, N>>(
    robot: &Robot<T, N, V>,
    data: &[M],
) -> Option<T> {
    let mut fk = ForwardKinematics::new();
    let (mut s, mut n) = (T::zero(), 0usize);
    for m in data {
        let Some((o, _)) = m.orientation() else {
            continue;
        };
        if fk
            .compute_at(robot, m.q(), m.tool(), m.conditions())
            .is_none()
        {
            return Some(T::of(f64::NAN));
        }
        s += orientation_error(o, &fk.tool_pose(robot)).norm_squared();
        n += 1;
    }
    (n > 0).then(|| (s / T::of(n as f64)).sqrt())
}
