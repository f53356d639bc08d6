//! Stepping a solver, and reading where it stands: progress, estimate, unidentifiable parameters.

use super::measurement::{kc_measurement, measurements};
use super::progress::{kc_lm_progress, progress_of};
use super::solver::{each_lm, lm_error, Lm, Solver, Solvers};
use crate::handle;
use crate::robot::{code_of, kc_param, kc_robot, Model};
use crate::{obj_mut, slice_mut, Kc, KC_BUFFER_TOO_SMALL, KC_INVALID_ROBOT, KC_NOT_INITIALIZED};
use kinecal::identify::lm::{LmError, LmProgress};
use kinecal::Observation;

#[inline(always)]
pub(super) unsafe fn lm_step<H: Solver<P>, const P: usize>(
    lm: *mut H,
    data: *const kc_measurement,
    n: usize,
    budget_poses: usize,
    out: *mut kc_lm_progress,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get_mut(lm) }?;
    // SAFETY: the header contract.
    let data = unsafe { measurements(data, n) }?;
    // SAFETY: the header contract.
    let out = unsafe { obj_mut(out) }?;
    let p = each_lm!(lm, s => step(s, data, budget_poses).map_err(lm_error))?;
    *out = progress_of(&p);
    Ok(())
}

#[inline(never)]
fn step<const N: usize, const P: usize>(
    lm: &mut Lm<N, P>,
    data: &[kc_measurement],
    budget: usize,
) -> Result<LmProgress<f32>, LmError>
where
    kc_measurement: Observation<f32, N>,
{
    lm.step(data, budget)
}

pub(super) unsafe fn lm_progress<H: Solver<P>, const P: usize>(
    lm: *const H,
    out: *mut kc_lm_progress,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get(lm) }?;
    let p = each_lm!(lm, s => Ok(s.progress()))?;
    // SAFETY: the header contract.
    *unsafe { obj_mut(out) }? = progress_of(&p);
    Ok(())
}

pub(super) unsafe fn lm_robot<H: Solver<P>, const P: usize>(
    lm: *const H,
    out: *mut kc_robot,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get(lm) }?;
    let robot = match lm {
        Solvers::J6(Ok(s)) => Model::J6(s.robot().with_capacity().map_err(|_| KC_INVALID_ROBOT)?),
        Solvers::J7(Ok(s)) => Model::J7(s.robot().with_capacity().map_err(|_| KC_INVALID_ROBOT)?),
        Solvers::J6(Err(_)) | Solvers::J7(Err(_)) => return Err(KC_NOT_INITIALIZED),
    };
    // SAFETY: the header contract; `out` is a robot handle, not the solver.
    let slot = unsafe { handle::uninit::<kc_robot>(out) }?;
    handle::init::<kc_robot>(slot, robot);
    Ok(())
}

pub(super) unsafe fn lm_unidentifiable<H: Solver<P>, const P: usize>(
    lm: *const H,
    out: *mut kc_param,
    cap: usize,
    count: *mut usize,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get(lm) }?;
    // SAFETY: the header contract.
    let count = unsafe { obj_mut(count) }?;
    // SAFETY: the header contract (`cap` values).
    let out = unsafe { slice_mut(out, cap) }?;
    each_lm!(lm, s => {
        let n = s.unidentifiable().count();
        *count = n;
        if cap < n {
            return Err(KC_BUFFER_TOO_SMALL);
        }
        for (o, p) in out.iter_mut().zip(s.unidentifiable()) {
            *o = code_of(p);
        }
        Ok(())
    })
}
