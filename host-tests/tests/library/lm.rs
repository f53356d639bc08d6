//! Levenberg–Marquardt identification against known truth.

use kinecal::identify::lm::{rms_error, FixedLevenberg, Levenberg, LmConfig, LmError, LmStop};
use kinecal::model::param::{apply_delta, value, Param, ParamSet};
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The ER20-C10 stand-in of the demo (joint limits ±170°).
fn er20() -> Robot<f64, 6, kinecal::Inline<64>> {
    kinecal_cli::simulation::er20_c10()
        .with_capacity::<kinecal::Inline<64>>()
        .unwrap()
}

fn perturbed(
    nominal: &Robot<f64, 6, kinecal::Inline<64>>,
    rng: &mut Xoshiro256PlusPlus,
) -> Robot<f64, 6, kinecal::Inline<64>> {
    let mut t = nominal.clone();
    let set = ParamSet::<64>::full(6, false).unwrap();
    let delta: Vec<f64> = set
        .as_slice()
        .iter()
        .map(|p| {
            if p.is_length() {
                rng.random_range(-0.8..0.8)
            } else {
                rng.random_range(-0.1f64..0.1).to_radians()
            }
        })
        .collect();
    apply_delta(&mut t, &set, &delta).unwrap();
    t
}

fn measure(
    robot: &Robot<f64, 6, kinecal::Inline<64>>,
    n: usize,
    sigma: f64,
    rng: &mut Xoshiro256PlusPlus,
) -> Vec<Measurement<f64, 6>> {
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut fk = ForwardKinematics::new();
    (0..n)
        .map(|_| {
            let q: [f64; 6] =
                core::array::from_fn(|_| rng.random_range(-170f64..170.0).to_radians());
            let p = fk.compute(robot, &q);
            let e = Vector3::new(noise.sample(rng), noise.sample(rng), noise.sample(rng));
            Measurement::new(q, p + e)
        })
        .collect()
}

#[test]
fn lm_reaches_the_noise_floor_on_simulated_geometry_errors() {
    let nominal = er20();
    for seed in 0..5u64 {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let truth = perturbed(&nominal, &mut rng);
        let sigma = 0.01;
        let ident = measure(&truth, 50, sigma, &mut rng);
        let valid = measure(&truth, 50, sigma, &mut rng);
        let before = rms_error(&nominal, &valid);
        let set = ParamSet::<64>::full(6, false).unwrap();
        let mut lm = Levenberg::fixed(nominal.clone(), set, LmConfig::default()).unwrap();
        let p = lm.run(&ident).unwrap();
        let after = rms_error(lm.robot(), &valid);
        let floor = 3f64.sqrt() * sigma;
        let names: Vec<String> = lm
            .unidentifiable()
            .map(|p| p.name(lm.robot()).to_string())
            .collect();
        eprintln!("seed {seed}: before {before:.3} mm, after {after:.4} mm (floor {floor:.4}), {} iterations, {:?}, unidentifiable {names:?}", p.iteration, p.stopped);
        assert!(before > 1.0);
        assert!(after < 1.25 * floor, "held-out {after} vs floor {floor}");
        assert!(matches!(
            p.stopped,
            Some(LmStop::Converged) | Some(LmStop::SmallStep)
        ));
        // theta6 and the tool trade off: exactly one of them must be held.
        assert!(!names.is_empty());
    }
}

#[test]
fn stepping_in_slices_gives_the_same_result_as_one_call() {
    let nominal = er20();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
    let truth = perturbed(&nominal, &mut rng);
    let data = measure(&truth, 40, 0.01, &mut rng);
    let set = ParamSet::<64>::full(6, false).unwrap();
    let mut a = Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    a.run(&data).unwrap();
    let mut b = Levenberg::fixed(nominal, set, LmConfig::default()).unwrap();
    let mut calls = 0;
    while b.step(&data, 3).unwrap().stopped.is_none() {
        calls += 1;
    }
    assert!(calls > 40);
    assert_eq!(a.robot(), b.robot());
}

#[test]
fn redundant_base_and_first_row_are_reported_and_held() {
    let nominal = er20();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let truth = perturbed(&nominal, &mut rng);
    let data = measure(&truth, 60, 0.01, &mut rng);
    let set = ParamSet::<64>::full(6, true).unwrap();
    let mut lm = Levenberg::fixed(nominal.clone(), set, LmConfig::default()).unwrap();
    lm.run(&data).unwrap();
    let held: Vec<Param> = lm.unidentifiable().collect();
    // base z and d1 move the point identically; so do base.rz and theta1.
    assert!(
        held.contains(&Param::BaseZ) || held.contains(&Param::D(0)),
        "{held:?}"
    );
    assert!(
        held.contains(&Param::BaseRz) || held.contains(&Param::Theta(0)),
        "{held:?}"
    );
    for p in &held {
        assert_eq!(
            kinecal::model::param::value(lm.robot(), *p),
            kinecal::model::param::value(&nominal, *p),
            "{p:?} moved"
        );
    }
    assert!(rms_error(lm.robot(), &data) < 0.02);
}

