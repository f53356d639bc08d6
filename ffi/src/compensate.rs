//! Compensation: the joint command that brings the identified robot to a target
//! (`kc_compensate`), the target to send to a controller that keeps its nominal kinematics
//! (`kc_compensate_cartesian`), and the streaming form along a trajectory (`kc_tracker`:
//! `Tracker<f32, 6 or 7>`).

use crate::handle::{self, handle};
use crate::robot::{frame_of, kc_robot, rot_of, Arm, Model};
use crate::KC_NOT_INITIALIZED;
use crate::{all_finite, array_ref, obj_mut, obj_ref, status, Kc, KC_MAX_JOINTS};
use crate::{kc_status, KC_COMPENSATE_FAILED, KC_INVALID_ARGUMENT, KC_NOT_FINITE};
use kinecal::compensate::{
    compensate, nominal_reach, CompensateError, Config, Solution, Status, Target, Tracker,
};
use nalgebra::Vector3;

/// The codes of `kc_target.kind`.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum kc_target_kind {
    /// Only the point (3 equations).
    KC_TARGET_POINT = 0,
    /// Point and tool orientation (6 equations).
    KC_TARGET_POSE = 1,
}

/// Where the tool should go, in the measurement frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_target {
    /// A `kc_target_kind`.
    pub kind: u8,
    /// The point, mm.
    pub xyz_mm: [f32; 3],
    /// Pose targets only: the tool orientation (the flange axes times the model's tool axes,
    /// as `kc_fk_pose` gives them) as a row-major rotation matrix (not checked to be one: the
    /// command stays within the step box of the seed whatever the target). Ignored for point
    /// targets.
    pub rot: [f32; 9],
}

/// Tuning of the Newton iteration and of its safety checks (the library's `Config<f32>`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct kc_compensate_config {
    /// Most Newton steps per call (1 ..= 255), each one forward kinematics. Default 8.
    pub iterations: u32,
    /// Damping floor (mm), >= 0. Default 0.1.
    pub damping_mm: f32,
    /// Stop early once the residual is below this (mm, orientation scaled), >= 0. Default 1e-5.
    pub tolerance_mm: f32,
    /// A residual above this after the iterations is not a success (mm), > 0. Default 0.01.
    pub accept_mm: f32,
    /// Per-joint bound on |command − seed| (rad), > 0. Default 2° (0.0349).
    pub max_step_rad: f32,
    /// Length scale (mm per rad) of orientation errors in pose targets; 0 = the robot's reach
    /// (the default). > 0 otherwise.
    pub orientation_scale_mm: f32,
    /// Singular when the scaled Jacobian's conditioning falls below `singular · reach`, >= 0.
    /// Default 0.01.
    pub singular: f32,
    /// 1: the model is compensated at `temperature_c` (its thermal-expansion term, if it has
    /// one, scales every length by 1 + c·(T − T0)); 0 (the default, and what a zeroed
    /// configuration says): at the term's reference temperature T0.
    pub at_temperature: u8,
    /// The temperature (°C) when `at_temperature` is 1, finite: the controller's sensor.
    /// Default 0 (not read).
    pub temperature_c: f32,
}

impl From<Config<f32>> for kc_compensate_config {
    fn from(c: Config<f32>) -> Self {
        Self {
            iterations: u32::from(c.iterations),
            damping_mm: c.damping,
            tolerance_mm: c.tolerance,
            accept_mm: c.accept,
            max_step_rad: c.max_step,
            orientation_scale_mm: c.orientation_scale.unwrap_or(0.0),
            singular: c.singular,
            at_temperature: u8::from(c.temperature_c.is_some()),
            temperature_c: c.temperature_c.unwrap_or(0.0),
        }
    }
}

fn config_of(c: &kc_compensate_config) -> Kc<Config<f32>> {
    crate::finite(&[
        c.damping_mm,
        c.tolerance_mm,
        c.accept_mm,
        c.max_step_rad,
        c.orientation_scale_mm,
        c.singular,
        c.temperature_c,
    ])?;
    let iterations = u8::try_from(c.iterations).map_err(|_| KC_INVALID_ARGUMENT)?;
    if iterations == 0 || c.orientation_scale_mm < 0.0 || c.at_temperature > 1 {
        return Err(KC_INVALID_ARGUMENT);
    }
    let cfg = Config {
        iterations,
        damping: c.damping_mm,
        tolerance: c.tolerance_mm,
        accept: c.accept_mm,
        max_step: c.max_step_rad,
        orientation_scale: if c.orientation_scale_mm == 0.0 {
            None
        } else {
            Some(c.orientation_scale_mm)
        },
        singular: c.singular,
        temperature_c: (c.at_temperature == 1).then_some(c.temperature_c),
    };
    if cfg.is_valid() {
        Ok(cfg)
    } else {
        Err(KC_INVALID_ARGUMENT)
    }
}

