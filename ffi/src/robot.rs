//! Robots (`kc_robot`: a `Robot<f32, 6 or 7, Inline<KC_MAX_EFFECT_VALUES>>`: geometry, joint
//! corrections, couplings), loading a binary model (`kc_robot_load`) and parameter codes
//! (`kc_param`).

use crate::handle::{self, handle};
use crate::{array_mut, array_ref, finite, obj_mut, obj_ref, slice_mut, status, Kc};
use crate::{kc_status, KC_BUFFER_TOO_SMALL, KC_INVALID_ARGUMENT, KC_INVALID_ROBOT};
use crate::{slice_ref, KC_MODEL_INVALID, KC_NOT_FINITE};
use crate::{KC_JOINTS, KC_MAX_JOINTS};
use kinecal::io::model_blob::{self, BlobError};
use kinecal::model::param::ParamSet;
use kinecal::{Frame, Joint, Param, Robot, RobotError};
use nalgebra::Vector3;

/// One joint's modified Denavit–Hartenberg row (Craig) plus the Hayati tilt `beta`:
/// `T_i(q) = Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta + q)·Tz(d)`, and the joint limits.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_joint_row {
    /// Twist about the previous frame's x axis (Craig's `alpha_{i-1}`), rad.
    pub alpha_rad: f32,
    /// Length along the previous frame's x axis (Craig's `a_{i-1}`), mm.
    pub a_mm: f32,
    /// Offset added to the joint angle, rad.
    pub theta_rad: f32,
    /// Offset along the joint axis z, mm.
    pub d_mm: f32,
    /// Hayati tilt about the y axis after `a`, rad (0 in a plain MDH row).
    pub beta_rad: f32,
    /// Lower joint limit, rad (`lower_rad < upper_rad`).
    pub lower_rad: f32,
    /// Upper joint limit, rad.
    pub upper_rad: f32,
}

/// A pose: translation (mm) and fixed-axis roll (x), pitch (y), yaw (z) in rad,
/// `R = Rz(yaw)·Ry(pitch)·Rx(roll)` (the robot file's `rpy_deg` convention, in radians).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_frame {
    /// Origin, mm.
    pub xyz_mm: [f32; 3],
    /// Roll, pitch, yaw, rad.
    pub rpy_rad: [f32; 3],
}

/// Room for joint-correction values in a [`kc_robot`] (every effect's values together: a
/// `joint-table`'s knots, a `joint-cyclic`'s two terms, …); at most 32 effects.
pub const KC_MAX_EFFECT_VALUES: usize = 1024;

/// A library robot of `N` joints as a [`kc_robot`] holds it.
pub(crate) type Arm<const N: usize> = Robot<f32, N, kinecal::Inline<KC_MAX_EFFECT_VALUES>>;

/// The library robot behind a [`kc_robot`]: 6 or 7 joints.
#[derive(Clone)]
pub(crate) enum Model {
    /// A six-joint arm.
    J6(Arm<6>),
    /// A seven-joint arm.
    J7(Arm<7>),
}

/// `$body` with `$r` bound to the robot of a [`Model`] (or of a `&Model`, `&mut Model`),
/// whatever its joint count: the body is compiled once per count.
macro_rules! each_robot {
    ($m:expr, $r:ident => $body:expr) => {
        match $m {
            crate::robot::Model::J6($r) => $body,
            crate::robot::Model::J7($r) => $body,
        }
    };
}
pub(crate) use each_robot;

impl Model {
    /// The joint count.
    #[inline(always)]
    pub(crate) fn joints(&self) -> usize {
        match self {
            Model::J6(_) => 6,
            Model::J7(_) => 7,
        }
    }
}

/// Bytes of a [`kc_robot`] (the largest robot of the supported targets, rounded up to 8; a
/// compile-time assertion checks it fits).
pub const KC_ROBOT_SIZE: usize = 5160;

/// A robot (`Robot<f32, N, Inline<KC_MAX_EFFECT_VALUES>>`, N = 6 or 7): base pose, MDH rows, tool
/// point, joint corrections (effects), joint couplings. Opaque; caller-owned (a `static` in
/// firmware); [`kc_robot_init`] or [`kc_robot_load`] constructs it.
#[repr(C, align(8))]
pub struct kc_robot {
    _opaque: [u8; KC_ROBOT_SIZE],
}

handle!(kc_robot, KC_ROBOT_SIZE, Model, 0x5252_5252);

