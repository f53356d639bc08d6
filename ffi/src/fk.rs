//! Forward kinematics (`kc_fk`: a `ForwardKinematics<f32, 6 or 7>` workspace) and the
//! identification Jacobian.

use crate::handle::{self, handle};
use crate::robot::{kc_param, kc_robot, param_of, rot_of, Arm, Model, KC_PARAMS_ALL};
use crate::KC_NOT_INITIALIZED;
use crate::{array_mut, array_ref, finite, slice_mut, slice_ref, status, Kc};
use crate::{kc_status, KC_BUFFER_TOO_SMALL, KC_INVALID_ARGUMENT, KC_TOO_MANY_PARAMS};
use kinecal::model::param::ParamSet;
use kinecal::{ForwardKinematics, Param};
use nalgebra::Vector3;

/// Bytes of a [`kc_fk`] (see `KC_ROBOT_SIZE`).
pub const KC_FK_SIZE: usize = 512;

/// A forward-kinematics workspace (`ForwardKinematics<f32, N>`): the frames of the last pose
/// computed, which [`kc_fk_jacobian`] differentiates. It takes the joint count of the robot it
/// computes. Opaque, caller-owned; [`kc_fk_init`].
#[repr(C, align(8))]
pub struct kc_fk {
    _opaque: [u8; KC_FK_SIZE],
}

/// The workspace behind a [`kc_fk`], for the joint count of the last robot computed.
pub(crate) enum Workspace {
    /// For a six-joint robot.
    J6(ForwardKinematics<f32, 6>),
    /// For a seven-joint robot.
    J7(ForwardKinematics<f32, 7>),
}

impl Workspace {
    /// The six-joint workspace (a fresh one if it held the other).
    #[inline(always)]
    fn six(&mut self) -> Kc<&mut ForwardKinematics<f32, 6>> {
        if let Workspace::J7(_) = self {
            *self = Workspace::J6(ForwardKinematics::new());
        }
        match self {
            Workspace::J6(f) => Ok(f),
            Workspace::J7(_) => Err(KC_NOT_INITIALIZED),
        }
    }

    /// The seven-joint workspace (a fresh one if it held the other).
    #[inline(always)]
    fn seven(&mut self) -> Kc<&mut ForwardKinematics<f32, 7>> {
        if let Workspace::J6(_) = self {
            *self = Workspace::J7(ForwardKinematics::new());
        }
        match self {
            Workspace::J7(f) => Ok(f),
            Workspace::J6(_) => Err(KC_NOT_INITIALIZED),
        }
    }
}

handle!(kc_fk, KC_FK_SIZE, Workspace, 0x4646_4646);

// `float *` output arrays are written as `Vector3<f32>` columns: nalgebra's `Matrix` is
// `repr(C)` over a `repr(transparent)` array, so a `Vector3<f32>` is three contiguous floats.
const _: () = assert!(
    core::mem::size_of::<Vector3<f32>>() == 12 && core::mem::align_of::<Vector3<f32>>() == 4
);

/// Three floats as the library's vector type, in place.
#[inline(always)]
fn vec3_mut(a: &mut [f32; 3]) -> &mut Vector3<f32> {
    // SAFETY: `Vector3<f32>` is `repr(C)` over a `repr(transparent)` `[[f32; 3]; 1]`: the same
    // size, alignment and bytes as `[f32; 3]` (asserted above), and every bit pattern is valid.
    unsafe { &mut *(a as *mut [f32; 3]).cast::<Vector3<f32>>() }
}

/// Initialises a workspace (identity frames).
///
/// # Safety
/// `w` is NULL or a writable `kc_fk` not otherwise in use.
#[no_mangle]
pub unsafe extern "C" fn kc_fk_init(w: *mut kc_fk) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let slot = unsafe { handle::uninit::<kc_fk>(w) }?;
        handle::init::<kc_fk>(slot, Workspace::J6(ForwardKinematics::new()));
        Ok(())
    })())
}

/// Forward kinematics of `r` at the joint readings `q[n]` (rad; n = the robot's joints): the measured point
/// (the tool point, measurement frame, mm) into `xyz_out[3]`. The workspace keeps the pose for
/// [`kc_fk_jacobian`]. `KC_NOT_FINITE` when a reading is NaN or infinite: checked on the
/// result (the library maps non-finite readings, and only those, to a non-finite point), so it
/// costs 6 instructions instead of 18 on the M4F; `xyz_out` then holds that point and the
/// workspace no pose (compute again before a Jacobian).
///
/// # Safety
/// Handles NULL or valid (`w` not otherwise in use); arrays NULL or of their sizes.
#[no_mangle]
pub unsafe extern "C" fn kc_fk_point(
    w: *mut kc_fk,
    r: *const kc_robot,
    q: *const f32,
    xyz_out: *mut f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let ws = unsafe { handle::get_mut(w) }?;
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract (3 floats).
        let out = unsafe { array_mut::<f32, 3>(xyz_out) }?;
        match robot {
            // SAFETY: the header contract (6 floats).
            Model::J6(m) => unsafe { fk_point(ws.six()?, m, q, out) },
            // SAFETY: the header contract (7 floats).
            Model::J7(m) => unsafe { fk_point(ws.seven()?, m, q, out) },
        }
    })())
}

