//! The refits of the discrepancy search, by the library's Levenberg–Marquardt
//! ([`kinecal::identify::lm::Levenberg`]) with the table penalty
//! ([`kinecal::identify::lm`]): the same solver as `identify` and the firmware, on the
//! heap ([`VecLm`], [`VecPenalty`]).
//!
//! A refit estimates a known parameter set ([`Problem`]: geometry without what the data could
//! not determine, plus effects) from a nearby model, so the solver's identifiability analysis
//! is off (`max_analyses = 0`): the table penalty determines what few poses excite. The
//! fold fits of one model all start from the same robot: each fold's own normal equations at
//! the start are accumulated once ([`kinecal::identify::lm::Pass::accumulate`]), and each fold
//! fit's first pass is the sum of the other folds' ([`Levenberg::complete_pass`]): one pass
//! over the poses per model instead of one over 80 % of them per fold.

use crate::calibration::folds::{subset, Folds};
use crate::compute::parallel::{self, run_lm};
use crate::compute::vec_lm::{VecLm, VecPenalty};
use crate::diagnose::linear::{effective_parameters, squared_errors, Normal, Problem};
use kinecal::identify::lm::{Levenberg, LmConfig, PassPart};
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::DMatrix;

/// The library solver of a refit.
pub type RefitLm<const N: usize, V> = Levenberg<f64, N, V, VecLm<f64>, VecPenalty<f64>>;

/// Consecutive rejected steps a refit may take beyond its `max_iterations` accepted ones.
pub const EXTRA_REJECTS: u32 = 12;

/// The solver's settings for a refit of at most `max_iterations` steps: no identifiability
/// analysis (the parameter set is given); light initial damping and the curvature kept while
/// steps succeed (the start is next to the solution and the model nearly linear there, so a
/// step typically costs a pass for the gradient only).
pub fn refit_config(max_iterations: u32) -> LmConfig<f64> {
    LmConfig {
        max_iterations: max_iterations.saturating_add(EXTRA_REJECTS),
        initial_damping: 1e-6,
        max_analyses: 0,
        keep_curvature: true,
        scale_by_products: true,
        ..LmConfig::default()
    }
}

/// A refit of `problem` starting from `start` (not yet run).
pub fn solver<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    problem: &Problem,
    max_iterations: u32,
) -> anyhow::Result<RefitLm<N, V>> {
    let penalty = VecPenalty::new(problem.len(), problem.penalty_terms());
    Levenberg::with_penalty(
        start.clone(),
        VecLm::new(&problem.params),
        penalty,
        refit_config(max_iterations),
    )
    .map_err(|e| anyhow::anyhow!("refit: {e:?}"))
}

/// Result of a penalised fit.
#[derive(Clone, Debug)]
pub struct FitOutcome<const N: usize, V: kinecal::ValueStorage> {
    /// The fitted model.
    pub robot: Robot<f64, N, V>,
    /// Sum of squared residuals (mm²) at the solution.
    pub ssr: f64,
    /// Steps taken (accepted and rejected).
    pub iterations: u32,
    /// The penalty `Π` the fit used (scaled units; resolved at the start).
    pub penalty: DMatrix<f64>,
}

impl<const N: usize, V: kinecal::ValueStorage> FitOutcome<N, V> {
    /// Effective number of parameters, `tr((JᵀJ + Π)⁻¹ JᵀJ)` at the solution: the degrees of
    /// freedom the fit used (= the parameter count without penalty). `problem` and `data` must
    /// be the fit's. Computed on demand (one pass over the poses and an O(p³) inverse) because
    /// only the final model's report needs it.
    pub fn effective_parameters(&self, problem: &Problem, data: &[Measurement<f64, N>]) -> f64 {
        effective_parameters(&Normal::of(problem, &self.robot, data).a, &self.penalty)
    }
}

