//! The solver handle `kc_lm`: its storage, the solvers it holds, and how one is set up.

use super::config::{kc_lm_config, lm_config_of};
use crate::handle::{self, handle};
use crate::robot::{kc_param, kc_robot, param_of, Arm, Model};
use crate::{
    kc_status, KC_DATA_CHANGED, KC_EFFECTS_UNSUPPORTED, KC_INVALID_ARGUMENT, KC_NOT_FINITE,
};
use crate::{obj_ref, slice_ref, Kc, KC_TOO_FEW_MEASUREMENTS, KC_TOO_MANY_PARAMS};
use kinecal::identify::lm::{FixedLm, Levenberg, LmConfig, LmError};
use kinecal::model::param::{ParamError, ParamSet};

// For the documentation's links only.
#[cfg(doc)]
use super::abi::kc_lm_step;
#[cfg(all(doc, feature = "lm-full"))]
use super::full::kc_lm_full;

/// Room for identified parameters in a `kc_lm`: the 24 of the MDH set of a 6-joint robot
/// (`kc_params_mdh`), as the Rust firmware sizes its solver (same code, same instruction counts,
/// same RAM); a 7-joint robot's solver identifies at most 24 of its parameters too.
pub const KC_LM_MAX_PARAMS: usize = 24;

/// The solver of an `N`-joint robot with room for `P` parameters.
pub(crate) type Lm<const N: usize, const P: usize> =
    Levenberg<f32, N, kinecal::Inline<0>, FixedLm<f32, P>>;

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
pub(super) use each_lm;

/// A solver handle.
pub(super) trait Solver<const P: usize>: handle::Handle<Inner = Solvers<P>> {}
impl<const P: usize, H: handle::Handle<Inner = Solvers<P>>> Solver<P> for H {}

/// Bytes of a [`kc_lm`] (see `KC_ROBOT_SIZE`).
pub const KC_LM_SIZE: usize = 9144;

/// A Levenberg–Marquardt identification (`Levenberg<f32, 6, Inline<0>, FixedLm<f32,
/// KC_LM_MAX_PARAMS>>`): a streaming stepper that does a bounded slice of work per
/// [`kc_lm_step`] call, snapshot and restore. Several KB: give it static storage. Room for
/// `KC_LM_MAX_PARAMS` parameters (the MDH set); [`kc_lm_full`] takes the base and the tool too.
#[repr(C, align(8))]
pub struct kc_lm {
    _opaque: [u8; KC_LM_SIZE],
}

// Built straight in place, no stack copy of the solver; an `Err` is never tagged initialised.
handle!(kc_lm, KC_LM_SIZE, Solvers<KC_LM_MAX_PARAMS>, 0x4c4c_4c4c);

pub(super) fn lm_error(e: LmError) -> kc_status {
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
        | LmError::Started
        | LmError::BadGroup => KC_INVALID_ARGUMENT,
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
    // The solver identifies geometry and holds no effect value (`Inline<0>`): a robot with
    // joint corrections is refused. Every effect has at least one value, so a model with
    // effects is the only one `with_capacity` refuses here.
    let geometry = robot
        .with_capacity::<kinecal::Inline<0>>()
        .map_err(|_| KC_EFFECTS_UNSUPPORTED)?;
    Ok(Levenberg::new(geometry, FixedLm::new(set), *cfg))
}

pub(super) unsafe fn lm_init<H: Solver<P>, const P: usize>(
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
