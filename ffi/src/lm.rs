//! Identification: the Levenberg–Marquardt stepper (`kc_lm`: `Levenberg<f32, 6 or 7, 0,
//! FixedLm<f32, 24>>`), its snapshots, and the RMS error of a model over measurements.

use crate::handle::{self, handle};
use crate::robot::{code_of, each_robot, kc_param, kc_robot, param_of, Arm, Model};
use crate::KC_INVALID_ROBOT;
use crate::{
    kc_status, KC_BUFFER_TOO_SMALL, KC_DATA_CHANGED, KC_INVALID_ARGUMENT, KC_NOT_FINITE,
    KC_NOT_INITIALIZED, KC_SNAPSHOT_INVALID, KC_TOO_FEW_MEASUREMENTS, KC_TOO_MANY_PARAMS,
};
use crate::{obj_mut, obj_ref, slice_mut, slice_ref, status, Kc, KC_MAX_JOINTS};
use kinecal::identify::lm::{rms_error, FixedLm, Levenberg, LmConfig, LmError, LmProgress, LmStop};
use kinecal::io::snapshot::{Snapshot, SnapshotError};
use kinecal::model::param::{ParamError, ParamSet};
use kinecal::Observation;
use nalgebra::Vector3;

/// Room for identified parameters in a `kc_lm`: the 24 of the MDH set of a 6-joint robot
/// (`kc_params_mdh`), as the Rust firmware sizes its solver (same code, same instruction counts,
/// same RAM); a 7-joint robot's solver identifies at most 24 of its parameters too.
pub const KC_LM_MAX_PARAMS: usize = 24;

/// One measured pose: joint readings (rad, as the controller reports them) and the point the
/// tracker saw (mm, measurement frame): a plain position observation of the first tool point,
/// read by the solver in place.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_measurement {
    /// Joint readings, rad: the robot's joints first (a 6-joint robot ignores the last).
    pub q: [f32; KC_MAX_JOINTS],
    /// Measured point, mm.
    pub xyz_mm: [f32; 3],
}

impl kc_measurement {
    /// The readings of an `N`-joint robot (`N` <= `KC_MAX_JOINTS`: the only counts used).
    #[inline(always)]
    fn readings<const N: usize>(&self) -> &[f32; N] {
        const { assert!(N <= KC_MAX_JOINTS) };
        // SAFETY: `q` holds KC_MAX_JOINTS >= N floats (asserted at compile time), so its first
        // N form an `[f32; N]` with the same alignment, borrowed as long as `self`.
        unsafe { &*self.q.as_ptr().cast::<[f32; N]>() }
    }
}

impl Observation<f32, 6> for kc_measurement {
    #[inline(always)]
    fn q(&self) -> &[f32; 6] {
        self.readings()
    }
    #[inline(always)]
    fn point(&self) -> Vector3<f32> {
        Vector3::new(self.xyz_mm[0], self.xyz_mm[1], self.xyz_mm[2])
    }
    fn is_valid(&self) -> bool {
        self.readings::<6>()
            .iter()
            .chain(&self.xyz_mm)
            .all(|v| v.is_finite())
    }
}

impl Observation<f32, 7> for kc_measurement {
    #[inline(always)]
    fn q(&self) -> &[f32; 7] {
        self.readings()
    }
    #[inline(always)]
    fn point(&self) -> Vector3<f32> {
        Vector3::new(self.xyz_mm[0], self.xyz_mm[1], self.xyz_mm[2])
    }
    fn is_valid(&self) -> bool {
        self.readings::<7>()
            .iter()
            .chain(&self.xyz_mm)
            .all(|v| v.is_finite())
    }
}

/// The caller's measurements, in place.
///
/// # Safety
/// `data` is NULL or points to `n` readable `kc_measurement` not written during the borrow.
#[inline(always)]
unsafe fn measurements<'a>(data: *const kc_measurement, n: usize) -> Kc<&'a [kc_measurement]> {
    // SAFETY: the caller's contract.
    unsafe { slice_ref(data, n) }
}