/// The settings of a call: the caller's, or the defaults for NULL.
///
/// # Safety
/// `cfg` is NULL or a valid `kc_compensate_config`.
#[inline(always)]
unsafe fn config_or_default(cfg: *const kc_compensate_config) -> Kc<Config<f32>> {
    if cfg.is_null() {
        Ok(Config::default())
    } else {
        // SAFETY: non-NULL, the caller's contract.
        config_of(unsafe { obj_ref(cfg) }?)
    }
}

/// The library's default settings.
///
/// # Safety
/// `out` is NULL or a writable `kc_compensate_config`.
#[no_mangle]
pub unsafe extern "C" fn kc_compensate_config_default(out: *mut kc_compensate_config) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        *unsafe { obj_mut(out) }? = Config::<f32>::default().into();
        Ok(())
    })())
}

/// The outcome class of a compensation (`kc_solution.status`).
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum kc_solution_status {
    /// The target is met within `accept_mm` at a well-conditioned pose.
    KC_SOLUTION_OK = 0,
    /// The Jacobian at the answer is (nearly) rank-deficient: a singularity.
    KC_SOLUTION_SINGULAR = 1,
    /// The residual did not converge, or the target is beyond the arm's reach.
    KC_SOLUTION_UNREACHABLE = 2,
    /// A joint limit or the step bound stops the joints that would reduce the residual.
    KC_SOLUTION_LIMITED = 3,
}

/// A joint command and how well it meets the target on the model.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_solution {
    /// The joint command (rad): within `max_step_rad` of the seed and inside the joint limits;
    /// the robot's joints first, the rest 0.
    pub q: [f32; KC_MAX_JOINTS],
    /// |target point − model point at q| (mm).
    pub position_error_mm: f32,
    /// Angle between target and model tool orientation at q (rad); 0 for point targets.
    pub orientation_error_rad: f32,
    /// Conditioning of the scaled Jacobian at q (mm/rad).
    pub sigma: f32,
    /// Newton steps tried.
    pub iterations: u32,
    /// A `kc_solution_status`.
    pub status: u8,
}

#[inline(always)]
fn solution_of<const N: usize>(s: &Solution<f32, N>, st: kc_solution_status) -> kc_solution {
    let mut q = [0.0; KC_MAX_JOINTS];
    for (o, v) in q.iter_mut().zip(&s.q) {
        *o = *v;
    }
    kc_solution {
        q,
        position_error_mm: s.position_error,
        orientation_error_rad: s.orientation_error,
        sigma: s.sigma,
        iterations: u32::from(s.iterations),
        status: st as u8,
    }
}

/// The library target of a C one (`KC_INVALID_ARGUMENT` for an unknown kind). A pose's matrix
/// is not checked to be a rotation (100 instructions a tick on the M4F; the library does not
/// need it: the command stays in the step box whatever the target); NaN is the library's to
/// refuse.
#[inline(always)]
fn target_of(t: &kc_target) -> Kc<Target<f32>> {
    const POINT: u8 = kc_target_kind::KC_TARGET_POINT as u8;
    const POSE: u8 = kc_target_kind::KC_TARGET_POSE as u8;
    match t.kind {
        POINT => Ok(Target::Point(Vector3::from(t.xyz_mm))),
        POSE => Ok(Target::Pose(frame_of(&t.xyz_mm, &t.rot))),
        _ => Err(KC_INVALID_ARGUMENT),
    }
}

/// The matrix of a pose target (nothing for a point target: its matrix is ignored).
fn pose_rot(t: &kc_target) -> &[f32] {
    if t.kind == kc_target_kind::KC_TARGET_POSE as u8 {
        &t.rot
    } else {
        &[]
    }
}