/// Runs a refit to the end over `data` (its passes on both cores when the data are many).
fn finish<const N: usize, V: kinecal::ValueStorage>(
    mut lm: RefitLm<N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
) -> anyhow::Result<FitOutcome<N, V>> {
    let progress = run_lm(&mut lm, data, |_, _| {}).map_err(|e| anyhow::anyhow!("refit: {e:?}"))?;
    // The library's Π, as a matrix (its weights resolved at the first pass).
    let n = problem.len();
    let mut penalty = DMatrix::zeros(n, n);
    if let Some(q) = lm.penalty_parts() {
        for (t, w) in q.terms.iter().zip(q.weights) {
            for i in 0..t.len {
                for j in i.saturating_sub(2)..(i + 3).min(t.len) {
                    penalty[(t.first + i, t.first + j)] += w * t.entry(i, j);
                }
            }
        }
    }
    Ok(FitOutcome {
        robot: lm.robot().clone(),
        ssr: progress.cost,
        iterations: progress.iteration,
        penalty,
    })
}

/// Penalised Levenberg–Marquardt from `start` over `data` (at most `max_iterations` accepted
/// steps).
pub fn fit<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    problem: &Problem,
    data: &[Measurement<f64, N>],
    max_iterations: u32,
) -> anyhow::Result<FitOutcome<N, V>> {
    anyhow::ensure!(
        3 * data.len() > problem.len(),
        "{} poses cannot determine {} parameters",
        data.len(),
        problem.len()
    );
    finish(solver(start, problem, max_iterations)?, problem, data)
}

/// Held-out squared error (mm²) of every pose of `data`, for several models (start and
/// parameter set) at once: for each fold, the model is refitted from its start on the other
/// folds and the fold's poses are predicted. All fold fits are independent and spread over the
/// cores together ([`parallel::map_each`]); each fold's own first-pass sums are accumulated
/// once per model (see the [module](self)).
pub fn fold_errors<const N: usize, V: kinecal::ValueStorage>(
    models: &[(&Robot<f64, N, V>, &Problem)],
    data: &[Measurement<f64, N>],
    folds: &Folds,
    max_iterations: u32,
) -> anyhow::Result<Vec<Vec<f64>>> {
    let splits: Vec<(Vec<usize>, Vec<usize>)> = (0..folds.k)
        .map(|f| folds.split(f))
        .filter(|(test, _)| !test.is_empty())
        .collect();
    for (_, problem) in models {
        anyhow::ensure!(
            splits
                .iter()
                .all(|(_, train)| 3 * train.len() > problem.len()),
            "too few poses per fold for {} parameters",
            problem.len()
        );
    }
    // The solvers at the start, whose first pass the folds' parts belong to.
    let templates: Vec<RefitLm<N, V>> = models
        .iter()
        .map(|(start, problem)| solver(start, problem, max_iterations))
        .collect::<anyhow::Result<_>>()?;
    // (model, split) of every fold fit.
    let refits: Vec<(usize, usize)> = (0..models.len())
        .flat_map(|m| (0..splits.len()).map(move |s| (m, s)))
        .collect();
    let own = parallel::map_each(&refits, |&(m, s)| -> anyhow::Result<_> {
        let lm = &templates[m];
        let pass = lm
            .pass()
            .ok_or_else(|| anyhow::anyhow!("refit: no first pass"))?;
        let mut part = PassPart::new(VecLm::for_pass(lm.params()));
        pass.accumulate(
            &mut ForwardKinematics::new(),
            &subset(data, &splits[s].0),
            &mut part,
        )
        .map_err(|e| anyhow::anyhow!("refit: {e:?}"))?;
        Ok(part)
    })
    .into_iter()
    .collect::<anyhow::Result<Vec<PassPart<f64, VecLm<f64>>>>>()?;
    drop(templates);
    let held_out = parallel::map_each(&refits, |&(m, s)| -> anyhow::Result<Vec<f64>> {
        let (start, problem) = models[m];
        let (test, train) = &splits[s];
        let mut lm = solver(start, problem, max_iterations)?;
        let others = refits
            .iter()
            .zip(&own)
            .filter(|((om, os), _)| *om == m && *os != s)
            .map(|(_, part)| part);
        lm.complete_pass(others)
            .map_err(|e| anyhow::anyhow!("refit: {e:?}"))?;
        let fitted = finish(lm, problem, &subset(data, train))?;
        Ok(squared_errors(&fitted.robot, &subset(data, test)))
    });
    let mut out = vec![vec![0.0; data.len()]; models.len()];
    for (&(m, s), e) in refits.iter().zip(held_out) {
        for (i, v) in splits[s].0.iter().zip(e?) {
            out[m][*i] = v;
        }
    }
    Ok(out)
}