/// The solver settings a firmware sets (the library's `LmConfig<f32>`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct kc_lm_config {
    /// Stop after this many accepted or rejected steps. Default 100.
    pub max_iterations: u32,
    /// Stop when a step lowers the cost by less than this fraction.
    pub cost_tolerance: f32,
    /// Stop when the scaled step is shorter than this (mm-equivalent).
    pub step_tolerance: f32,
    /// Relative pivot below which a parameter direction counts as unidentifiable, in (0, 1).
    pub rank_tolerance: f32,
    /// Ridge on the accumulated scaled update, relative to the mean diagonal of JᵀJ (>= 0).
    pub ridge: f32,
    /// Initial damping relative to the diagonal (> 0). Default 1e-3.
    pub initial_damping: f32,
    /// Relative pivot a held parameter needs to join on a re-analysis (>= 0).
    pub activation_tolerance: f32,
    /// Most identifiability analyses in one run (0: none, estimate every parameter).
    /// Default 8.
    pub max_analyses: u8,
    /// Non-zero: keep JᵀJ while steps succeed (cheaper refits). Default 0.
    pub keep_curvature: u8,
}

impl From<LmConfig<f32>> for kc_lm_config {
    fn from(c: LmConfig<f32>) -> Self {
        Self {
            max_iterations: c.max_iterations,
            cost_tolerance: c.cost_tolerance,
            step_tolerance: c.step_tolerance,
            rank_tolerance: c.rank_tolerance,
            ridge: c.ridge,
            initial_damping: c.initial_damping,
            activation_tolerance: c.activation_tolerance,
            max_analyses: c.max_analyses,
            keep_curvature: u8::from(c.keep_curvature),
        }
    }
}

fn lm_config_of(c: &kc_lm_config) -> Kc<LmConfig<f32>> {
    let cfg = LmConfig {
        max_iterations: c.max_iterations,
        cost_tolerance: c.cost_tolerance,
        step_tolerance: c.step_tolerance,
        rank_tolerance: c.rank_tolerance,
        ridge: c.ridge,
        initial_damping: c.initial_damping,
        max_analyses: c.max_analyses,
        activation_tolerance: c.activation_tolerance,
        keep_curvature: c.keep_curvature != 0,
        // The library's default: a controller's slices cost what they did.
        complete_passes: false,
    };
    crate::finite(&[
        c.cost_tolerance,
        c.step_tolerance,
        c.rank_tolerance,
        c.ridge,
        c.initial_damping,
        c.activation_tolerance,
    ])?;
    if cfg.is_valid() {
        Ok(cfg)
    } else {
        Err(KC_INVALID_ARGUMENT)
    }
}

/// The library's default settings (scaled to `float` precision).
///
/// # Safety
/// `out` is NULL or a writable `kc_lm_config`.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_config_default(out: *mut kc_lm_config) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        *unsafe { obj_mut(out) }? = LmConfig::<f32>::default().into();
        Ok(())
    })())
}

/// Why a run stopped (`kc_lm_progress.stopped`).
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum kc_lm_stop {
    /// Still running.
    KC_LM_RUNNING = 0,
    /// The cost stopped decreasing (relative change below tolerance).
    KC_LM_CONVERGED = 1,
    /// The step became negligibly small.
    KC_LM_SMALL_STEP = 2,
    /// The iteration limit was reached.
    KC_LM_MAX_ITERATIONS = 3,
    /// No step could lower the cost even with very strong damping.
    KC_LM_NO_PROGRESS = 4,
}

/// Where a run stands.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct kc_lm_progress {
    /// Accepted and rejected steps so far.
    pub iteration: u32,
    /// Full passes over all poses so far.
    pub evaluations: u32,
    /// Sum of squared residuals (mm²) at the current estimate (after the first pass).
    pub cost: f32,
    /// A `kc_lm_stop`: 0 while running.
    pub stopped: u8,
    /// 1 when the run stopped at a fixed point (`KC_LM_CONVERGED` or `KC_LM_SMALL_STEP`).
    pub converged: u8,
}

#[inline(always)]
fn progress_of(p: &LmProgress<f32>) -> kc_lm_progress {
    let stopped = match p.stopped {
        None => kc_lm_stop::KC_LM_RUNNING,
        Some(LmStop::Converged) => kc_lm_stop::KC_LM_CONVERGED,
        Some(LmStop::SmallStep) => kc_lm_stop::KC_LM_SMALL_STEP,
        Some(LmStop::MaxIterations) => kc_lm_stop::KC_LM_MAX_ITERATIONS,
        Some(LmStop::NoProgress) => kc_lm_stop::KC_LM_NO_PROGRESS,
    };
    kc_lm_progress {
        iteration: p.iteration,
        evaluations: p.evaluations,
        cost: p.cost,
        stopped: stopped as u8,
        converged: u8::from(matches!(
            stopped,
            kc_lm_stop::KC_LM_CONVERGED | kc_lm_stop::KC_LM_SMALL_STEP
        )),
    }
}