#[test]
fn bad_input_is_refused_without_damage() {
    let nominal = er20();
    let set = ParamSet::<64>::full(6, false).unwrap();
    let mut lm = Levenberg::fixed(nominal.clone(), set, LmConfig::default()).unwrap();
    assert!(lm.step::<Measurement<f64, 6>>(&[], 10).is_err());
    let mut bad = vec![Measurement::<f64, 6>::default(); 20];
    bad[3].point.x = f64::NAN;
    assert!(lm.step(&bad, 10).is_err());
    assert_eq!(lm.robot(), &nominal);
    let mut bad_set = ParamSet::<64>::new();
    bad_set.push(Param::D(9)).unwrap();
    assert!(FixedLevenberg::<f64, 6, kinecal::Inline<64>, 64>::fixed(
        nominal,
        bad_set,
        LmConfig::default()
    )
    .is_err());
}

/// Settings that cannot run are refused at construction (a damping of zero or below
/// never grows, so the "damp harder and retry" loop of a failed step never ended).
#[test]
fn settings_that_cannot_run_are_refused() {
    let set = ParamSet::<64>::full(6, false).unwrap();
    let ok = LmConfig::<f64>::default();
    assert!(ok.is_valid() && LmConfig::<f32>::default().is_valid());
    let bad = [
        LmConfig {
            initial_damping: 0.0,
            ..ok
        },
        LmConfig {
            initial_damping: -1.0,
            ..ok
        },
        LmConfig {
            initial_damping: f64::NAN,
            ..ok
        },
        LmConfig {
            initial_damping: f64::INFINITY,
            ..ok
        },
        LmConfig {
            rank_tolerance: 0.0,
            ..ok
        },
        LmConfig {
            rank_tolerance: 1.0,
            ..ok
        },
        LmConfig {
            cost_tolerance: -1e-9,
            ..ok
        },
        LmConfig {
            step_tolerance: f64::NAN,
            ..ok
        },
        LmConfig {
            ridge: f64::INFINITY,
            ..ok
        },
        LmConfig {
            activation_tolerance: -1.0,
            ..ok
        },
    ];
    for cfg in bad {
        assert!(!cfg.is_valid(), "{cfg:?}");
        let e = Levenberg::fixed(er20(), set.clone(), cfg).err();
        assert_eq!(e, Some(LmError::Config), "{cfg:?}");
    }
}

#[test]
fn snapshot_at_every_step_restores_to_a_bit_identical_run() {
    use kinecal::io::snapshot::Snapshot;
    let nominal = er20();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    let truth = perturbed(&nominal, &mut rng);
    let data = measure(&truth, 30, 0.01, &mut rng);
    let set = ParamSet::<64>::full(6, false).unwrap();
    let mut reference =
        Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    reference.run(&data).unwrap();

    // Interrupt after every call of 7 poses: save, restore into a fresh solver, continue.
    let mut lm = Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    let mut restores = 0;
    loop {
        let p = lm.step(&data, 7).unwrap();
        if p.stopped.is_some() {
            break;
        }
        let mut buf = Vec::new();
        lm.save(&mut buf).unwrap();
        let mut fresh =
            Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
        fresh.restore(&mut buf.as_slice()).unwrap();
        lm = fresh;
        restores += 1;
    }
    assert!(restores > 10);
    assert_eq!(lm.robot(), reference.robot());
    assert_eq!(lm.progress(), reference.progress());

    // A corrupted snapshot is refused and the target keeps its state.
    let mut buf = Vec::new();
    lm.save(&mut buf).unwrap();
    let mut target = Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    target.step(&data, 5).unwrap();
    let before = target.progress();
    let before_robot = target.robot().clone();
    for i in [0usize, 5, 25, buf.len() / 2, buf.len() - 1] {
        let mut bad = buf.clone();
        bad[i] ^= 0x10;
        assert!(
            target.restore(&mut bad.as_slice()).is_err(),
            "flipped byte {i} accepted"
        );
    }
    assert!(target.restore(&mut &buf[..buf.len() - 3]).is_err());
    assert_eq!(target.progress(), before);
    assert_eq!(target.robot(), &before_robot);
}

