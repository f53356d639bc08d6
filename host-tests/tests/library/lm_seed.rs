//! A refit's first pass taken from the run it starts from
//! (`Levenberg::complete_first_pass_from`, used by identify's refit with the prior): the refit
//! goes on bit for bit as after its own first pass, on one thread and in the host's parts, and
//! every seed that would not give the same numbers is refused with the run left as it was.

use kinecal::identify::lm::{Levenberg, LmConfig, LmError, LmProgress, LmStop, PenaltyTerm};
use kinecal::model::param::{value, Param, ParamSet};
use kinecal::{ForwardKinematics, Inline, Measurement, Robot};
use kinecal_cli::calibration::prior;
use kinecal_cli::compute::parallel::{run_lm, PARALLEL_MIN_POSES};
use kinecal_cli::compute::vec_lm::{VecLm, VecPenalty};
use kinecal_cli::simulation;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

type Model = Robot<f64, 6, Inline<64>>;
type First = Levenberg<f64, 6, Inline<64>, VecLm<f64>>;
type Refit = Levenberg<f64, 6, Inline<64>, VecLm<f64>, VecPenalty<f64>>;

/// A perturbed ER20 (base estimated too: some of it held) and noisy poses of it.
fn problem(n: usize, seed: u64) -> (Model, Vec<Param>, Vec<Measurement<f64, 6>>) {
    let nominal = simulation::er20_c10()
        .with_capacity::<Inline<64>>()
        .unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let (_, data) = simulation::perturbed_measurements(&nominal, n, 0.01, &mut rng);
    (
        nominal,
        ParamSet::<64>::full(6, true).unwrap().to_vec(),
        data,
    )
}

/// The unpenalised first fit as identify runs it (every pass forms every column).
fn first_fit(
    start: &Model,
    params: &[Param],
    data: &[Measurement<f64, 6>],
    cfg: LmConfig<f64>,
) -> First {
    let cfg = LmConfig {
        complete_passes: true,
        ..cfg
    };
    let mut lm = Levenberg::new(start.clone(), VecLm::new(params), cfg).unwrap();
    run_lm(&mut lm, data, |_, _| {}).unwrap();
    lm
}

/// A refit from `first`'s model over what it estimated, pulled towards `nominal` (a ridge per
/// parameter, as identify's prior).
fn refit(first: &First, nominal: &Model) -> Refit {
    let active: Vec<Param> = (0..first.params().len())
        .filter(|&k| first.is_active(k))
        .map(|k| first.params()[k])
        .collect();
    let terms = (0..active.len())
        .map(|k| PenaltyTerm {
            first: k,
            len: 1,
            ridge: 1e-4 * (k + 1) as f64,
            smoothness: 0.0,
            relative: false,
        })
        .collect();
    let mut penalty = VecPenalty::new(active.len(), terms);
    for (k, p) in active.iter().enumerate() {
        penalty.prior_mut()[k] = value(nominal, *p).unwrap();
    }
    let cfg = LmConfig {
        max_analyses: 0,
        ..LmConfig::default()
    };
    Levenberg::with_penalty(first.robot().clone(), VecLm::new(&active), penalty, cfg).unwrap()
}

/// Everything a run's outcome is made of, bit for bit.
fn outcome(lm: &Refit) -> (LmProgress<f64>, Vec<u64>, Vec<u64>) {
    let n = lm.params().len();
    let values = lm
        .params()
        .iter()
        .map(|p| value(lm.robot(), *p).unwrap().to_bits())
        .collect();
    let normal = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .map(|(i, j)| lm.normal_matrix(i, j).to_bits())
        .collect();
    (lm.progress(), values, normal)
}

/// The largest distance (mm) between the points two models predict at the poses of `data`.
fn model_gap(a: &Model, b: &Model, data: &[Measurement<f64, 6>]) -> f64 {
    let (mut fa, mut fb) = (ForwardKinematics::new(), ForwardKinematics::new());
    data.iter()
        .map(|m| (fa.compute(a, &m.q) - fb.compute(b, &m.q)).norm())
        .fold(0.0, f64::max)
}

#[test]
fn a_seeded_refit_is_the_refit_bit_for_bit() {
    // 400 poses: every pass on the calling thread; the larger: in the host's parts.
    for (n, seed) in [(400, 1), (PARALLEL_MIN_POSES + 1500, 2)] {
        let (nominal, params, data) = problem(n, seed);
        let first = first_fit(&nominal, &params, &data, LmConfig::default());
        assert_eq!(first.progress().stopped, Some(LmStop::Converged));
        assert!(
            first.unidentifiable().count() > 0,
            "the base confounds some parameters: the refit estimates fewer"
        );
        let mut own = refit(&first, &nominal);
        own.adopt_scales_of(&first).unwrap();
        run_lm(&mut own, &data, |_, _| {}).unwrap();
        let mut seeded = refit(&first, &nominal);
        let after = seeded.complete_first_pass_from(&first).unwrap();
        assert_eq!(after.evaluations, 1, "the first pass is done");
        assert!(seeded.pass().is_none(), "a solve is next, not a pass");
        run_lm(&mut seeded, &data, |_, _| {}).unwrap();
        assert!(own.progress().stopped.is_some());
        // The seeded pass counts as one (the normal equations at that model were formed).
        assert_eq!(outcome(&seeded), outcome(&own), "{n} poses");
        // The first fit's scales precondition the refit differently from its own start's
        // (the reach moved with the fit): the same minimum.
        let mut own_scales = refit(&first, &nominal);
        run_lm(&mut own_scales, &data, |_, _| {}).unwrap();
        assert!(own_scales.scale(0) != own.scale(0) || own_scales.scale(6) != own.scale(6));
        assert!(model_gap(own_scales.robot(), own.robot(), &data) < 1e-6);
        assert_eq!(
            own.adopt_scales_of(&first),
            Err(LmError::PassMismatch),
            "only before the first pass"
        );
    }
}