/// The library row of a C row (finite checked by the caller).
#[inline(always)]
pub(crate) fn joint_of(r: &kc_joint_row) -> Joint<f32> {
    Joint {
        alpha: r.alpha_rad,
        a: r.a_mm,
        theta: r.theta_rad,
        d: r.d_mm,
        beta: r.beta_rad,
        lower: r.lower_rad,
        upper: r.upper_rad,
    }
}

fn row_of(j: &Joint<f32>) -> kc_joint_row {
    kc_joint_row {
        alpha_rad: j.alpha,
        a_mm: j.a,
        theta_rad: j.theta,
        d_mm: j.d,
        beta_rad: j.beta,
        lower_rad: j.lower,
        upper_rad: j.upper,
    }
}

fn row_values(r: &kc_joint_row) -> [f32; 7] {
    [
        r.alpha_rad,
        r.a_mm,
        r.theta_rad,
        r.d_mm,
        r.beta_rad,
        r.lower_rad,
        r.upper_rad,
    ]
}

/// Status of a refused robot description (finiteness is checked before the library is called).
pub(crate) fn robot_error(e: RobotError) -> kc_status {
    match e {
        RobotError::NotFinite
        | RobotError::OutOfRange
        | RobotError::NotRotation
        | RobotError::BadCoupling(_)
        | RobotError::BadEffect(_) => KC_INVALID_ROBOT,
    }
}

/// A frame from a translation and a row-major rotation matrix (not checked).
#[inline(always)]
pub(crate) fn frame_of(xyz: &[f32; 3], rot: &[f32; 9]) -> Frame<f32> {
    Frame {
        x: Vector3::new(rot[0], rot[3], rot[6]),
        y: Vector3::new(rot[1], rot[4], rot[7]),
        z: Vector3::new(rot[2], rot[5], rot[8]),
        o: Vector3::new(xyz[0], xyz[1], xyz[2]),
    }
}

/// The row-major rotation matrix of a frame.
#[inline(always)]
pub(crate) fn rot_of(f: &Frame<f32>) -> [f32; 9] {
    [
        f.x.x, f.y.x, f.z.x, //
        f.x.y, f.y.y, f.z.y, //
        f.x.z, f.y.z, f.z.z,
    ]
}

/// A robot of `N` joints from the caller's rows, base and tool (NULL: identity, flange origin).
///
/// # Safety
/// `rows` is NULL or `N` rows; `base` NULL or a frame; `tool_mm` NULL or 3 floats.
unsafe fn build<const N: usize>(
    rows: *const kc_joint_row,
    base: *const kc_frame,
    tool_mm: *const f32,
) -> Kc<Arm<N>> {
    // SAFETY: the caller passes `N` rows (header contract: the robot's joint count).
    let rows: &[kc_joint_row; N] = unsafe { array_ref(rows) }?;
    for row in rows {
        finite(&row_values(row))?;
    }
    let base = if base.is_null() {
        Frame::identity()
    } else {
        // SAFETY: non-NULL: a kc_frame per the header.
        let b = unsafe { obj_ref(base) }?;
        finite(&b.xyz_mm)?;
        finite(&b.rpy_rad)?;
        Frame::from_xyz_rpy(b.xyz_mm, b.rpy_rad)
    };
    let tool = if tool_mm.is_null() {
        [0.0; 3]
    } else {
        // SAFETY: non-NULL: 3 floats per the header.
        *unsafe { array_ref::<f32, 3>(tool_mm) }?
    };
    finite(&tool)?;
    Robot::new(base, rows.map(|r| joint_of(&r)), Vector3::from(tool)).map_err(robot_error)
}

unsafe fn robot_init(
    r: *mut kc_robot,
    joints: u32,
    rows: *const kc_joint_row,
    base: *const kc_frame,
    tool_mm: *const f32,
) -> Kc<()> {
    let robot = match joints {
        // SAFETY: forwarded contract (6 rows).
        6 => Model::J6(unsafe { build::<6>(rows, base, tool_mm) }?),
        // SAFETY: forwarded contract (7 rows).
        7 => Model::J7(unsafe { build::<7>(rows, base, tool_mm) }?),
        _ => return Err(KC_INVALID_ARGUMENT),
    };
    // SAFETY: the header contract: `r` is NULL or a writable kc_robot not otherwise borrowed.
    let slot = unsafe { handle::uninit::<kc_robot>(r) }?;
    handle::init::<kc_robot>(slot, robot);
    Ok(())
}

