//! Where a run stands (`kc_lm_progress`) and why it stopped (`kc_lm_stop`).

use kinecal::identify::lm::{LmProgress, LmStop};

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
pub(super) fn progress_of(p: &LmProgress<f32>) -> kc_lm_progress {
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
