//! The base found must put every swept joint's axis where the sweep measured it. The base is
//! built from the axes of joints 1 and 2 alone, so a joint whose sign in the data is the
//! opposite of the robot file's still gives a base: turned by 180° (joint 2 negated gave
//! `rpy_deg = [0, 0, -160]` where the truth is `[0, 0, 20]`), and the robot placed there misses
//! the points by metres. The further sweeps tell: each joint's axis, as the robot file at the
//! base found puts it, must point the way the sweep turned (right-handed about the axis as
//! the reading increases) and pass through the sweep's circle, within the limits by which a
//! calibration moves a joint ([`MOST_ANGLE_CHANGE_DEG`], [`MOST_LENGTH_CHANGE_MM`]).

use crate::calibration::arm_size::{MOST_ANGLE_CHANGE_DEG, MOST_LENGTH_CHANGE_MM};
use crate::output::numfmt::sig;
use crate::simulation::sweeps::SweepSet;
use kinecal::frames::circle_point::Line;
use kinecal::{ForwardKinematics, Robot};

/// A sweep whose axis direction is less certain than this (one standard deviation, degrees)
/// is not compared.
pub const MOST_SD_AXIS_DEG: f64 = 1.0;

/// Whether the sweeps `sweeps` agree with `placed` (the robot file's model at the base found):
/// `Err` with why for the first swept joint (from joint 3) whose measured axis points more
/// than [`MOST_ANGLE_CHANGE_DEG`] from the model's, or lies more than [`MOST_LENGTH_CHANGE_MM`]
/// from it at the circle's centre; `Ok` with how many were compared when every one agrees.
/// Sweeps the method cannot use are skipped (they are judged elsewhere), and so are those whose
/// axis direction is less certain than [`MOST_SD_AXIS_DEG`].
pub fn compared<const N: usize, V: kinecal::ValueStorage>(
    placed: &Robot<f64, N, V>,
    sweeps: &SweepSet<N>,
) -> Result<usize, String> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut count = 0;
    let why = (2..N).find_map(|j| {
        let sweep = sweeps.get(j)?;
        let measured = sweep.axis().ok()?;
        // A point near the axis (the flange's, with the reflector on it) turns on a circle
        // too small to give the axis's direction.
        let sd = measured.circle.sd_normal.to_degrees();
        if sd.is_nan() || sd > MOST_SD_AXIS_DEG {
            return None;
        }
        let q = sweep.q.first()?;
        fk.compute(placed, q);
        let f = fk.frames.get(j)?;
        let model = Line::new(f.o, f.z)?;
        let angle = measured.line.direction.angle(&model.direction).to_degrees();
        let off = model.distance(&measured.circle.centre);
        if !(angle.is_finite() && off.is_finite()) {
            return None;
        }
        let k = j + 1;
        count += 1;
        if angle > MOST_ANGLE_CHANGE_DEG {
            Some(format!(
                "the sweep of joint {k} turns about an axis {}° from the one the robot file, at \
                 the base found from joints 1 and 2, gives it: a joint's sign in the data (one \
                 of joints 1 to {k}) is the opposite of the robot file's, its zero is 180° from \
                 the file's, or a row's `sweep` names another joint; check the signs and zeros \
                 of the joint readings and the sweep column",
                sig(angle, 3)
            ))
        } else if off > MOST_LENGTH_CHANGE_MM {
            Some(format!(
                "the sweep of joint {k} turns about an axis {} mm from where the robot file, at \
                 the base found from joints 1 and 2, puts it: a joint's sign or zero in the \
                 data (one of joints 1 to {}) differs from the robot file's, or the points are \
                 in another length unit; check the joint readings and the units",
                sig(off, 3),
                k - 1
            ))
        } else {
            None
        }
    });
    why.map_or(Ok(count), Err)
}

/// The RMS distance (mm) of the swept points from the model at the base found beyond which
/// [`points_off`] refuses: a joint negated puts them metres away (2.4 m), while a stated tool
/// that is wrong, even by its whole length (a reflector 109 mm out where the file says
/// `[0, 0, 0]`), leaves them nearer.
pub const POINTS_OFF_MM: f64 = 500.0;

/// Why the swept points contradict `placed` (the robot file's model, its tool as stated, at the
/// base found): their RMS distance from where the model puts the tool at the rows' readings is
/// above [`POINTS_OFF_MM`]. Only for sweeps that [`compared`] could not check (joints 1 and 2
/// alone, or further sweeps on the flange axis); `None` when they agree or there is nothing to
/// compare.
pub fn points_off<const N: usize, V: kinecal::ValueStorage>(
    placed: &Robot<f64, N, V>,
    sweeps: &SweepSet<N>,
) -> Option<String> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    let (mut sum, mut count) = (0.0, 0usize);
    for j in 0..N {
        let Some(sweep) = sweeps.get(j) else { continue };
        for (q, p) in sweep.q.iter().zip(sweep.points) {
            let d = (fk.compute(placed, q) - p).norm();
            if d.is_finite() {
                sum += d * d;
                count += 1;
            }
        }
    }
    let rms = (count > 0).then(|| (sum / count as f64).sqrt())?;
    (rms > POINTS_OFF_MM).then(|| {
        format!(
            "the robot file, at the base found from the sweeps of joints 1 and 2, puts the tool \
             {} mm RMS from the swept points: a joint's sign or zero in the data differs from \
             the robot file's (joint 1 or 2 negated turns the base found by 180°), the tool \
             point is not the one measured (write xyz_mm = \"unknown\" if nobody measured it), \
             or the points are in another length unit; check the joint readings, the tool and \
             the units",
            sig(rms, 3)
        )
    })
}