/// Builds a robot in `r` of `joints` joints (6 or 7) from its MDH rows (`rows[joints]`; an
/// array of `KC_MAX_JOINTS` does), the base pose (`base`: the robot base frame in the
/// measurement frame; NULL = identity) and the tool point in the flange frame (`tool_mm[3]`;
/// NULL = the flange origin). No couplings, no joint corrections.
///
/// Errors: `KC_NULL_POINTER` (`r`, `rows`), `KC_INVALID_ARGUMENT` (`joints` not 6 or 7),
/// `KC_NOT_FINITE` (any value NaN or infinite), `KC_INVALID_ROBOT` (a length beyond ±1 km, an
/// angle beyond ±1e4 rad, `lower >= upper`). On error `r` is unchanged.
///
/// # Safety
/// Pointers are NULL or valid for the sizes above; `r` is not otherwise in use during the call.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_init(
    r: *mut kc_robot,
    joints: u32,
    rows: *const kc_joint_row,
    base: *const kc_frame,
    tool_mm: *const f32,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { robot_init(r, joints, rows, base, tool_mm) })
}

/// Copies robot `src` into `dst` (a new handle; `dst` may be initialised or not).
///
/// # Safety
/// Both are NULL or valid handles; they do not overlap.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_copy(dst: *mut kc_robot, src: *const kc_robot) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let s = unsafe { handle::get(src) }?;
        // SAFETY: the header contract; `dst` does not overlap `src`.
        let slot = unsafe { handle::uninit::<kc_robot>(dst) }?;
        handle::init::<kc_robot>(slot, s.clone());
        Ok(())
    })())
}

/// The status of a refused binary model.
fn blob_status(e: BlobError) -> kc_status {
    match e {
        BlobError::NotFinite => KC_NOT_FINITE,
        BlobError::Refused(_) => KC_INVALID_ROBOT,
        BlobError::BufferTooSmall { .. }
        | BlobError::Truncated
        | BlobError::NotAModel
        | BlobError::Version(_)
        | BlobError::Checksum
        | BlobError::Joints(_)
        | BlobError::Malformed
        | BlobError::UnknownRecord(_)
        | BlobError::Capacity => KC_MODEL_INVALID,
    }
}

unsafe fn robot_load(r: *mut kc_robot, blob: *const u8, len: usize) -> Kc<()> {
    // SAFETY: the header contract: `len` readable bytes.
    let blob = unsafe { slice_ref(blob, len) }?;
    let robot = match model_blob::joint_count(blob).map_err(blob_status)? {
        6 => Model::J6(decoded(blob)?),
        7 => Model::J7(decoded(blob)?),
        _ => return Err(KC_MODEL_INVALID),
    };
    // SAFETY: the header contract: `r` is NULL or a writable kc_robot not otherwise borrowed.
    let slot = unsafe { handle::uninit::<kc_robot>(r) }?;
    handle::init::<kc_robot>(slot, robot);
    Ok(())
}

/// The robot of `N` joints a binary model describes.
fn decoded<const N: usize>(blob: &[u8]) -> Kc<Arm<N>> {
    let zero = Joint::mdh(0.0, 0.0, 0.0, 0.0);
    let mut robot: Arm<N> =
        Robot::new(Frame::identity(), [zero; N], Vector3::zeros()).map_err(robot_error)?;
    model_blob::decode(blob, &mut robot).map_err(blob_status)?;
    Ok(robot)
}

/// Builds the robot in `r` (initialised or not) from a binary model written by `kinecal export
/// --format firmware` (`blob`, `len` bytes; docs/formats.md, "Binary model (.kcm)"): rows,
/// base, tool point(s) and orientation, joint corrections, couplings. Forward kinematics,
/// Jacobians, compensation and the tracker then honour its corrections and couplings.
///
/// Errors, `r` unchanged: `KC_NULL_POINTER` (`r`, or `blob` with `len` > 0),
/// `KC_MODEL_INVALID` (truncated, corrupted: CRC-32, another layout version, a joint count
/// other than 6 or 7, a record this library does not know, more than
/// `KC_MAX_EFFECT_VALUES` values, 32 effects or 4 couplings), `KC_NOT_FINITE` (a NaN or
/// infinite number), `KC_INVALID_ROBOT` (a model `kc_robot_init` would refuse, or effects a
/// robot file refuses: of the wrong shape, the same effect twice, an order, start or step on
/// a kind that has none).
///
/// # Safety
/// `r` is NULL or a writable `kc_robot` not otherwise in use; `blob` is NULL or `len` bytes.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_load(r: *mut kc_robot, blob: *const u8, len: usize) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { robot_load(r, blob, len) })
}