/// The status of a compensation result, `*out` written when a command was computed.
#[inline(always)]
fn finish<const N: usize>(
    r: Result<Solution<f32, N>, CompensateError<f32, N>>,
    out: &mut kc_solution,
    inputs: &[&[f32]],
) -> Kc<()> {
    let (s, st) = match &r {
        Ok(s) => (s, kc_solution_status::KC_SOLUTION_OK),
        Err(CompensateError::Singular(s)) => (s, kc_solution_status::KC_SOLUTION_SINGULAR),
        Err(CompensateError::Unreachable(s)) => (s, kc_solution_status::KC_SOLUTION_UNREACHABLE),
        Err(CompensateError::Limited(s)) => (s, kc_solution_status::KC_SOLUTION_LIMITED),
        Err(CompensateError::InvalidInput) => {
            // Nothing was computed: say whether a NaN or a range caused it.
            return Err(if inputs.iter().all(|v| all_finite(v)) {
                KC_INVALID_ARGUMENT
            } else {
                KC_NOT_FINITE
            });
        }
    };
    *out = solution_of(s, st);
    if matches!(Status::of(&r), Status::Ok) {
        Ok(())
    } else {
        Err(KC_COMPENSATE_FAILED)
    }
}

/// Compensation of `robot` towards the caller's target from its `N` seed readings.
///
/// # Safety
/// `seed` is NULL or `N` floats.
#[inline(always)]
unsafe fn compensate_n<const N: usize>(
    robot: &Arm<N>,
    t: &kc_target,
    seed: *const f32,
    cfg: &Config<f32>,
    out: &mut kc_solution,
) -> Kc<[f32; N]> {
    // SAFETY: the caller's contract.
    let seed = unsafe { array_ref::<f32, N>(seed) }?;
    let target = target_of(t)?;
    let r = compensate(robot, &target, seed, cfg);
    // Used only on success (`finish` returns the failure otherwise).
    let q = r.as_ref().map(|s| s.q).unwrap_or(*seed);
    finish(r, out, &[seed, &t.xyz_mm, pose_rot(t)])?;
    Ok(q)
}

/// The joint command (from the seed `seed[n]`, n = the robot's joints, e.g. the nominal
/// inverse kinematics) that brings the model `r` to `target`, with the settings `cfg` (NULL =
/// defaults), into `*out`.
///
/// `KC_OK`: the target is met. `KC_COMPENSATE_FAILED`: it is not (singular, unreachable,
/// limited: `out->status`); `*out` holds the best safe command (within the step box around the
/// seed; a seed beyond a joint limit by more than `max_step` gets the command `max_step` towards
/// the range, still beyond the limit: `LIMITED`, creep or stop, the controller's limit check
/// decides). `KC_NOT_FINITE` / `KC_INVALID_ARGUMENT` (NaN, a bad setting, a target more than 1000
/// reaches away, an unknown target kind, NaN in a pose's matrix): nothing was
/// computed and `*out` is unchanged: hold the previous command.
///
/// # Safety
/// Handles and pointers NULL or valid for their types and sizes; `out` writable.
#[no_mangle]
pub unsafe extern "C" fn kc_compensate(
    r: *const kc_robot,
    target: *const kc_target,
    seed: *const f32,
    cfg: *const kc_compensate_config,
    out: *mut kc_solution,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        let t = unsafe { obj_ref(target) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        // SAFETY: the header contract.
        let cfg = unsafe { config_or_default(cfg) }?;
        match robot {
            // SAFETY: the header contract (6 seed readings).
            Model::J6(m) => unsafe { compensate_n(m, t, seed, &cfg, out) }.map(|_| ()),
            // SAFETY: the header contract (7 seed readings).
            Model::J7(m) => unsafe { compensate_n(m, t, seed, &cfg, out) }.map(|_| ()),
        }
    })())
}

/// The target the nominal robot reaches at the command `q`, as a C target.
#[inline(always)]
fn sent_of<const N: usize>(
    model: &Arm<N>,
    nominal: &Arm<N>,
    pose: bool,
    q: &[f32; N],
) -> kc_target {
    match nominal_reach(model, nominal, pose, q) {
        Target::Point(p) => kc_target {
            kind: kc_target_kind::KC_TARGET_POINT as u8,
            xyz_mm: [p.x, p.y, p.z],
            rot: [0.0; 9],
        },
        Target::Pose(f) => kc_target {
            kind: kc_target_kind::KC_TARGET_POSE as u8,
            xyz_mm: [f.o.x, f.o.y, f.o.z],
            rot: rot_of(&f),
        },
    }
}