/// The solver of an `N`-joint robot with room for `P` parameters.
pub(crate) type Lm<const N: usize, const P: usize> = Levenberg<f32, N, 0, FixedLm<f32, P>>;

/// What a solver handle holds: its constructor's `Result`, for a 6- or 7-joint robot.
pub(crate) enum Solvers<const P: usize> {
    /// A six-joint robot's solver.
    J6(Result<Lm<6, P>, LmError>),
    /// A seven-joint robot's solver.
    J7(Result<Lm<7, P>, LmError>),
}

/// `$body` with `$s` bound to the solver of a `Solvers` (or `&`, `&mut`) that was built.
macro_rules! each_lm {
    ($m:expr, $s:ident => $body:expr) => {
        match $m {
            Solvers::J6(Ok($s)) => $body,
            Solvers::J7(Ok($s)) => $body,
            Solvers::J6(Err(_)) | Solvers::J7(Err(_)) => Err(KC_NOT_INITIALIZED),
        }
    };
}

/// A solver handle.
trait Solver<const P: usize>: handle::Handle<Inner = Solvers<P>> {}
impl<const P: usize, H: handle::Handle<Inner = Solvers<P>>> Solver<P> for H {}

/// Bytes of a [`kc_lm`] (see `KC_ROBOT_SIZE`).
pub const KC_LM_SIZE: usize = 9136;

/// A Levenberg–Marquardt identification (`Levenberg<f32, 6, 0, FixedLm<f32,
/// KC_LM_MAX_PARAMS>>`): a streaming stepper that does a bounded slice of work per
/// [`kc_lm_step`] call, snapshot and restore. Several KB: give it static storage. Room for
/// `KC_LM_MAX_PARAMS` parameters (the MDH set); [`kc_lm_full`] takes the base and the tool too.
#[repr(C, align(8))]
pub struct kc_lm {
    _opaque: [u8; KC_LM_SIZE],
}

// Built straight in place, no stack copy of the solver; an `Err` is never tagged initialised.
handle!(kc_lm, KC_LM_SIZE, Solvers<KC_LM_MAX_PARAMS>, 0x4c4c_4c4c);

/// Room for identified parameters in a `kc_lm_full`: every geometric parameter of a 7-joint
/// arm (`KC_PARAMS_ALL`: 6 base, 5 × 7 row, 3 tool; 39 of a 6-joint arm), for a firmware that also fits the base
/// pose and the tool point (`kc_params_full`).
#[cfg(feature = "lm-full")]
pub const KC_LM_FULL_MAX_PARAMS: usize = 44;

/// Bytes of a [`kc_lm_full`] (see `KC_ROBOT_SIZE`).
#[cfg(feature = "lm-full")]
pub const KC_LM_FULL_SIZE: usize = 21520;

/// As [`kc_lm`] with room for `KC_LM_FULL_MAX_PARAMS` parameters (twice the memory; the
/// `kc_lm_full_*` functions are those of `kc_lm`). Only in a static library built with the
/// cargo feature `lm-full` (and C code compiled with `-DKC_LM_FULL`): a second solver in the
/// library changes how LLVM inlines the shared solver code, and on the M4F a plain `kc_lm`
/// then spends ~12 % more instructions per pose (7,967 against 7,097).
#[cfg(feature = "lm-full")]
#[repr(C, align(8))]
pub struct kc_lm_full {
    _opaque: [u8; KC_LM_FULL_SIZE],
}

#[cfg(feature = "lm-full")]
handle!(
    kc_lm_full,
    KC_LM_FULL_SIZE,
    Solvers<KC_LM_FULL_MAX_PARAMS>,
    0x4c4d_4c46
);

fn lm_error(e: LmError) -> kc_status {
    match e {
        LmError::TooFewMeasurements => KC_TOO_FEW_MEASUREMENTS,
        LmError::DataChanged => KC_DATA_CHANGED,
        LmError::NonFiniteMeasurement => KC_NOT_FINITE,
        // A kc_measurement is always of the first point.
        LmError::UnknownToolPoint => KC_INVALID_ARGUMENT,
        LmError::Params(ParamError::Capacity) => KC_TOO_MANY_PARAMS,
        LmError::Config
        | LmError::Params(_)
        | LmError::PassMismatch
        | LmError::Penalty(_)
        | LmError::Started => KC_INVALID_ARGUMENT,
    }
}

