//! The pieces of the discrepancy workflow against known truth: the t distribution, the paired
//! test's false-alarm rate, the folds, the linearised screen against full refits, the
//! penalised table fit, and `kinecal diagnose` end to end (JSON keys, model file, plots).

use crate::common::{effect, main_sized_stack};

use kinecal::model::param::{Param, ParamSet};
use kinecal::{Measurement, Robot};
use kinecal_cli::commands::diagnose::{run, Args};
use kinecal_cli::diagnose::candidates::{catalogue, Candidate, CandidateKind, CatalogueConfig};
use kinecal_cli::diagnose::cross_validation::{
    candidate_columns, refit_errors, rms, Folds, Linearised,
};
use kinecal_cli::diagnose::fit_geometry;
use kinecal_cli::diagnose::linear::{squared_errors, Problem, TablePenalty};
use kinecal_cli::diagnose::refit::fit;
use kinecal_cli::diagnose::significance::{
    incomplete_beta, paired_improvement, repeat_noise, student_t_sf,
};
use kinecal_cli::formats::measurements;
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::simulation::{simulate, EffectArg, GeomErrors, Simulation};
use kinecal_cli::VCAP;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::PathBuf;

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

fn er20() -> Robot<f64, 6, VCAP> {
    RobotFile::load(&data_dir().join("er20.toml"))
        .unwrap()
        .to_robot::<6>()
        .unwrap()
}

/// The progress callback sees the stages in the order they run: the geometry, the baseline,
/// then per round a screen of the candidates and a refit of the best families, as many rounds
/// as the result reports; the result equals that of `diagnose`.
#[test]
fn progress_reports_every_stage_in_order() {
    main_sized_stack(|| {
        use kinecal_cli::diagnose::{diagnose_with_progress, Progress};
        let (_, d) = simulated(vec![effect("joint-compliance", 2, &[3e-4], 1)], 0.01, 7, 80);
        let mut seen = Vec::new();
        let r = diagnose_with_progress(&er20(), true, &[], &d, &Default::default(), &mut |p| {
            seen.push(p)
        })
        .unwrap();
        assert_eq!(seen[..2], [Progress::Geometry, Progress::Baseline]);
        let mut round = 0;
        for pair in seen[2..].chunks(2) {
            round += 1;
            match pair {
                [Progress::Screen {
                    round: a,
                    candidates,
                }, Progress::Refit { round: b, families }] => {
                    assert_eq!((*a, *b), (round, round));
                    assert!(*candidates > 0 && *families > 0 && families <= candidates);
                }
                [Progress::Screen { round: a, .. }] => assert_eq!(*a, round),
                other => panic!("unexpected stages {other:?}"),
            }
        }
        assert!(round >= r.found.len().max(1), "{seen:?}");
        let plain =
            kinecal_cli::diagnose::diagnose(&er20(), true, &[], &d, &Default::default()).unwrap();
        assert_eq!(plain.final_validation_rms_mm, r.final_validation_rms_mm);
    });
}

fn simulated(
    effects: Vec<EffectArg>,
    noise: f64,
    seed: u64,
    poses: usize,
) -> (Robot<f64, 6, VCAP>, Vec<Measurement<f64, 6>>) {
    let s = Simulation {
        poses,
        noise_mm: noise,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects,
    };
    let (truth, d) = simulate(&er20(), &s).unwrap();
    (truth, d.measurements())
}

#[test]
fn student_t_tail_matches_tables() {
    // Two-sided 5 % critical values: t(10) = 2.228, t(30) = 2.042; normal limit 1.960.
    assert!((student_t_sf(2.228, 10.0) - 0.025).abs() < 2e-4);
    assert!((student_t_sf(2.042, 30.0) - 0.025).abs() < 2e-4);
    assert!((student_t_sf(1.95996, 1e7) - 0.025).abs() < 1e-5);
    // Cauchy (1 dof): P(T > 1) = 1/4; symmetry and the centre.
    assert!((student_t_sf(1.0, 1.0) - 0.25).abs() < 1e-12);
    assert!((student_t_sf(-2.228, 10.0) - 0.975).abs() < 2e-4);
    assert!((student_t_sf(0.0, 5.0) - 0.5).abs() < 1e-12);
    // I_x(1, 1) = x; I_½(a, a) = ½.
    assert!((incomplete_beta(1.0, 1.0, 0.3) - 0.3).abs() < 1e-12);
    assert!((incomplete_beta(7.5, 7.5, 0.5) - 0.5).abs() < 1e-12);
}