/// For a controller that keeps its nominal kinematics: compensates `target` on the model `r`
/// as [`kc_compensate`] does (`*out`), and on success writes into `*sent` the target to send
/// instead: where the `nominal` robot, placed at `r`'s base, puts the tool at that command (the
/// point for a point target; point and tool orientation for a pose target). The controller's
/// own inverse kinematics of `*sent` then moves the real robot to `target`. Only the nominal
/// robot's geometry and tool are used as the controller has them (its base is `r`'s).
///
/// Results and errors as [`kc_compensate`], and `KC_INVALID_ARGUMENT` when the two robots
/// have different joint counts; `*sent` is written only with `KC_OK`.
///
/// # Safety
/// Handles and pointers NULL or valid for their types and sizes; `out` and `sent` writable.
#[no_mangle]
pub unsafe extern "C" fn kc_compensate_cartesian(
    r: *const kc_robot,
    nominal: *const kc_robot,
    target: *const kc_target,
    seed: *const f32,
    cfg: *const kc_compensate_config,
    out: *mut kc_solution,
    sent: *mut kc_target,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        let nominal = unsafe { handle::get(nominal) }?;
        // SAFETY: the header contract.
        let t = unsafe { obj_ref(target) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        // SAFETY: the header contract.
        let sent = unsafe { obj_mut(sent) }?;
        // SAFETY: the header contract.
        let cfg = unsafe { config_or_default(cfg) }?;
        let pose = t.kind == kc_target_kind::KC_TARGET_POSE as u8;
        *sent = match (robot, nominal) {
            (Model::J6(m), Model::J6(n)) => {
                // SAFETY: the header contract (6 seed readings).
                let q = unsafe { compensate_n(m, t, seed, &cfg, out) }?;
                sent_of(m, n, pose, &q)
            }
            (Model::J7(m), Model::J7(n)) => {
                // SAFETY: the header contract (7 seed readings).
                let q = unsafe { compensate_n(m, t, seed, &cfg, out) }?;
                sent_of(m, n, pose, &q)
            }
            _ => return Err(KC_INVALID_ARGUMENT),
        };
        Ok(())
    })())
}

/// Bytes of a [`kc_tracker`] (see `KC_ROBOT_SIZE`).
pub const KC_TRACKER_SIZE: usize = 112;

/// Streaming compensation along a trajectory (`Tracker<f32, N>`): keeps the previous command
/// and starts each cycle from it. It takes the joint count of the robot it is used with (a
/// robot of another count starts a new trajectory). Opaque, caller-owned; [`kc_tracker_init`].
#[repr(C, align(8))]
pub struct kc_tracker {
    _opaque: [u8; KC_TRACKER_SIZE],
}

/// The tracker behind a [`kc_tracker`], for the joint count of its trajectory.
pub(crate) enum Trackers {
    /// Of a six-joint robot.
    J6(Tracker<f32, 6>),
    /// Of a seven-joint robot.
    J7(Tracker<f32, 7>),
}

impl Trackers {
    /// The six-joint tracker (a new trajectory with the same settings if it held the other).
    #[inline(always)]
    fn six(&mut self) -> Kc<&mut Tracker<f32, 6>> {
        if let Trackers::J7(t) = self {
            *self = Trackers::J6(Tracker::new(t.config));
        }
        match self {
            Trackers::J6(t) => Ok(t),
            Trackers::J7(_) => Err(KC_NOT_INITIALIZED),
        }
    }

    /// The seven-joint tracker (a new trajectory with the same settings if it held the other).
    #[inline(always)]
    fn seven(&mut self) -> Kc<&mut Tracker<f32, 7>> {
        if let Trackers::J6(t) = self {
            *self = Trackers::J7(Tracker::new(t.config));
        }
        match self {
            Trackers::J7(t) => Ok(t),
            Trackers::J6(_) => Err(KC_NOT_INITIALIZED),
        }
    }
}

handle!(kc_tracker, KC_TRACKER_SIZE, Trackers, 0x5454_5454);

/// A tracker with no trajectory yet and the settings `cfg` (NULL = defaults). Errors:
/// `KC_INVALID_ARGUMENT` / `KC_NOT_FINITE` (settings); on error `t` is unchanged.
///
/// # Safety
/// `t` NULL or a writable `kc_tracker` not otherwise in use; `cfg` NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn kc_tracker_init(
    t: *mut kc_tracker,
    cfg: *const kc_compensate_config,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let cfg = unsafe { config_or_default(cfg) }?;
        // SAFETY: the header contract.
        let slot = unsafe { handle::uninit::<kc_tracker>(t) }?;
        handle::init::<kc_tracker>(slot, Trackers::J6(Tracker::new(cfg)));
        Ok(())
    })())
}