/// # Safety
/// As [`kc_lm_init`].
/// A solver for `robot` with the parameter codes `codes`.
fn solver<const N: usize, const P: usize>(
    robot: &Arm<N>,
    codes: &[kc_param],
    cfg: &LmConfig<f32>,
) -> Kc<Result<Lm<N, P>, LmError>> {
    let mut set = ParamSet::<P>::new();
    for c in codes {
        set.push(param_of(*c)?).map_err(|_| KC_TOO_MANY_PARAMS)?;
    }
    set.check(robot).map_err(|_| KC_INVALID_ARGUMENT)?;
    // The solver identifies geometry: a robot with joint corrections is refused.
    let geometry = robot.with_capacity::<0>().map_err(|_| KC_INVALID_ROBOT)?;
    Ok(Levenberg::new(geometry, FixedLm::new(set), *cfg))
}

unsafe fn lm_init<H: Solver<P>, const P: usize>(
    lm: *mut H,
    start: *const kc_robot,
    params: *const kc_param,
    n: usize,
    cfg: *const kc_lm_config,
) -> Kc<()> {
    // SAFETY: the header contract.
    let robot = unsafe { handle::get(start) }?;
    if n == 0 {
        return Err(KC_INVALID_ARGUMENT);
    }
    if n > P {
        return Err(KC_TOO_MANY_PARAMS);
    }
    // SAFETY: the header contract (`n` values).
    let codes = unsafe { slice_ref(params, n) }?;
    let cfg = if cfg.is_null() {
        LmConfig::default()
    } else {
        // SAFETY: non-NULL: a kc_lm_config per the header.
        lm_config_of(unsafe { obj_ref(cfg) }?)?
    };
    let made = match robot {
        Model::J6(m) => Solvers::J6(solver(m, codes, &cfg)?),
        Model::J7(m) => Solvers::J7(solver(m, codes, &cfg)?),
    };
    // SAFETY: the header contract; `lm` is not the robot handle (distinct C types).
    let slot = unsafe { handle::uninit::<H>(lm) }?;
    let e = match handle::init::<H>(slot, made) {
        Solvers::J6(Err(e)) | Solvers::J7(Err(e)) => *e,
        Solvers::J6(Ok(_)) | Solvers::J7(Ok(_)) => return Ok(()),
    };
    handle::forget::<H>(slot);
    Err(lm_error(e))
}