/// With nothing to find, the one-sided paired test rejects at its nominal rate, and a real
/// improvement of half a standard deviation over 100 poses is found almost always.
#[test]
fn paired_test_holds_its_level_and_has_power() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    // Squared errors of two models with the same error distribution (chi-square-like, skewed).
    let sq = Normal::new(0.0, 1.0).unwrap();
    let draw = |shift: f64, rng: &mut Xoshiro256PlusPlus| -> (Vec<f64>, Vec<f64>) {
        let a: Vec<f64> = (0..100)
            .map(|_| {
                (0..3)
                    .map(|_| {
                        let x: f64 = sq.sample(rng);
                        x * x
                    })
                    .sum::<f64>()
            })
            .collect();
        let b: Vec<f64> = a
            .iter()
            .map(|x| {
                let e: f64 = sq.sample(rng);
                x * (1.0 - shift) + 0.3 * e
            })
            .collect();
        (a, b)
    };
    let trials = 4000;
    let mut rejections = 0;
    for _ in 0..trials {
        let (a, b) = draw(0.0, &mut rng);
        rejections += usize::from(paired_improvement(&a, &b).p < 0.05);
    }
    let rate = rejections as f64 / trials as f64;
    assert!((0.035..0.065).contains(&rate), "false-alarm rate {rate}");
    let mut found = 0;
    for _ in 0..200 {
        let (a, b) = draw(0.3, &mut rng);
        found += usize::from(paired_improvement(&a, &b).p < 0.05 / 40.0);
    }
    assert!(found > 190, "power {found}/200");
}

#[test]
fn folds_are_deterministic_balanced_and_keep_repeats_together() {
    let (_, mut d) = simulated(Vec::new(), 0.01, 3, 103);
    // Poses 0, 1, 2 measured once more, 0.06 mm away in x: pooled σ² = 3·(0.06²/2) / 9.
    for i in 0..3 {
        let mut m = d[i];
        m.point.x += 0.06;
        d.push(m);
    }
    let a = Folds::new(&d, 5, 9);
    assert_eq!(a, Folds::new(&d, 5, 9));
    assert_ne!(a, Folds::new(&d, 5, 10));
    for i in 0..3 {
        assert_eq!(
            a.of[103 + i],
            a.of[i],
            "a repeat of pose {i} is in another fold"
        );
    }
    for f in 0..5 {
        let n = a.of.iter().filter(|x| **x == f).count();
        assert!((18..=24).contains(&n), "fold {f}: {n} poses");
    }
    let (sigma, dof) = repeat_noise(&d).unwrap();
    assert_eq!(dof, 9);
    assert!((sigma - 0.06 / 6f64.sqrt()).abs() < 1e-12, "{sigma}");
    // Two repeated groups are too few to trust.
    assert!(repeat_noise(&d[..105]).is_none());
}

/// At the current solution, one linearised step per fold predicts the held-out errors of the
/// full refits (the screen ranks candidates like the refits).
#[test]
fn linearised_screen_agrees_with_full_refits() {
    main_sized_stack(|| {
        let (_, d) = simulated(
            vec![effect("joint-compliance", 2, &[3e-4], 1)],
            0.02,
            11,
            100,
        );
        let nominal = er20();
        let (geo, held) = fit_geometry(&nominal, true, &[], &d).unwrap();
        let mut params: Vec<Param> = ParamSet::<64>::full(6, false).unwrap().as_slice().to_vec();
        params.retain(|p| !held.contains(p));
        let problem = Problem::new(&geo, &params, TablePenalty::default()).unwrap();
        let current = fit(&geo, &problem, &d, 20).unwrap().robot;
        let folds = Folds::new(&d, 5, 0);
        let lin = Linearised::new(&current, &problem, &d, &folds);
        let base_lin = rms(&lin.baseline());
        let base_refit = rms(&refit_errors(&current, &problem, &d, &folds, 20).unwrap());
        assert!(
            (base_lin / base_refit - 1.0).abs() < 0.01,
            "{base_lin} vs {base_refit}"
        );
        for c in [
            Candidate {
                kind: CandidateKind::Compliance,
                joint: 1,
            },
            Candidate {
                kind: CandidateKind::Cyclic(1),
                joint: 1,
            },
            Candidate {
                kind: CandidateKind::Scale,
                joint: 3,
            },
        ] {
            let mut robot_c = current.clone();
            let extra = c.add_to(&mut robot_c).unwrap();
            let cols = candidate_columns(&robot_c, &extra, &d);
            let screened = rms(&lin.screen(&cols, extra.len(), None));
            let mut p = problem.params.clone();
            p.extend(extra);
            let problem_c = Problem::new(&robot_c, &p, TablePenalty::default()).unwrap();
            let refit = rms(&refit_errors(&robot_c, &problem_c, &d, &folds, 20).unwrap());
            eprintln!(
                "{}: screen {screened:.5} refit {refit:.5} (baseline {base_refit:.5})",
                c.label()
            );
            assert!(
                (screened / refit - 1.0).abs() < 0.02,
                "{}: {screened} vs {refit}",
                c.label()
            );
        }
    });
}