/// The number of joints of `r` (6 or 7) into `*n`: the entries of its joint arrays (readings,
/// rows, commands) that the functions read and write.
///
/// # Safety
/// `r` is NULL or a valid handle; `n` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_joints(r: *const kc_robot, n: *mut u32) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        *unsafe { obj_mut(n) }? = robot.joints() as u32;
        Ok(())
    })())
}

/// Replaces row `joint` (0-based) of `r`. Errors: `KC_INVALID_ARGUMENT` (joint beyond the
/// robot's),
/// `KC_NOT_FINITE`, `KC_INVALID_ROBOT` (as in [`kc_robot_init`]); on error `r` is unchanged.
///
/// # Safety
/// `r` is NULL or a valid handle not otherwise in use; `row` is NULL or a valid row.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_set_row(
    r: *mut kc_robot,
    joint: u32,
    row: *const kc_joint_row,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get_mut(r) }?;
        // SAFETY: the header contract.
        let row = unsafe { obj_ref(row) }?;
        let i = usize::try_from(joint).map_err(|_| KC_INVALID_ARGUMENT)?;
        if i >= robot.joints() {
            return Err(KC_INVALID_ARGUMENT);
        }
        finite(&row_values(row))?;
        each_robot!(robot, m => m.set_joint(i, joint_of(row)).map_err(robot_error))
    })())
}

/// Replaces the base pose of `r` with the translation `xyz_mm[3]` and the row-major rotation
/// matrix `rot[9]`. Errors: `KC_NOT_FINITE`, `KC_INVALID_ROBOT` (`rot` not a rotation: not
/// orthonormal and right-handed within 1e-4; origin beyond ±1 km); on error `r` is unchanged.
///
/// # Safety
/// `r` is NULL or a valid handle not otherwise in use; the arrays are NULL or of their sizes.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_set_base(
    r: *mut kc_robot,
    xyz_mm: *const f32,
    rot: *const f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get_mut(r) }?;
        // SAFETY: the header contract (3 floats).
        let xyz = unsafe { array_ref::<f32, 3>(xyz_mm) }?;
        // SAFETY: the header contract (9 floats).
        let rot = unsafe { array_ref::<f32, 9>(rot) }?;
        finite(xyz)?;
        finite(rot)?;
        each_robot!(robot, m => m.set_base(frame_of(xyz, rot)).map_err(robot_error))
    })())
}

/// Replaces the tool point (flange frame, mm) of `r`. Errors: `KC_NOT_FINITE`,
/// `KC_INVALID_ROBOT` (beyond ±1 km); on error `r` is unchanged.
///
/// # Safety
/// `r` is NULL or a valid handle not otherwise in use; `tool_mm` is NULL or 3 floats.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_set_tool(r: *mut kc_robot, tool_mm: *const f32) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get_mut(r) }?;
        // SAFETY: the header contract (3 floats).
        let t = unsafe { array_ref::<f32, 3>(tool_mm) }?;
        finite(t)?;
        each_robot!(robot, m => m.set_tool(Vector3::from(*t)).map_err(robot_error))
    })())
}

/// Couples joint `joint` to joint `from` (0-based): the model angle of `joint` is its
/// reading plus `ratio` times the reading of `from` (FANUC J3: `joint` 2, `from` 1, ratio 1).
/// Errors: `KC_NOT_FINITE` (ratio), `KC_INVALID_ROBOT` (an index beyond the joints, the same
/// joint, |ratio| > 1000, a joint coupled twice, a chain, more than 4 couplings); on error
/// `r` is unchanged.
///
/// # Safety
/// `r` is NULL or a valid handle not otherwise in use.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_set_coupling(
    r: *mut kc_robot,
    joint: u32,
    from: u32,
    ratio: f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get_mut(r) }?;
        finite(&[ratio])?;
        let j = usize::try_from(joint).map_err(|_| KC_INVALID_ROBOT)?;
        let f = usize::try_from(from).map_err(|_| KC_INVALID_ROBOT)?;
        each_robot!(robot, m => m.set_coupling(j, f, ratio).map_err(robot_error))
    })())
}

