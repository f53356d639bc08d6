//! The solver settings (`kc_lm_config`) and their defaults.

use crate::{kc_status, obj_mut, status, Kc, KC_INVALID_ARGUMENT};
use kinecal::identify::lm::LmConfig;

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

pub(super) fn lm_config_of(c: &kc_lm_config) -> Kc<LmConfig<f32>> {
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
        scale_by_products: false,
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
