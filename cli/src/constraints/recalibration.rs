//! Whether the robot changed since a model's calibration, judged on a constraint session
//! (`kinecal validate` on a constraint file), as [`crate::calibration::recalibration`] judges
//! a tracker session: the groups are left out fold by fold (group `i` in fold `i mod k`) and
//! each left-out group's residual against its own refitted shape is predicted twice, by the
//! model and by the robot calibrated again on the other groups (the geometry the constraint fit
//! estimates, from the model; its effects kept). A model of the same robot predicts left-out
//! groups about as well as a new calibration; one of a robot whose joint 2 zero moved 0.1°
//! since predicts them many times worse (host-tests `validate_sessions`), though still better
//! than the nominal robot, which is all `validate` compared before.

use super::read::Group;
use super::shapes::held_out_error;
use crate::calibration::recalibration::Recalibration;
use crate::HostRobot;
use kinecal::Param;

/// At most this many folds.
const MAX_FOLDS: usize = 10;

/// [`Recalibration`] of `model` on `groups`. `None` with fewer than four groups, or when a
/// fold's other groups could not be fitted or their fit did not converge.
pub fn recalibrate<const N: usize>(
    model: &HostRobot<N>,
    file: &crate::formats::robot_file::RobotFile,
    groups: &[Group<N>],
) -> Option<Recalibration> {
    if groups.len() < 4 {
        return None;
    }
    let base_unknown = !groups.iter().any(|g| g.kind == super::read::Kind::Point);
    let params: Vec<Param> = super::fit::candidates(model, file, base_unknown, &[])
        .ok()?
        .into_iter()
        .filter(|p| !matches!(p, Param::Effect(_)))
        .collect();
    let k = groups.len().min(MAX_FOLDS);
    let each: Vec<usize> = (0..k).collect();
    let folds = crate::compute::parallel::map_each(&each, |&f| -> Option<(f64, f64, usize)> {
        let in_fold = |i: usize| i % k == f;
        let test: Vec<&Group<N>> = (0..groups.len())
            .filter(|&i| in_fold(i))
            .map(|i| &groups[i])
            .collect();
        let train: Vec<Group<N>> = (0..groups.len())
            .filter(|&i| !in_fold(i))
            .map(|i| groups[i].clone())
            .collect();
        let fitted = super::fit::fit(model, &train, &params)
            .ok()
            .filter(|f| f.converged)?;
        let square = |robot: &HostRobot<N>| -> f64 {
            test.iter().map(|g| held_out_error(robot, g).powi(2)).sum()
        };
        Some((square(model), square(&fitted.robot), test.len()))
    });
    let done: Vec<(f64, f64, usize)> = folds.into_iter().collect::<Option<_>>()?;
    let n: usize = done.iter().map(|d| d.2).sum();
    let rms = |sq: f64| (sq / n.max(1) as f64).sqrt();
    let (model_rms_mm, recalibrated_rms_mm) = (
        rms(done.iter().map(|d| d.0).sum()),
        rms(done.iter().map(|d| d.1).sum()),
    );
    (model_rms_mm.is_finite() && recalibrated_rms_mm.is_finite()).then_some(Recalibration {
        folds: k,
        model_rms_mm,
        recalibrated_rms_mm,
        with_joint_scales_rms_mm: None,
    })
}