/// The point of `robot` at the caller's `N` readings `q` into `out`.
///
/// # Safety
/// `q` is NULL or `N` floats.
#[inline(always)]
unsafe fn fk_point<const N: usize>(
    fk: &mut ForwardKinematics<f32, N>,
    robot: &Arm<N>,
    q: *const f32,
    out: &mut [f32; 3],
) -> Kc<()> {
    // SAFETY: the caller's contract.
    let q = unsafe { array_ref::<f32, N>(q) }?;
    // A `Vector3<f32>` is three floats with the alignment of one (asserted above), so the
    // library writes the point straight into the caller's array.
    let p = vec3_mut(out);
    *p = fk.compute(robot, q);
    finite(p.as_slice())
}

/// The tool pose of `robot` at the caller's `N` readings `q` (the library's
/// `ForwardKinematics::tool_pose`: the flange axes times the robot's tool axes, at the measured
/// point): point into `out`, row-major rotation into `rot`.
///
/// # Safety
/// `q` is NULL or `N` floats.
#[inline(always)]
unsafe fn fk_pose<const N: usize>(
    fk: &mut ForwardKinematics<f32, N>,
    robot: &Arm<N>,
    q: *const f32,
    out: &mut [f32; 3],
    rot: &mut [f32; 9],
) -> Kc<()> {
    // SAFETY: the caller's contract.
    let q = unsafe { array_ref::<f32, N>(q) }?;
    fk.compute(robot, q);
    let f = fk.tool_pose(robot);
    *out = [f.o.x, f.o.y, f.o.z];
    *rot = rot_of(&f);
    finite(out)
}

/// As [`kc_fk_point`] (`KC_NOT_FINITE` likewise), also the tool orientation in the measurement
/// frame as a row-major rotation matrix into `rot_out[9]`: the measured frame's axes, i.e. the
/// flange axes times the model's tool axes (the robot file's `[tool] rpy_deg`, kept in the
/// binary model; a robot without one, e.g. from `kc_robot_init`, gives the flange axes). With
/// `xyz_out` the tool pose: the frame a pose `kc_target` means to `kc_compensate`, so that
/// handed back as a target from the same readings it is met at those readings.
///
/// # Safety
/// As [`kc_fk_point`]; `rot_out` is NULL or 9 floats.
#[no_mangle]
pub unsafe extern "C" fn kc_fk_pose(
    w: *mut kc_fk,
    r: *const kc_robot,
    q: *const f32,
    xyz_out: *mut f32,
    rot_out: *mut f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let ws = unsafe { handle::get_mut(w) }?;
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract (3 floats).
        let out = unsafe { array_mut::<f32, 3>(xyz_out) }?;
        // SAFETY: the header contract (9 floats).
        let rot = unsafe { array_mut::<f32, 9>(rot_out) }?;
        match robot {
            // SAFETY: the header contract (6 floats).
            Model::J6(m) => unsafe { fk_pose(ws.six()?, m, q, out, rot) },
            // SAFETY: the header contract (7 floats).
            Model::J7(m) => unsafe { fk_pose(ws.seven()?, m, q, out, rot) },
        }
    })())
}

/// The identification Jacobian at the pose of the last [`kc_fk_point`] / [`kc_fk_pose`] call
/// on `w` (with the same robot `r`; `KC_INVALID_ARGUMENT` when `w` last computed a robot of
/// another joint count): column `k` (∂ point / ∂ `params[k]`, mm per mm or per rad)
/// into `out[3*k + axis]`. `n` <= `KC_PARAMS_ALL`; `out_len` >= `3*n` (else
/// `KC_BUFFER_TOO_SMALL`). Converts the codes on every call: in a loop use
/// [`kc_fk_jacobian_set`].
///
/// # Safety
/// Handles NULL or valid; `params` NULL or `n` values; `out` NULL or `out_len` floats.
#[no_mangle]
pub unsafe extern "C" fn kc_fk_jacobian(
    w: *const kc_fk,
    r: *const kc_robot,
    params: *const kc_param,
    n: usize,
    out: *mut f32,
    out_len: usize,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let fk = unsafe { handle::get(w) }?;
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        if n > KC_PARAMS_ALL {
            return Err(KC_TOO_MANY_PARAMS);
        }
        // SAFETY: the header contract (`n` values).
        let codes = unsafe { slice_ref(params, n) }?;
        let mut set = [Param::BaseX; KC_PARAMS_ALL];
        for (s, c) in set.iter_mut().zip(codes) {
            *s = param_of(*c)?;
        }
        let set = set.get(..n).ok_or(KC_TOO_MANY_PARAMS)?;
        jacobian(fk, robot, set, out, out_len)
    })())
}

