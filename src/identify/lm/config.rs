//! The settings of a [`super::Levenberg`] run.

use crate::Real;

/// Settings of the solver; [`LmConfig::default`] suits laser-tracker data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmConfig<T: Real> {
    /// Stop after this many accepted or rejected steps.
    pub max_iterations: u32,
    /// Stop when a step lowers the cost by less than this fraction.
    pub cost_tolerance: T,
    /// Stop when the scaled step is shorter than this (mm-equivalent).
    pub step_tolerance: T,
    /// Relative pivot below which a parameter direction counts as unidentifiable.
    pub rank_tolerance: T,
    /// Ridge on the accumulated scaled update, relative to the mean diagonal of `JᵀJ`.
    pub ridge: T,
    /// Initial damping relative to the diagonal.
    pub initial_damping: T,
    /// Most identifiability analyses in one run (the first one included); 1 decides once, at
    /// the starting model; 0 makes none: every parameter the caller does not hold is
    /// estimated (a refit of a parameter set known to be determined, or made so by a penalty).
    pub max_analyses: u8,
    /// Relative pivot a held parameter needs to join on a re-analysis (stricter than
    /// `rank_tolerance`): moving off the nominal geometry turns exact dependencies (d of
    /// parallel axes) into near ones, which the data still cannot determine.
    pub activation_tolerance: T,
    /// Keep the curvature `JᵀJ` while steps succeed: a candidate's pass then sums only `Jᵀr`
    /// and the cost (about half the work of a pass with many parameters), and the next step
    /// is solved with the `JᵀJ` of an earlier point. It is formed afresh (a full pass at the
    /// estimate) after a rejected step and after a step that gained less than half of what it
    /// promised. The fixed point is the same; for refits that start next to their solution
    /// (nearly linear) it saves most of the work. Re-analyses of identifiability are only
    /// triggered by full passes. Default off.
    pub keep_curvature: bool,
    /// Form the held parameters' columns in full on every pass: the normal equations a pass
    /// leaves are then complete at the model it ends at, and re-analysing or confirming the
    /// held set reads them instead of making a pass of its own (one or two passes fewer per
    /// run, the same numbers; each pass costs more when many parameters are held). Ignored
    /// with `keep_curvature`. Default off (a firmware's slices stay as they were); the
    /// command line's fits turn it on.
    pub complete_passes: bool,
    /// Scale the columns of angles and effect values by the reach's inverse in the solver's
    /// own passes ([`super::Levenberg::step`]), as a [`super::Pass`] does, instead of dividing
    /// them by the reach: one division per pose instead of one per such column and pose, where
    /// the passes are many (the discrepancy search's thousands of refits); the results differ
    /// in the last bits.
    /// Default off (a firmware's and `identify`'s numbers stay as they were).
    pub scale_by_products: bool,
}

impl<T: Real> LmConfig<T> {
    /// Settings for a constraint session ([`super::Levenberg::step_constraints`]): the
    /// default, but a direction counts as undetermined below a relative pivot of 1e-4 (to join
    /// later, 1e-3), and every pass forms the held columns. An overall scale seen by sockets
    /// and planes alone is determined only through the residuals' own size (a relative
    /// singular value near 1e-5 at a nominal model), the weakest determined directions of a
    /// socket session near 0.1 (pivots near 1e-2); with the default tolerance a UR10 socket
    /// session estimates the scale from noise, in 13 iterations instead of 3
    /// (host-tests/tests/command_line/constraint_reference.rs).
    pub fn for_constraints() -> Self {
        Self {
            rank_tolerance: T::of(1e-4),
            activation_tolerance: T::of(1e-3),
            complete_passes: true,
            ..Self::default()
        }
    }

    /// Whether the settings can run: every number finite, the initial damping above zero (a
    /// zero or negative damping never grows, so a failed step would be retried forever), the
    /// rank tolerance in (0, 1), the other tolerances and the ridge at least zero.
    pub fn is_valid(&self) -> bool {
        let finite_non_negative = |x: T| x.finite() && x >= T::zero();
        self.initial_damping.finite()
            && self.initial_damping > T::zero()
            && self.rank_tolerance > T::zero()
            && self.rank_tolerance < T::one()
            && finite_non_negative(self.cost_tolerance)
            && finite_non_negative(self.step_tolerance)
            && finite_non_negative(self.ridge)
            && finite_non_negative(self.activation_tolerance)
    }
}

impl<T: Real> Default for LmConfig<T> {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            cost_tolerance: T::of(1e-10).max(T::EPS * T::of(16.0)),
            step_tolerance: T::of(1e-9).max(T::EPS * T::of(16.0)),
            rank_tolerance: T::EPS.sqrt(),
            ridge: T::of(1e-9).max(T::EPS),
            initial_damping: T::of(1e-3),
            max_analyses: 8,
            activation_tolerance: T::of(1e-4),
            keep_curvature: false,
            complete_passes: false,
            scale_by_products: false,
        }
    }
}