/// A table on the grid the data were made with is recovered: the residual drops to the noise
/// and the knot values match the truth up to the part `theta` takes (a constant).
#[test]
fn penalised_fit_recovers_a_table() {
    main_sized_stack(|| {
        let knots = [2e-4, -1e-4, 3e-4, 0.0, -2e-4, 1e-4, -3e-4];
        let (truth, d) = simulated(vec![effect("joint-table", 3, &knots, 1)], 0.005, 21, 300);
        let nominal = er20();
        let (geo, held) = fit_geometry(&nominal, true, &[], &d).unwrap();
        let cands = catalogue(&geo, true, &d, &CatalogueConfig::default());
        // The 6-interval grid over joint 3's limits (the truth's) is on offer.
        let c = *cands
            .iter()
            .find(|c| c.joint == 2 && matches!(c.kind, CandidateKind::Table { step, .. } if (step.to_degrees() - 50.0).abs() < 1e-9))
            .expect("6-interval grid on joint 3");
        let mut robot = geo.clone();
        let extra = c.add_to(&mut robot).unwrap();
        let mut params: Vec<Param> = ParamSet::<64>::full(6, false).unwrap().as_slice().to_vec();
        params.retain(|p| !held.contains(p));
        params.extend(extra);
        let problem = Problem::new(&robot, &params, TablePenalty::default()).unwrap();
        let before = (squared_errors(&geo, &d).iter().sum::<f64>() / d.len() as f64).sqrt();
        let fitted = fit(&robot, &problem, &d, 30).unwrap();
        let after = (fitted.ssr / d.len() as f64).sqrt();
        assert!(before > 0.1, "{before}");
        assert!(after < 1.2 * 3f64.sqrt() * 0.005, "{before} → {after}");
        // Knot values up to a constant (which theta3 absorbed).
        let v = c.values(&fitted.robot);
        let CandidateKind::Table { start, step, .. } = c.kind else {
            unreachable!()
        };
        let offset = fitted.robot.joints()[2].theta - truth.joints()[2].theta;
        for (i, t) in knots.iter().enumerate() {
            let q = truth.joints()[2].lower + i as f64 * 50f64.to_radians();
            let k = ((q - start) / step).round() as usize;
            if k < v.len() {
                assert!(
                    (v[k] + offset - t).abs() < 2e-5,
                    "knot {i}: {} vs {t}",
                    v[k] + offset
                );
            }
        }
    });
}

/// With repeated poses the noise floor comes from their scatter (the model plays no part), and
/// the search stops once the held-out error reaches it.
#[test]
fn noise_floor_comes_from_repeated_poses() {
    main_sized_stack(|| {
        let sigma = 0.02;
        let (truth, mut d) = simulated(
            vec![effect("joint-compliance", 2, &[3e-4], 1)],
            sigma,
            31,
            80,
        );
        // The first 20 configurations measured twice more: same readings, fresh noise.
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(99);
        let configs: Vec<[f64; 6]> = d[..20].iter().map(|m| m.q).collect();
        for _ in 0..2 {
            let points = kinecal_cli::simulation::measure(&truth, &configs, sigma, &mut rng);
            for (q, p) in configs.iter().zip(points) {
                d.push(Measurement::new(*q, p));
            }
        }
        let r =
            kinecal_cli::diagnose::diagnose(&er20(), true, &[], &d, &Default::default()).unwrap();
        assert_eq!(
            r.noise_source,
            kinecal_cli::diagnose::NoiseSource::RepeatedPoses
        );
        let floor = 3f64.sqrt() * sigma;
        assert!(
            (r.noise_floor_mm / floor - 1.0).abs() < 0.2,
            "{} vs {floor}",
            r.noise_floor_mm
        );
        let names: Vec<(&str, usize)> = r
            .found
            .iter()
            .map(|f| (f.candidate.id(), f.candidate.joint))
            .collect();
        assert_eq!(names, [("joint-compliance", 1)]);
        assert!(r.final_validation_rms_mm < 1.25 * r.noise_floor_mm);
    });
}