/// Reads back the rows (`out[n]`, n = the robot's joints; an array of `KC_MAX_JOINTS` does), the base pose (`base_out`, may be NULL; roll,
/// pitch, yaw as [`kc_frame`]) and the tool point (`tool_out[3]`, may be NULL) of `r`.
///
/// # Safety
/// `r` is NULL or a valid handle; the outputs are NULL or of their sizes.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_rows(
    r: *const kc_robot,
    out: *mut kc_joint_row,
    base_out: *mut kc_frame,
    tool_out: *mut f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract (as many rows as the robot has joints).
        let out = unsafe { slice_mut::<kc_joint_row>(out, robot.joints()) }?;
        each_robot!(robot, m => {
            for (o, j) in out.iter_mut().zip(m.joints()) {
                *o = row_of(j);
            }
            if !base_out.is_null() {
                // SAFETY: non-NULL: a kc_frame per the header.
                let b = unsafe { obj_mut(base_out) }?;
                let f = m.base();
                b.xyz_mm = [f.o.x, f.o.y, f.o.z];
                b.rpy_rad = f.rpy();
            }
            if !tool_out.is_null() {
                // SAFETY: non-NULL: 3 floats per the header.
                let t = unsafe { array_mut::<f32, 3>(tool_out) }?;
                *t = [m.tool().x, m.tool().y, m.tool().z];
            }
        });
        Ok(())
    })())
}

/// The base rotation of `r` as a row-major matrix (`rot_out[9]`) and its origin (`xyz_out[3]`).
///
/// # Safety
/// `r` is NULL or a valid handle; the outputs are NULL or of their sizes.
#[no_mangle]
pub unsafe extern "C" fn kc_robot_base(
    r: *const kc_robot,
    xyz_out: *mut f32,
    rot_out: *mut f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract (3 floats).
        let xyz = unsafe { array_mut::<f32, 3>(xyz_out) }?;
        // SAFETY: the header contract (9 floats).
        let rot = unsafe { array_mut::<f32, 9>(rot_out) }?;
        let f = each_robot!(robot, m => m.base());
        *xyz = [f.o.x, f.o.y, f.o.z];
        *rot = rot_of(f);
        Ok(())
    })())
}

/// A model parameter: `kind` is a `kc_param_kind`, `joint` the 0-based joint of the row
/// parameters (`KC_PARAM_ALPHA` … `KC_PARAM_BETA`; 0 for the others).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct kc_param {
    /// A `kc_param_kind`.
    pub kind: u8,
    /// Joint (0-based) of a row parameter.
    pub joint: u8,
}

/// The codes of `kc_param.kind`.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum kc_param_kind {
    /// Base origin x in the measurement frame, mm.
    KC_PARAM_BASE_X = 0,
    /// Base origin y, mm.
    KC_PARAM_BASE_Y = 1,
    /// Base origin z, mm.
    KC_PARAM_BASE_Z = 2,
    /// Base rotation about the measurement frame's x axis, rad.
    KC_PARAM_BASE_RX = 3,
    /// Base rotation about y, rad.
    KC_PARAM_BASE_RY = 4,
    /// Base rotation about z, rad.
    KC_PARAM_BASE_RZ = 5,
    /// `alpha` of a joint, rad.
    KC_PARAM_ALPHA = 6,
    /// `a` of a joint, mm.
    KC_PARAM_A = 7,
    /// `theta` (angle offset) of a joint, rad.
    KC_PARAM_THETA = 8,
    /// `d` of a joint, mm.
    KC_PARAM_D = 9,
    /// `beta` (Hayati tilt) of a joint, rad.
    KC_PARAM_BETA = 10,
    /// Tool point x in the flange frame, mm.
    KC_PARAM_TOOL_X = 11,
    /// Tool point y, mm.
    KC_PARAM_TOOL_Y = 12,
    /// Tool point z, mm.
    KC_PARAM_TOOL_Z = 13,
}

/// Every distinct parameter of a 7-joint robot: 6 base + 5 × 7 row + 3 tool (39 of a 6-joint
/// robot).
pub const KC_PARAMS_ALL: usize = 44;