/// The nominal ER20, 60 poses of a perturbed one (σ 0.01 mm, drawn from `seed`) and every
/// parameter with the base.
fn perturbed_session(
    seed: u64,
) -> (
    Robot<f64, 6, kinecal::Inline<64>>,
    Vec<Measurement<f64, 6>>,
    ParamSet<64>,
) {
    let nominal = er20();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let truth = perturbed(&nominal, &mut rng);
    let data = measure(&truth, 60, 0.01, &mut rng);
    (nominal, data, ParamSet::<64>::full(6, true).unwrap())
}

/// With `complete_passes` every pass forms the held columns in full, so what the run leaves
/// is the complete normal matrix at its final model (what the covariance and confounding
/// reports read) without a confirming pass of its own: equal, unscaled, to the first pass of
/// a fresh run started there (which forms every column), held rows and columns included; a
/// run whose steps are all accepted makes one pass per iteration plus the first, and ends at
/// the model the run without the option reaches with its extra passes.
#[test]
fn the_normal_matrix_left_is_complete_at_the_final_model() {
    let (nominal, data, set) = perturbed_session(3);
    let cfg = LmConfig {
        complete_passes: true,
        ..LmConfig::default()
    };
    let mut lm = Levenberg::fixed(nominal.clone(), set.clone(), cfg).unwrap();
    let done = lm.run(&data).unwrap();
    let mut plain = Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    let plain_done = plain.run(&data).unwrap();
    assert_eq!(lm.robot(), plain.robot(), "the same fit, bit for bit");
    assert!(
        done.evaluations < plain_done.evaluations,
        "{} passes with, {} without",
        done.evaluations,
        plain_done.evaluations
    );
    let held: Vec<Param> = lm.unidentifiable().collect();
    assert!(!held.is_empty(), "the base and the first row confound");
    let mut fresh = Levenberg::fixed(lm.robot().clone(), set, LmConfig::default()).unwrap();
    // One call of as many poses as there are: exactly the first pass.
    fresh.step(&data, data.len()).unwrap();
    let n = lm.params().len();
    let unscaled = |l: &FixedLevenberg<f64, 6, kinecal::Inline<64>, 64>, i: usize, j: usize| {
        l.normal_matrix(i.max(j), i.min(j)) * l.scale(i) * l.scale(j)
    };
    let mut worst = 0f64;
    for i in 0..n {
        for j in 0..=i {
            let (a, b) = (unscaled(&lm, i, j), unscaled(&fresh, i, j));
            let tol = 1e-9
                * (unscaled(&lm, i, i) * unscaled(&lm, j, j))
                    .sqrt()
                    .max(1e-300);
            assert!(
                (a - b).abs() <= tol,
                "JᵀJ[{i}][{j}] ({:?}, {:?}): {a} left, {b} at the final model",
                lm.params()[i],
                lm.params()[j]
            );
            worst = worst.max((a - b).abs() / tol);
        }
    }
    eprintln!(
        "{} held, {} iterations, {} passes; worst difference {:.2e} of the tolerance",
        held.len(),
        done.iteration,
        done.evaluations,
        worst
    );
    assert!(done.evaluations <= done.iteration + 1, "{done:?}");
}

/// With `scale_by_products` the solver's own passes multiply the angle columns by the reach's
/// inverse instead of dividing them by the reach: the fit is the same up to rounding (every
/// parameter within 1e-8 mm at the tool's scale, the same number of steps), and not the same bit
/// for bit, so the option really changes the arithmetic it claims to.
#[test]
fn scaling_by_products_fits_what_dividing_fits() {
    let (nominal, data, set) = perturbed_session(11);
    let cfg = LmConfig {
        scale_by_products: true,
        ..LmConfig::default()
    };
    let mut products = Levenberg::fixed(nominal.clone(), set.clone(), cfg).unwrap();
    let with = products.run(&data).unwrap();
    let mut divided = Levenberg::fixed(nominal.clone(), set, LmConfig::default()).unwrap();
    let without = divided.run(&data).unwrap();
    assert_eq!(with.iteration, without.iteration, "{with:?} vs {without:?}");
    let n = products.params().len();
    let mut differs = false;
    for i in 0..n {
        let p = products.params()[i];
        let (a, b) = (
            value(products.robot(), p).unwrap(),
            value(divided.robot(), p).unwrap(),
        );
        // In mm: the parameter times its scale (1 for lengths, the reach for angles).
        assert!(
            (a - b).abs() * products.scale(i) <= 1e-8,
            "{p:?}: {a} with products, {b} divided"
        );
        differs |= a != b;
    }
    assert!(differs, "the option changed no bit of the fit");
    assert!(
        (with.cost / without.cost - 1.0).abs() < 1e-9,
        "{with:?} vs {without:?}"
    );
}