fn write_case(dir: &std::path::Path, effects: Vec<EffectArg>, seed: u64) -> (PathBuf, PathBuf) {
    let s = Simulation {
        poses: 100,
        noise_mm: 0.02,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects,
    };
    let (_, ds) = simulate(&er20(), &s).unwrap();
    let data = dir.join("d.csv");
    measurements::write(&data, &ds).unwrap();
    (data_dir().join("er20.toml"), data)
}

/// `kinecal diagnose` arguments as the command line would give them (so that arguments added
/// later with defaults need no change here).
fn parse_args(argv: &[&str]) -> Args {
    use clap::Parser;
    #[derive(clap::Parser)]
    struct Cmd {
        #[command(flatten)]
        args: Args,
    }
    Cmd::try_parse_from(std::iter::once("diagnose").chain(argv.iter().copied()))
        .unwrap()
        .args
}

fn args(robot: PathBuf, data: PathBuf) -> Args {
    parse_args(&[
        "--robot",
        robot.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
    ])
}

#[test]
fn diagnose_command_names_the_effect_writes_the_model_and_plots() {
    main_sized_stack(|| {
        let tmp = tempfile::tempdir().unwrap();
        let (robot, data) = write_case(
            tmp.path(),
            vec![effect("joint-compliance", 2, &[2e-4], 1)],
            4,
        );
        let mut a = args(robot, data.clone());
        a.out = Some(tmp.path().join("m.toml"));
        a.plots = Some(tmp.path().join("plots"));
        let r = run(&a).unwrap().to_value();
        for key in [
            "baseline_validation_rms_mm",
            "found",
            "final_validation_rms_mm",
            "noise_floor_mm",
        ] {
            assert!(r.get(key).is_some(), "missing {key}");
        }
        let found = r["found"].as_array().unwrap();
        assert_eq!(found.len(), 1, "{r:#}");
        assert_eq!(found[0]["effect"], "joint-compliance");
        assert_eq!(found[0]["joint"], 2);
        let k = found[0]["values"][0].as_f64().unwrap();
        assert!((k - 2e-4).abs() < 2e-5, "compliance {k}");
        let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
        let fin = r["final_validation_rms_mm"].as_f64().unwrap();
        let floor = r["noise_floor_mm"].as_f64().unwrap();
        assert_eq!(found[0]["validation_rms_mm"].as_f64().unwrap(), fin);
        assert!(
            base > 3.0 * floor && fin < 1.25 * floor,
            "{base} → {fin}, floor {floor}"
        );
        assert!(
            (floor / (3f64.sqrt() * 0.02) - 1.0).abs() < 0.25,
            "floor {floor}"
        );
        assert!(found[0]["sentence"]
            .as_str()
            .unwrap()
            .starts_with("joint 2 deflects under load"));
        // The extended model reads back with its effect, and reproduces the data as well.
        let model = RobotFile::load(&tmp.path().join("m.toml")).unwrap();
        assert!(model.base.is_some());
        assert_eq!(model.effects.len(), 1);
        assert_eq!(model.effects[0].kind, "joint-compliance");
        assert_eq!(model.effects[0].joint, 2);
        let robot = model.to_robot::<6>().unwrap();
        let d = kinecal_cli::formats::measurements::load::<6>(&data)
            .unwrap()
            .measurements::<f64>();
        let fit_rms = (squared_errors(&robot, &d).iter().sum::<f64>() / d.len() as f64).sqrt();
        assert!(fit_rms < floor, "model file fit {fit_rms}");
        // Plots: per-pose errors and one per named effect, valid SVG.
        let plots: Vec<String> = r["plots"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p.as_str().unwrap().to_string())
            .collect();
        assert_eq!(plots.len(), 2);
        for p in plots {
            let text = std::fs::read_to_string(&p).unwrap();
            assert!(text.contains("<svg") && text.contains("</svg>"), "{p}");
        }
    });
}