#[test]
fn seeds_that_would_change_the_numbers_are_refused() {
    let (nominal, params, data) = problem(300, 3);
    let first = first_fit(&nominal, &params, &data, LmConfig::default());
    let check_unchanged = |mut lm: Refit, why: &str| {
        let mut own = refit(&first, &nominal);
        own.run(&data).unwrap();
        lm.run(&data).unwrap();
        assert_eq!(
            outcome(&lm),
            outcome(&own),
            "{why}: the refused run goes on as its own"
        );
    };

    // A run stopped at its iteration limit: its normal equations may be a rejected step's.
    let cut = first_fit(
        &nominal,
        &params,
        &data,
        LmConfig {
            max_iterations: 1,
            ..LmConfig::default()
        },
    );
    assert_eq!(cut.progress().stopped, Some(LmStop::MaxIterations));
    let mut lm = refit(&first, &nominal);
    assert_eq!(
        lm.complete_first_pass_from(&cut),
        Err(LmError::PassMismatch)
    );
    check_unchanged(lm, "unconverged seed");

    // A run that ended elsewhere than this run's start.
    let mut other = refit(&first, &nominal);
    other.run(&data).unwrap();
    let mut moved = Levenberg::new(
        other.robot().clone(),
        VecLm::new(first.params()),
        LmConfig {
            complete_passes: true,
            ..LmConfig::default()
        },
    )
    .unwrap();
    moved.run(&data).unwrap();
    let lm_robot_differs = moved.robot() != first.robot();
    assert!(lm_robot_differs, "the prior moved the model");
    let mut lm = refit(&first, &nominal);
    assert_eq!(
        lm.complete_first_pass_from(&moved),
        Err(LmError::PassMismatch)
    );
    check_unchanged(lm, "seed at another model");

    // A parameter the seed did not estimate (held there: only its diagonal was formed).
    let held = Levenberg::new(nominal.clone(), VecLm::new(&params), LmConfig::default())
        .map(|mut lm| {
            lm.run(&data).unwrap();
            lm
        })
        .unwrap();
    assert!(held.unidentifiable().count() > 0);
    let mut lm: First = Levenberg::new(
        held.robot().clone(),
        VecLm::new(&params),
        LmConfig::default(),
    )
    .unwrap();
    assert_eq!(
        lm.complete_first_pass_from(&held),
        Err(LmError::PassMismatch)
    );

    // A run that already passed over data.
    let mut lm = refit(&first, &nominal);
    lm.step(&data, 10).unwrap();
    assert_eq!(
        lm.complete_first_pass_from(&first),
        Err(LmError::PassMismatch)
    );
}

#[test]
fn identify_refit_with_the_first_solver_is_the_refit_without() {
    // Through the host's functions, in parts: the fit, its prior refit seeded and not.
    let (nominal, params, data) = problem(PARALLEL_MIN_POSES + 800, 6);
    let sigma: Vec<Option<f64>> = params
        .iter()
        .map(|p| {
            Some(if p.is_length() {
                0.5
            } else {
                0.05_f64.to_radians()
            })
        })
        .collect();
    let (fit, solver) =
        kinecal_cli::calibration::fit_lm_with_solver(&nominal, &params, &data, LmConfig::default())
            .unwrap();
    let seeded =
        prior::refit_after(&nominal, &params, &sigma, &data, fit.clone(), Some(&solver)).unwrap();
    let own = prior::refit(&nominal, &params, &sigma, &data, fit).unwrap();
    assert!(!own.prior.is_empty(), "the prior took part");
    // Scaled as the first fit (see above): the same minimum, the same report to its digits.
    assert!(model_gap(&seeded.robot, &own.robot, &data) < 1e-6);
    for (name, s) in &own.sigma {
        assert!(
            (seeded.sigma[name] - s).abs() <= 1e-6 * s,
            "{name} {} {s}",
            seeded.sigma[name]
        );
    }
    for (name, share) in &own.prior {
        let d = seeded.prior[name].data_share - share.data_share;
        assert!(d.abs() < 1e-6, "{name} {d}");
    }
    let chi = (seeded.chi2_per_dof.unwrap() / own.chi2_per_dof.unwrap() - 1.0).abs();
    assert!(chi < 1e-9);
    assert_eq!(seeded.evaluations, own.evaluations);
}