/// Forgets the trajectory (the next call starts from its seed).
///
/// # Safety
/// `t` NULL or valid and not otherwise in use.
#[no_mangle]
pub unsafe extern "C" fn kc_tracker_reset(t: *mut kc_tracker) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        match unsafe { handle::get_mut(t) }? {
            Trackers::J6(t) => t.reset(),
            Trackers::J7(t) => t.reset(),
        }
        Ok(())
    })())
}

/// One tracker cycle with the nominal readings.
///
/// # Safety
/// `nominal` is NULL or `N` floats.
#[inline(always)]
unsafe fn next_n<const N: usize>(
    tracker: &mut Tracker<f32, N>,
    robot: &Arm<N>,
    tg: &kc_target,
    nominal: *const f32,
    out: &mut kc_solution,
) -> Kc<()> {
    // SAFETY: the caller's contract.
    let nominal = unsafe { array_ref::<f32, N>(nominal) }?;
    let target = target_of(tg)?;
    let r = tracker.next(robot, &target, nominal);
    finish(r, out, &[nominal, &tg.xyz_mm, pose_rot(tg)])
}

/// One trajectory point: `target` with the controller's nominal inverse kinematics
/// `nominal[n]` (n = the robot's joints) for it. The step box is centred on `nominal`; the
/// iteration starts from the previous correction carried over. Results and errors as
/// [`kc_compensate`]; after `KC_COMPENSATE_FAILED` the tracker continues from the best safe
/// command, after the other errors it is unchanged.
///
/// # Safety
/// Handles and pointers NULL or valid for their types and sizes; `t` and `out` writable.
#[no_mangle]
pub unsafe extern "C" fn kc_tracker_next(
    t: *mut kc_tracker,
    r: *const kc_robot,
    target: *const kc_target,
    nominal: *const f32,
    out: *mut kc_solution,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let tracker = unsafe { handle::get_mut(t) }?;
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        let tg = unsafe { obj_ref(target) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        match robot {
            // SAFETY: the header contract (6 readings).
            Model::J6(m) => unsafe { next_n(tracker.six()?, m, tg, nominal, out) },
            // SAFETY: the header contract (7 readings).
            Model::J7(m) => unsafe { next_n(tracker.seven()?, m, tg, nominal, out) },
        }
    })())
}

/// Starts a trajectory of robot `r` at the joints' current position `q[n]` (n = the robot's
/// joints), for [`kc_tracker_follow`]. `KC_NOT_FINITE` on NaN (tracker unchanged).
///
/// # Safety
/// `t` NULL or valid and not otherwise in use; `r` NULL or valid; `q` NULL or n floats.
#[no_mangle]
pub unsafe extern "C" fn kc_tracker_start(
    t: *mut kc_tracker,
    r: *const kc_robot,
    q: *const f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let tracker = unsafe { handle::get_mut(t) }?;
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        match robot.joints() {
            6 => {
                // SAFETY: the header contract (6 floats).
                let q = unsafe { array_ref::<f32, 6>(q) }?;
                tracker.six()?.start(q).map_err(|_| KC_NOT_FINITE)
            }
            _ => {
                // SAFETY: the header contract (7 floats).
                let q = unsafe { array_ref::<f32, 7>(q) }?;
                tracker.seven()?.start(q).map_err(|_| KC_NOT_FINITE)
            }
        }
    })())
}

/// One trajectory point without a nominal solution: the previous command is the seed, so the
/// joints move at most `max_step_rad` per cycle. Needs [`kc_tracker_start`] or an earlier
/// [`kc_tracker_next`] with a robot of the same joint count (else `KC_INVALID_ARGUMENT`).
/// Results as [`kc_compensate`].
///
/// # Safety
/// As [`kc_tracker_next`].
#[no_mangle]
pub unsafe extern "C" fn kc_tracker_follow(
    t: *mut kc_tracker,
    r: *const kc_robot,
    target: *const kc_target,
    out: *mut kc_solution,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let tracker = unsafe { handle::get_mut(t) }?;
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        let tg = unsafe { obj_ref(target) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(out) }?;
        let target = target_of(tg)?;
        match robot {
            Model::J6(m) => {
                let r = tracker.six()?.follow(m, &target);
                finish(r, out, &[&tg.xyz_mm, pose_rot(tg)])
            }
            Model::J7(m) => {
                let r = tracker.seven()?.follow(m, &target);
                finish(r, out, &[&tg.xyz_mm, pose_rot(tg)])
            }
        }
    })())
}
