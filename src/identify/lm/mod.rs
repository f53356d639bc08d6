//! Streaming Levenberg–Marquardt identification with identifiability analysis.
//!
//! The normal equations `JᵀJ`, `Jᵀr` are accumulated one measurement at a time, so memory is
//! `O(P²)` whatever the number of poses, and one [`Levenberg::step`] call processes at most a
//! caller-chosen number of poses: firmware runs it in idle cycles, the desktop in one call.
//!
//! A candidate step is tried with a full pass at the candidate, which accumulates its normal
//! equations while summing its cost: accepted (the usual case), they are the next iteration's,
//! so an iteration costs one pass over the data; rejected, the estimate's are accumulated
//! again. Passes can be spread over workers (below).
//!
//! Parameters are scaled by [`Param::scale`](crate::model::param::Param::scale) (angles × reach) so that a unit step moves the
//! tool by about a millimetre whatever the parameter; Marquardt's diagonal damping with
//! Nielsen's update of λ makes convergence from the nominal model reliable.
//!
//! **Identifiability follows the model.** On the first pass the scaled normal matrix is
//! normalised to unit diagonal (a correlation matrix) and factored by rank-revealing Cholesky.
//! Columns whose pivot falls below `rank_tolerance` are directions the data cannot determine
//! (base z vs d1, theta of the last joint vs the tool, d of parallel axes, effect values no
//! pose excites): they are held at their current value instead of running off. What the data
//! determine depends on where the model is, though: a tool point started on the flange axis
//! makes theta6 and the last rows' angles invisible until the fit moves the point off the axis.
//! So the decision is taken again whenever a held parameter's column has grown since it was
//! taken (checked at every accepted step, `O(P)`), and once more at the converged model; the
//! run only ends when a re-analysis at the final model confirms the held set; a re-analysis
//! takes a pass forming the held columns in full, or none with `complete_passes` (every pass
//! forms them: the host's choice). Re-analysis prefers the parameters already estimated, so a
//! confounded pair does not swap back and forth. A tiny ridge on the accumulated update keeps nearly dependent directions bounded.
//!
//! **Penalties and subsets.** A run may minimise `Σ|r_i|² + uᵀΠu` instead, `Π` a caller-given
//! quadratic penalty (a prior) on the scaled parameters ([`PenaltyTerm`]:
//! ridges and smoothness terms, e.g. on the knots of correction tables) in a second
//! caller-owned value ([`Levenberg::with_penalty`]); the penalty enters the normal equations,
//! the identifiability analysis (a direction the penalty determines is determined) and the
//! cost that accepts steps. The caller chooses the parameters (the storage's list), may hold
//! some of them at their start values ([`Levenberg::hold`]), and may turn the analysis off
//! (`max_analyses = 0`: every parameter not held is estimated, as a refit of a known parameter
//! set wants). A run starts from any model: the nominal one, or a previous fit.
//!
//! **Storage, owned by the caller** (as smoltcp's sockets take their buffers): the solver itself
//! holds only the robot, a workspace and a few scalars. Its `O(P²)` arrays (the parameter list,
//! the normal equations, the solver's scratch: [`LmParts`]) live in a type the caller chooses
//! through [`LmStorage`]: [`FixedLm`] keeps them in fixed arrays of capacity `P` (firmware: a
//! static or stack value sized for its robot), and a host sizes them from the problem on the
//! heap (the `kinecal` command line's `VecLm`). A 600-parameter model then needs no
//! megabyte-sized value on any stack. A penalty lives in a second caller-owned value
//! ([`LmPenalty`]): [`NoPenalty`] (the default) has no storage and compiles to nothing,
//! [`FixedPenalty`] keeps one in fixed arrays, a host sizes one on the heap (`VecPenalty`).
//! With a penalty the run minimises `Σ |r_i|² + uᵀ Π u`, `u_k = (x_k − prior_k) · scale_k`,
//! `Π` a sum of [`PenaltyTerm`]s (a ridge and a second-difference smoothness on a run of
//! consecutive parameters; a *relative* term takes its weight from the mean diagonal of `JᵀJ`
//! over its run at the first pass).
//!
//! **Passes spread over workers.** The passes are where the time goes with many poses, and
//! they are sums: each worker can take a slice of the measurements into its own partial sums.
//! [`Levenberg::pass`] hands out the pass the run needs next (borrowing the solver immutably,
//! so the workers may share it), [`Pass::accumulate`] fills one [`PassPart`], and
//! [`Levenberg::complete_pass`] merges the parts and moves the run on. The outcome equals
//! [`Levenberg::step`] over the same data up to the order of summation; a caller who always
//! cuts the data into the same parts gets the same numbers whatever the number of threads. The
//! library spawns nothing: the caller chooses the workers and owns each part's storage.
//!
//! **A refit from a fit's result** (a prior pulling towards the file values, fewer
//! parameters) would begin with a pass at the model the fit converged at, whose normal
//! equations the fit's last pass formed: [`Levenberg::complete_first_pass_from`] takes them
//! (the refit in the fit's column scales, [`Levenberg::adopt_scales_of`]), bit for bit what
//! the pass would give when both summed the poses in the same order.
//!
//! **Inside** (private modules; the calls go one way, from the stepper down):
//! `levenberg` (the stepper: state, public calls, the phases of a run) → `pass` (a pass over a
//! slice, for workers) → `normal` (one observation into the normal equations) → `residual`
//! (an observation's weighted residual, RMS errors); `levenberg` → `solve` (the damped
//! solve) and `analysis` (identifiability); below them all `config`, `storage`, `penalty` and
//! `status`; `snapshot` saves and restores the stepper; `seed` starts a refit from a
//! finished run.

mod analysis;
mod config;
mod constraint;
mod constraint_step;
mod levenberg;
mod normal;
mod pass;
mod penalty;
mod residual;
mod seed;
mod snapshot;
mod solve;
mod status;
mod storage;

pub use config::LmConfig;
pub use constraint::{constraint_scratch_len, constraint_shape, ConstraintShape, ABSORBED};
pub use levenberg::{FixedLevenberg, Levenberg};
pub use pass::{Pass, PassKind, PassPart};
pub use penalty::{
    FixedPenalty, LmPenalty, NoPenalty, PenaltyError, PenaltyParts, PenaltyPartsRef, PenaltyTerm,
};
pub use residual::{observation_cost, rms_error, rms_orientation_error};
pub use status::{LmError, LmProgress, LmStop};
pub use storage::{
    add_batch_rows, add_dense_rows, FixedLm, LmParts, LmPartsRef, LmStorage, LM_FLAG_VECTORS,
    LM_INDEX_VECTORS, LM_VECTORS,
};