#[inline(always)]
unsafe fn lm_step<H: Solver<P>, const P: usize>(
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

unsafe fn lm_progress<H: Solver<P>, const P: usize>(
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

unsafe fn lm_robot<H: Solver<P>, const P: usize>(lm: *const H, out: *mut kc_robot) -> Kc<()> {
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

unsafe fn lm_unidentifiable<H: Solver<P>, const P: usize>(
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

struct Count(usize);

impl embedded_io::ErrorType for Count {
    type Error = core::convert::Infallible;
}

impl embedded_io::Write for Count {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0 = self.0.saturating_add(buf.len());
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

fn snapshot_size<const N: usize, const P: usize>(lm: &Lm<N, P>) -> Kc<usize> {
    let mut c = Count(0);
    lm.save(&mut c).map_err(|_| KC_SNAPSHOT_INVALID)?;
    Ok(c.0)
}

unsafe fn lm_snapshot_size<H: Solver<P>, const P: usize>(lm: *const H, size: *mut usize) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get(lm) }?;
    // SAFETY: the header contract.
    let size = unsafe { obj_mut(size) }?;
    *size = each_lm!(lm, s => snapshot_size(s))?;
    Ok(())
}

fn save<const N: usize, const P: usize>(
    lm: &Lm<N, P>,
    buf: &mut [u8],
    written: &mut usize,
) -> Kc<()> {
    let cap = buf.len();
    let mut w: &mut [u8] = buf;
    match lm.save(&mut w) {
        Ok(()) => {
            *written = cap - w.len();
            Ok(())
        }
        Err(SnapshotError::Io) => {
            *written = snapshot_size(lm)?;
            Err(KC_BUFFER_TOO_SMALL)
        }
        Err(_) => Err(KC_SNAPSHOT_INVALID),
    }
}

unsafe fn lm_save<H: Solver<P>, const P: usize>(
    lm: *const H,
    buf: *mut u8,
    cap: usize,
    written: *mut usize,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get(lm) }?;
    // SAFETY: the header contract.
    let written = unsafe { obj_mut(written) }?;
    // SAFETY: the header contract (`cap` bytes).
    let buf: &mut [u8] = unsafe { slice_mut(buf, cap) }?;
    each_lm!(lm, s => save(s, buf, written))
}

unsafe fn lm_restore<H: Solver<P>, const P: usize>(
    lm: *mut H,
    buf: *const u8,
    len: usize,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get_mut(lm) }?;
    // SAFETY: the header contract (`len` bytes).
    let r: &[u8] = unsafe { slice_ref(buf, len) }?;
    each_lm!(lm, s => restore(s, r).map_err(|_| KC_SNAPSHOT_INVALID))
}

#[inline(never)]
fn restore<const N: usize, const P: usize>(
    lm: &mut Lm<N, P>,
    mut r: &[u8],
) -> Result<(), SnapshotError> {
    lm.restore(&mut r)
}

/// Starts an identification in `lm` from the model `start` (copied), estimating the `n`
/// parameters `params` (1 ..= `KC_LM_MAX_PARAMS`, duplicates ignored) with the settings `cfg`
/// (NULL = defaults). The solver is built in place in `lm`.
///
/// Errors: `KC_NULL_POINTER`, `KC_NOT_INITIALIZED` (`start`), `KC_TOO_MANY_PARAMS`,
/// `KC_INVALID_ARGUMENT` (no parameter, an unknown code or joint, invalid settings),
/// `KC_NOT_FINITE` (a setting). Checked before `lm` is written: on these errors `lm` is
/// unchanged.
///
/// # Safety
/// Handles NULL or valid (`lm` not otherwise in use); `params` NULL or `n` values; `cfg` NULL or
/// valid.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_init(
    lm: *mut kc_lm,
    start: *const kc_robot,
    params: *const kc_param,
    n: usize,
    cfg: *const kc_lm_config,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_init(lm, start, params, n, cfg) })
}

/// Does at most `budget_poses` poses of work (a solve counts as one and ends the call) over
/// the `n` measurements `data` and reports the progress in `*out`. Pass the same data (same
/// count) on every call of a run. The run is over when `out->stopped` is non-zero.
///
/// Errors: `KC_TOO_FEW_MEASUREMENTS` (fewer than `n_params / 3` poses), `KC_NOT_FINITE` (a
/// measurement holds NaN or infinity; checked on the first call), `KC_DATA_CHANGED` (another
/// count than on the first call). On error the solver is unchanged.
///
/// # Safety
/// `lm` NULL or valid and not otherwise in use; `data` NULL or `n` values not written during
/// the call; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_step(
    lm: *mut kc_lm,
    data: *const kc_measurement,
    n: usize,
    budget_poses: usize,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_step(lm, data, n, budget_poses, out) })
}

/// Where the run stands (as the last [`kc_lm_step`] reported it).
///
/// # Safety
/// `lm` NULL or valid; `out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_get_progress(
    lm: *const kc_lm,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_progress(lm, out) })
}

/// Copies the current estimate into the robot handle `out` (initialised or not).
///
/// # Safety
/// `lm` NULL or valid; `out` NULL or a writable `kc_robot` not otherwise in use.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_robot(lm: *const kc_lm, out: *mut kc_robot) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_robot(lm, out) })
}

/// The parameters found unidentifiable (held at their start values) into `out[cap]`, their
/// number into `*count` (0 before the first full pass). `KC_BUFFER_TOO_SMALL` (only the count
/// written) when `cap` is smaller; `out` may be NULL when `cap` is 0.
///
/// # Safety
/// `lm` NULL or valid; `out` NULL or `cap` writable values; `count` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_unidentifiable(
    lm: *const kc_lm,
    out: *mut kc_param,
    cap: usize,
    count: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_unidentifiable(lm, out, cap, count) })
}

/// The size in bytes of a snapshot of `lm` now (it depends on the parameter count only).
///
/// # Safety
/// `lm` NULL or valid; `size` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_snapshot_size(lm: *const kc_lm, size: *mut usize) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_snapshot_size(lm, size) })
}

/// Writes a snapshot of the solver's complete state into `buf[cap]` (as to a flash page) and
/// its length into `*written`. `KC_BUFFER_TOO_SMALL` when it does not fit: `*written` is then
/// the size needed and `buf` holds a partial, unusable snapshot.
///
/// # Safety
/// `lm` NULL or valid; `buf` NULL or `cap` writable bytes; `written` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_save(
    lm: *const kc_lm,
    buf: *mut u8,
    cap: usize,
    written: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_save(lm, buf, cap, written) })
}