#[test]
fn diagnose_command_names_nothing_when_nothing_is_missing() {
    main_sized_stack(|| {
        let tmp = tempfile::tempdir().unwrap();
        let (robot, data) = write_case(tmp.path(), Vec::new(), 8);
        let r = run(&args(robot, data)).unwrap().to_value();
        assert_eq!(r["found"].as_array().unwrap().len(), 0, "{r:#}");
        let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
        assert_eq!(base, r["final_validation_rms_mm"].as_f64().unwrap());
        assert!(base < 1.25 * r["noise_floor_mm"].as_f64().unwrap());
        assert!(r["summary"]
            .as_str()
            .unwrap()
            .starts_with("Nothing significant is missing from the model"));
    });
}

#[test]
fn diagnose_command_refuses_bad_input_with_a_reason() {
    main_sized_stack(|| {
        let tmp = tempfile::tempdir().unwrap();
        let s = Simulation {
            poses: 6,
            noise_mm: 0.02,
            seed: 1,
            geom_errors: None,
            effects: Vec::new(),
        };
        let (_, ds) = simulate(&er20(), &s).unwrap();
        let data = tmp.path().join("few.csv");
        measurements::write(&data, &ds).unwrap();
        let e = run(&args(data_dir().join("er20.toml"), data))
            .unwrap_err()
            .to_string();
        assert!(e.contains("too few"), "{e}");
        let mut a = args(data_dir().join("er20.toml"), tmp.path().join("missing.csv"));
        a.folds = 5;
        let e = run(&a).unwrap_err().to_string();
        assert!(e.contains("missing.csv"), "{e}");
    });
}

// ---------------------------------------------------------------------------------------------
// The noise floor and the figures of the human output (a user's report on 24 real poses: a
// "noise floor" above the held-out error, "0.018 → 0.018 mm", and "starting model refitted
// 0.2972 mm → extended model 0.3023 mm" with nothing added).

/// A robot of the tests, as nominal (what diagnose is given) and as simulated (its base where
/// the tracker sees it), the base known or not.
struct Arm {
    name: &'static str,
    nominal: Robot<f64, 6, VCAP>,
    simulated: Robot<f64, 6, VCAP>,
    base_known: bool,
}

fn arms() -> Vec<Arm> {
    let er = er20();
    let ur10 = RobotFile::load(&data_dir().join("ur10.toml")).unwrap();
    let nominal = ur10.to_robot::<6>().unwrap();
    let mut simulated = nominal.clone();
    // As in the test matrix: the tracker sees the base about 3 m away, diagnose starts from
    // the identity (base estimated).
    simulated
        .set_base(kinecal::Frame::from_xyz_rpy(
            [380.0, -3240.0, 200.0],
            [0.3f64, -0.2, 35.0].map(f64::to_radians),
        ))
        .unwrap();
    assert!(!ur10.base_known());
    vec![
        Arm {
            name: "er20",
            nominal: er.clone(),
            simulated: er,
            base_known: true,
        },
        Arm {
            name: "ur10",
            nominal,
            simulated,
            base_known: false,
        },
    ]
}

/// `identify + held` poses of `arm` with geometric errors only (nothing hidden), σ = `sigma`.
fn nothing_hidden(
    arm: &Arm,
    identify: usize,
    held: usize,
    sigma: f64,
    seed: u64,
) -> (Vec<Measurement<f64, 6>>, Vec<Measurement<f64, 6>>) {
    let s = Simulation {
        poses: identify + held,
        noise_mm: sigma,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects: Vec::new(),
    };
    let mut d = simulate(&arm.simulated, &s).unwrap().1.measurements();
    let held = d.split_off(identify);
    (d, held)
}

/// `diagnose` of `arm`'s nominal model on `ident`, with the default configuration.
fn diagnose_arm(arm: &Arm, ident: &[Measurement<f64, 6>]) -> kinecal_cli::diagnose::Diagnosis<6> {
    kinecal_cli::diagnose::diagnose(
        &arm.nominal,
        arm.base_known,
        &[],
        ident,
        &Default::default(),
    )
    .unwrap()
}