/// The library parameter of a code (`KC_INVALID_ARGUMENT` for an unknown kind or a joint
/// beyond the robot's).
#[inline(always)]
pub(crate) fn param_of(p: kc_param) -> Kc<Param> {
    let j = p.joint;
    let row = |f: fn(u8) -> Param| {
        if (j as usize) < KC_MAX_JOINTS {
            Ok(f(j))
        } else {
            Err(KC_INVALID_ARGUMENT)
        }
    };
    match p.kind {
        0 => Ok(Param::BaseX),
        1 => Ok(Param::BaseY),
        2 => Ok(Param::BaseZ),
        3 => Ok(Param::BaseRx),
        4 => Ok(Param::BaseRy),
        5 => Ok(Param::BaseRz),
        6 => row(Param::Alpha),
        7 => row(Param::A),
        8 => row(Param::Theta),
        9 => row(Param::D),
        10 => row(Param::Beta),
        11 => Ok(Param::ToolX),
        12 => Ok(Param::ToolY),
        13 => Ok(Param::ToolZ),
        _ => Err(KC_INVALID_ARGUMENT),
    }
}

/// The code of a library parameter (effects do not exist in this ABI: kind 255).
pub(crate) fn code_of(p: Param) -> kc_param {
    let (kind, joint) = match p {
        Param::BaseX => (0, 0),
        Param::BaseY => (1, 0),
        Param::BaseZ => (2, 0),
        Param::BaseRx => (3, 0),
        Param::BaseRy => (4, 0),
        Param::BaseRz => (5, 0),
        Param::Alpha(j) => (6, j),
        Param::A(j) => (7, j),
        Param::Theta(j) => (8, j),
        Param::D(j) => (9, j),
        Param::Beta(j) => (10, j),
        Param::ToolX => (11, 0),
        Param::ToolY => (12, 0),
        Param::ToolZ => (13, 0),
        // Not in this ABI (one tool point, no tool orientation): as effects.
        Param::ToolPoint(..) | Param::ToolRx | Param::ToolRy | Param::ToolRz => (255, 0),
        Param::Effect(_) => (255, 0),
    };
    kc_param { kind, joint }
}

/// Writes a parameter set to the caller's array: `*count` = its length; `KC_BUFFER_TOO_SMALL`
/// (nothing written but the count) when `cap` is smaller.
unsafe fn write_params(
    params: &[Param],
    out: *mut kc_param,
    cap: usize,
    count: *mut usize,
) -> Kc<()> {
    // SAFETY: the header contract.
    let count = unsafe { obj_mut(count) }?;
    *count = params.len();
    if cap < params.len() {
        return Err(KC_BUFFER_TOO_SMALL);
    }
    // SAFETY: the header contract: `cap` writable kc_param.
    let out = unsafe { slice_mut(out, cap) }?;
    for (o, p) in out.iter_mut().zip(params) {
        *o = code_of(*p);
    }
    Ok(())
}

/// The 24-parameter set of the BPNN-PSO paper for a 6-joint robot: alpha, a, theta, d of every
/// joint, joint by joint, into `out[24]` (a 7-joint robot's 28: [`kc_params_full`]).
///
/// # Safety
/// `out` is NULL or 24 writable `kc_param`.
#[no_mangle]
pub unsafe extern "C" fn kc_params_mdh(out: *mut kc_param) -> kc_status {
    status((|| {
        let set = ParamSet::<24>::mdh(KC_JOINTS).map_err(|_| KC_INVALID_ARGUMENT)?;
        let mut n = 0usize;
        // SAFETY: the header contract: 24 writable kc_param; `n` is a local.
        unsafe { write_params(set.as_slice(), out, 24, &mut n) }
    })())
}

/// The full default set of a robot of `joints` joints (6 or 7): the base pose when
/// `base_unknown` is non-zero (6), alpha, a, theta, d of every joint (24 or 28) and the tool
/// point (3): 27, 33, 31 or 37 parameters. `*count` receives the length; `KC_BUFFER_TOO_SMALL`
/// (only the count written) when `cap` is smaller; `KC_INVALID_ARGUMENT` for another `joints`.
///
/// # Safety
/// `out` is NULL or `cap` writable `kc_param`; `count` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_params_full(
    joints: u32,
    base_unknown: u8,
    out: *mut kc_param,
    cap: usize,
    count: *mut usize,
) -> kc_status {
    status((|| {
        if !(6..=KC_MAX_JOINTS as u32).contains(&joints) {
            return Err(KC_INVALID_ARGUMENT);
        }
        let set = ParamSet::<KC_PARAMS_ALL>::full(joints as usize, base_unknown != 0)
            .map_err(|_| KC_INVALID_ARGUMENT)?;
        // SAFETY: forwarded contract.
        unsafe { write_params(set.as_slice(), out, cap, count) }
    })())
}