/// Bytes of a [`kc_param_set`] (see `KC_ROBOT_SIZE`).
pub const KC_PARAM_SET_SIZE: usize = 192;

/// A parameter set converted once for [`kc_fk_jacobian_set`] (`ParamSet<KC_PARAMS_ALL>`): the
/// per-call conversion of `kc_param` codes in [`kc_fk_jacobian`] costs about a quarter of a
/// 24-column Jacobian on a Cortex-M4F. Opaque, caller-owned; [`kc_param_set_init`].
#[repr(C, align(8))]
pub struct kc_param_set {
    _opaque: [u8; KC_PARAM_SET_SIZE],
}

handle!(
    kc_param_set,
    KC_PARAM_SET_SIZE,
    ParamSet<KC_PARAMS_ALL>,
    0x5050_5050
);

/// Converts the `n` codes `params` (at most `KC_PARAMS_ALL`; duplicates dropped, order kept)
/// into the set `s`. Errors: `KC_INVALID_ARGUMENT` (an unknown kind or a joint beyond 6),
/// `KC_TOO_MANY_PARAMS`; on error `s` is unchanged.
///
/// # Safety
/// `s` NULL or a writable `kc_param_set` not otherwise in use; `params` NULL or `n` values.
#[no_mangle]
pub unsafe extern "C" fn kc_param_set_init(
    s: *mut kc_param_set,
    params: *const kc_param,
    n: usize,
) -> kc_status {
    status((|| {
        if n > KC_PARAMS_ALL {
            return Err(KC_TOO_MANY_PARAMS);
        }
        // SAFETY: the header contract (`n` values).
        let codes = unsafe { slice_ref(params, n) }?;
        let mut set = ParamSet::new();
        for c in codes {
            set.push(param_of(*c)?).map_err(|_| KC_TOO_MANY_PARAMS)?;
        }
        // SAFETY: the header contract.
        let slot = unsafe { handle::uninit::<kc_param_set>(s) }?;
        handle::init::<kc_param_set>(slot, set);
        Ok(())
    })())
}

/// The number of parameters in `s` into `*count`.
///
/// # Safety
/// `s` NULL or valid; `count` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_param_set_len(s: *const kc_param_set, count: *mut usize) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let set = unsafe { handle::get(s) }?;
        // SAFETY: the header contract.
        *unsafe { crate::obj_mut(count) }? = set.len();
        Ok(())
    })())
}

/// As [`kc_fk_jacobian`] for a converted set: column `k` of the set's parameter `k` into
/// `out[3*k + axis]`, `out_len` >= 3 × the set's length. No per-call conversion: the cost of
/// the library's Jacobian plus the checks.
///
/// # Safety
/// Handles NULL or valid; `out` NULL or `out_len` floats.
#[no_mangle]
pub unsafe extern "C" fn kc_fk_jacobian_set(
    w: *const kc_fk,
    r: *const kc_robot,
    set: *const kc_param_set,
    out: *mut f32,
    out_len: usize,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let fk = unsafe { handle::get(w) }?;
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        let set = unsafe { handle::get(set) }?;
        jacobian(fk, robot, set.as_slice(), out, out_len)
    })())
}

/// The Jacobian columns of `set` into the caller's `out_len` floats, for a workspace and a
/// robot of the same joint count.
#[inline(always)]
fn jacobian(ws: &Workspace, robot: &Model, set: &[Param], out: *mut f32, out_len: usize) -> Kc<()> {
    match (ws, robot) {
        (Workspace::J6(fk), Model::J6(m)) => columns(fk, m, set, out, out_len),
        (Workspace::J7(fk), Model::J7(m)) => columns(fk, m, set, out, out_len),
        _ => Err(KC_INVALID_ARGUMENT),
    }
}

#[inline(always)]
fn columns<const N: usize>(
    fk: &ForwardKinematics<f32, N>,
    robot: &Arm<N>,
    set: &[Param],
    out: *mut f32,
    out_len: usize,
) -> Kc<()> {
    let n = set.len();
    if out_len / 3 < n {
        return Err(KC_BUFFER_TOO_SMALL);
    }
    // SAFETY: the caller's contract gives `out_len` >= 3n writable floats, and a
    // `Vector3<f32>` is three floats with the alignment of one (asserted above).
    let cols = unsafe { slice_mut(out.cast::<Vector3<f32>>(), n) }?;
    fk.identification_jacobian(robot, set, cols)
        .map_err(|_| KC_INVALID_ARGUMENT)
}