/// Replaces the solver's state with the snapshot in `buf[len]` (bytes after the snapshot are
/// ignored). The handle must hold a solver of the same parameter count (e.g. a fresh
/// [`kc_lm_init`] with the same robot and parameters); the run then continues exactly as the
/// saved one would have, bit for bit. `KC_SNAPSHOT_INVALID` for a truncated or corrupted
/// snapshot (CRC), one of another solver, scalar or shape; on error `lm` is unchanged.
///
/// # Safety
/// `lm` NULL or valid and not otherwise in use; `buf` NULL or `len` readable bytes.
#[no_mangle]
pub unsafe extern "C" fn kc_lm_restore(lm: *mut kc_lm, buf: *const u8, len: usize) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_restore(lm, buf, len) })
}

/// [`kc_lm_init`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_init`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_init(
    lm: *mut kc_lm_full,
    start: *const kc_robot,
    params: *const kc_param,
    n: usize,
    cfg: *const kc_lm_config,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_init(lm, start, params, n, cfg) })
}

/// [`kc_lm_step`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_step`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_step(
    lm: *mut kc_lm_full,
    data: *const kc_measurement,
    n: usize,
    budget_poses: usize,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_step(lm, data, n, budget_poses, out) })
}

/// [`kc_lm_get_progress`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_get_progress`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_get_progress(
    lm: *const kc_lm_full,
    out: *mut kc_lm_progress,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_progress(lm, out) })
}

/// [`kc_lm_robot`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_robot`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_robot(lm: *const kc_lm_full, out: *mut kc_robot) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_robot(lm, out) })
}

/// [`kc_lm_unidentifiable`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_unidentifiable`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_unidentifiable(
    lm: *const kc_lm_full,
    out: *mut kc_param,
    cap: usize,
    count: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_unidentifiable(lm, out, cap, count) })
}

/// [`kc_lm_snapshot_size`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_snapshot_size`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_snapshot_size(
    lm: *const kc_lm_full,
    size: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_snapshot_size(lm, size) })
}

/// [`kc_lm_save`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_save`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_save(
    lm: *const kc_lm_full,
    buf: *mut u8,
    cap: usize,
    written: *mut usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_save(lm, buf, cap, written) })
}

/// [`kc_lm_restore`] for a [`kc_lm_full`].
///
/// # Safety
/// As [`kc_lm_restore`].
#[cfg(feature = "lm-full")]
#[no_mangle]
pub unsafe extern "C" fn kc_lm_full_restore(
    lm: *mut kc_lm_full,
    buf: *const u8,
    len: usize,
) -> kc_status {
    // SAFETY: forwarded contract.
    status(unsafe { lm_restore(lm, buf, len) })
}

/// Root-mean-square position error (mm, 3-D distance per pose) of `r` over the `n`
/// measurements `data` into `*rms_mm`. Errors: `KC_TOO_FEW_MEASUREMENTS` (`n` = 0),
/// `KC_NOT_FINITE` (a measurement holds NaN or infinity).
///
/// # Safety
/// `r` NULL or valid; `data` NULL or `n` values; `rms_mm` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn kc_rms_error(
    r: *const kc_robot,
    data: *const kc_measurement,
    n: usize,
    rms_mm: *mut f32,
) -> kc_status {
    status((|| {
        // SAFETY: the header contract.
        let robot = unsafe { handle::get(r) }?;
        // SAFETY: the header contract.
        let data = unsafe { measurements(data, n) }?;
        // SAFETY: the header contract.
        let out = unsafe { obj_mut(rms_mm) }?;
        if data.is_empty() {
            return Err(KC_TOO_FEW_MEASUREMENTS);
        }
        *out = each_robot!(robot, m => rms(m, data))?;
        Ok(())
    })())
}

/// The RMS error of `robot` over the measurements (`KC_NOT_FINITE` for a NaN in them).
fn rms<const N: usize>(robot: &Arm<N>, data: &[kc_measurement]) -> Kc<f32>
where
    kc_measurement: Observation<f32, N>,
{
    if !data.iter().all(|d| d.is_valid()) {
        return Err(KC_NOT_FINITE);
    }
    Ok(rms_error(robot, data))
}