fn rms_of(sq: &[f64]) -> f64 {
    (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
}

/// On 24 poses (5 folds of ~19 identification poses for ~25 parameters) the held-out errors
/// carry much more than the noise: the floor must not exceed what held-out poses reach, and
/// still be of the noise's size. Nothing is hidden: nothing is named, and the final model is
/// the baseline's own fit.
#[test]
fn noise_floor_never_exceeds_the_held_out_rms_on_few_poses() {
    main_sized_stack(|| {
        let sigma = 0.02;
        let truth = 3f64.sqrt() * sigma;
        for arm in arms() {
            for seed in [1u64, 2, 3] {
                let (ident, held) = nothing_hidden(&arm, 24, 100, sigma, seed);
                let d = diagnose_arm(&arm, &ident);
                let unseen = rms_of(&squared_errors(&d.model, &held));
                let line = format!(
                    "{} seed {seed}: floor {:.4} [{:.4}, {:.4}] (true {truth:.4}), cross-validated {:.4}, unseen poses {unseen:.4}, found {}",
                    arm.name,
                    d.noise_floor_mm,
                    d.noise_floor_interval_mm[0],
                    d.noise_floor_interval_mm[1],
                    d.final_validation_rms_mm,
                    d.found.len()
                );
                eprintln!("{line}");
                assert_eq!(d.noise_source, kinecal_cli::diagnose::NoiseSource::HeldOut);
                assert!(
                    d.noise_floor_mm.is_finite() && d.noise_floor_mm > 0.0,
                    "{line}"
                );
                assert!(d.noise_floor_mm <= d.final_validation_rms_mm, "{line}");
                // Of the noise's size (the estimate has ~45 degrees of freedom here).
                assert!((0.7..1.4).contains(&(d.noise_floor_mm / truth)), "{line}");
                let [lo, hi] = d.noise_floor_interval_mm;
                assert!(lo < d.noise_floor_mm && d.noise_floor_mm < hi, "{line}");
                // Nothing hidden: nothing named, and the final model is the baseline's fit.
                assert!(d.found.is_empty(), "{line}");
                assert_eq!(d.final_validation_rms_mm, d.baseline_validation_rms_mm);
                assert_eq!(
                    squared_errors(&d.model, &held),
                    squared_errors(&d.baseline_model, &held),
                    "{line}: the final model is a different fit than the baseline's"
                );
            }
        }
    });
}

/// On many poses the fold fits add little, and the floor is an honest estimate of √3 σ.
#[test]
fn noise_floor_is_the_noise_level_on_many_poses() {
    main_sized_stack(|| {
        let sigma = 0.02;
        let truth = 3f64.sqrt() * sigma;
        for arm in arms() {
            for seed in [5u64, 6] {
                let (ident, _) = nothing_hidden(&arm, 200, 0, sigma, seed);
                let d = diagnose_arm(&arm, &ident);
                let line = format!(
                    "{} seed {seed}: floor {:.4} [{:.4}, {:.4}] / true {truth:.4} = {:.3}, cross-validated {:.4}",
                    arm.name,
                    d.noise_floor_mm,
                    d.noise_floor_interval_mm[0],
                    d.noise_floor_interval_mm[1],
                    d.noise_floor_mm / truth,
                    d.final_validation_rms_mm
                );
                eprintln!("{line}");
                assert!((0.8..1.25).contains(&(d.noise_floor_mm / truth)), "{line}");
                assert!(d.noise_floor_mm <= d.final_validation_rms_mm, "{line}");
                let [lo, hi] = d.noise_floor_interval_mm;
                assert!(
                    lo < truth && truth < hi,
                    "{line}: interval misses the truth"
                );
                assert!(hi / lo < 1.3, "{line}: interval too wide for 200 poses");
            }
        }
    });
}

/// Chi-square quantiles of the interval against tables.
#[test]
fn chi_square_quantiles_match_tables() {
    use kinecal_cli::diagnose::significance::{chi_square_quantile, normal_quantile};
    assert!((normal_quantile(0.975) - 1.959_964).abs() < 1e-6);
    assert!((normal_quantile(0.025) + 1.959_964).abs() < 1e-6);
    assert!((normal_quantile(0.5)).abs() < 1e-12);
    // χ²(10): 3.247, 20.483; χ²(100): 74.22, 129.56.
    for (p, nu, q) in [
        (0.025, 10.0, 3.247),
        (0.975, 10.0, 20.483),
        (0.025, 100.0, 74.222),
        (0.975, 100.0, 129.561),
    ] {
        let x = chi_square_quantile(p, nu);
        assert!((x / q - 1.0).abs() < 0.01, "χ²({nu}) {p}: {x} vs {q}");
    }
}

/// Figures that differ print differently; equal ones alike; never `inf` or `NaN`.
#[test]
fn figures_that_differ_print_differently() {
    use kinecal_cli::diagnose::distinct_figures;
    assert_eq!(distinct_figures([0.0178, 0.0174]), ["0.0178", "0.0174"]);
    let [a, b] = distinct_figures([0.29720, 0.29724]);
    assert_ne!(a, b);
    assert_eq!((a.as_str(), b.as_str()), ("0.29720", "0.29724"));
    assert_eq!(distinct_figures([0.2972, 0.2972]), ["0.297", "0.297"]);
    let [x, y, z] = distinct_figures([f64::NAN, f64::INFINITY, 0.05]);
    assert_eq!((x.as_str(), y.as_str(), z.as_str()), ("-", "-", "0.0500"));
}

/// The numbers in `text` (tokens that parse as f64, punctuation around them trimmed).
fn numbers(text: &str) -> Vec<(String, f64)> {
    text.split(|c: char| c.is_whitespace() || c == '(' || c == ')' || c == '[' || c == ']')
        .map(|t| t.trim_end_matches([',', ';', ':', '.']))
        .filter_map(|t| t.parse::<f64>().ok().map(|v| (t.to_string(), v)))
        .collect()
}

/// `printed` shows `value` to at least three significant digits.
fn shows(printed: &(String, f64), value: f64) -> bool {
    (printed.1 - value).abs() <= 0.005 * value.abs() + 1e-15
}

fn kinecal(argv: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
        .args(argv)
        .output()
        .unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "kinecal {argv:?}: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The user's case, simulated: 24 poses searched, 6 held out, nothing hidden. The JSON's
/// starting and extended figures are one fit (equal exactly), the floor is below both held-out
/// figures, and the human output says it once, with no `inf`/`NaN`.
#[test]
fn nothing_added_reports_one_fit_and_a_floor_below_the_held_out_errors() {
    main_sized_stack(|| {
        let tmp = tempfile::tempdir().unwrap();
        let arms = arms();
        for (arm, seed) in [(&arms[0], 11u64), (&arms[1], 12)] {
            let (mut ident, held) = nothing_hidden(arm, 24, 6, 0.02, seed);
            ident.extend(held);
            let path = tmp.path().join(format!("{}.csv", arm.name));
            let mut points = Vec::new();
            let mut configs = Vec::new();
            for m in &ident {
                configs.push(m.q);
                points.push(m.point);
            }
            measurements::write(&path, &kinecal_cli::simulation::dataset(&configs, &points))
                .unwrap();
            let robot = data_dir().join(format!("{}.toml", arm.name));
            let argv = [
                "diagnose",
                "--robot",
                robot.to_str().unwrap(),
                "--data",
                path.to_str().unwrap(),
                "--holdout",
                "6",
            ];
            let r = run(&parse_args(&argv[1..])).unwrap().to_value();
            assert_eq!(r["poses"], 24);
            assert_eq!(r["found"].as_array().unwrap().len(), 0, "{r:#}");
            let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
            let fin = r["final_validation_rms_mm"].as_f64().unwrap();
            let floor = r["noise_floor_mm"].as_f64().unwrap();
            let h = &r["holdout"];
            let (hg, hf) = (
                h["geometric_rms_mm"].as_f64().unwrap(),
                h["final_rms_mm"].as_f64().unwrap(),
            );
            eprintln!(
                "{}: cross-validated {base:.5} → {fin:.5}, floor {floor:.5}, held-out {hg:.5} → {hf:.5}",
                arm.name
            );
            assert_eq!(base, fin);
            assert_eq!(hg, hf, "refitted and extended are different fits");
            assert!(
                floor <= fin && floor <= hf,
                "floor {floor} above {fin} / {hf}"
            );
            let iv = r["noise_floor_interval_mm"].as_array().unwrap();
            assert!(iv[0].as_f64().unwrap() <= floor && floor <= iv[1].as_f64().unwrap());
            // Human output: one held-out figure, shown to three significant digits or more.
            let text = kinecal(&argv);
            eprintln!("{text}");
            for bad in ["NaN", "inf", " → -"] {
                assert!(!text.contains(bad), "{bad} in:\n{text}");
            }
            let line = text
                .lines()
                .find(|l| l.starts_with("held-out poses (6)"))
                .unwrap_or_else(|| panic!("no held-out line in:\n{text}"));
            assert!(
                !line.contains('→') && line.contains("nothing added"),
                "{line}"
            );
            let nums = numbers(line);
            assert_eq!(nums.len(), 2, "{line}"); // "(6)" and the figure
            assert!(shows(&nums[1], hf), "{line} vs {hf}");
            let summary = text.lines().nth(1).unwrap();
            let nums = numbers(summary);
            assert!(shows(&nums[0], base) && shows(&nums[1], floor), "{summary}");
        }
    });
}

/// Something found: every figure of the headline, the sentence and the held-out line is shown
/// to at least three significant digits, and figures that differ print differently (without
/// held-out poses the final cross-validated RMS and the floor differ by a few % only).
#[test]
fn human_output_shows_small_differences() {
    main_sized_stack(|| {
        let tmp = tempfile::tempdir().unwrap();
        let (robot, data) = write_case(
            tmp.path(),
            vec![effect("joint-compliance", 2, &[2e-4], 1)],
            4,
        );
        let argv = [
            "diagnose",
            "--robot",
            robot.to_str().unwrap(),
            "--data",
            data.to_str().unwrap(),
        ];
        let r = run(&parse_args(&argv[1..])).unwrap().to_value();
        assert_eq!(r["found"].as_array().unwrap().len(), 1, "{r:#}");
        let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
        let fin = r["final_validation_rms_mm"].as_f64().unwrap();
        let floor = r["noise_floor_mm"].as_f64().unwrap();
        assert!(floor < fin && fin < 1.1 * floor, "{fin} vs {floor}");
        let text = kinecal(&argv);
        eprintln!("{text}");
        for bad in ["NaN", "inf"] {
            assert!(!text.contains(bad), "{bad} in:\n{text}");
        }
        // "1 effect(s) missing from the model: held-out RMS A → B mm, noise floor C mm."
        let summary = text.lines().nth(1).unwrap();
        let nums = numbers(summary);
        assert_eq!(nums.len(), 4, "{summary}");
        for (n, v) in nums[1..].iter().zip([base, fin, floor]) {
            assert!(shows(n, v), "{summary}: {} shows {v}", n.0);
        }
        assert_ne!(
            nums[2].0, nums[3].0,
            "{summary}: final and floor print alike"
        );
        // The sentence of the effect (under its explanation): the same figures.
        assert!(text
            .lines()
            .any(|l| l.starts_with("  1. Joint 2 deflects under load")));
        let sentence = text
            .lines()
            .find(|l| l.starts_with("     The search: "))
            .unwrap();
        assert!(
            sentence.contains(&format!("{} → {} mm", nums[1].0, nums[2].0)),
            "{sentence}"
        );
        // With held-out poses: "held-out poses (20): starting model refitted X mm → extended
        // model Y mm".
        let argv = [&argv[..], &["--holdout", "20"]].concat();
        let r = run(&parse_args(&argv[1..])).unwrap().to_value();
        let hg = r["holdout"]["geometric_rms_mm"].as_f64().unwrap();
        let hf = r["holdout"]["final_rms_mm"].as_f64().unwrap();
        assert!(r["noise_floor_mm"].as_f64().unwrap() <= hf);
        let text = kinecal(&argv);
        eprintln!("{text}");
        let line = text
            .lines()
            .find(|l| l.starts_with("held-out poses (20)"))
            .unwrap();
        let nums = numbers(line);
        assert_eq!(nums.len(), 3, "{line}");
        assert!(shows(&nums[1], hg) && shows(&nums[2], hf), "{line}");
        assert_ne!(nums[1].0, nums[2].0, "{line}");
    });
}
