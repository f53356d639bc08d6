//! The pieces of the discrepancy workflow against known truth: the t distribution, the paired
//! test's false-alarm rate, the folds, the linearised screen against full refits, the
//! penalised table fit, and `kinecal diagnose` end to end (JSON keys, model file, plots).

use kinecal::param::{Param, ParamSet};
use kinecal::{Measurement, Robot};
use kinecal_host::candidates::{catalogue, Candidate, CandidateKind, CatalogueConfig};
use kinecal_host::cli::diagnose::{run, Args};
use kinecal_host::cross_validation::{candidate_columns, refit_errors, rms, Folds, Linearised};
use kinecal_host::data;
use kinecal_host::diagnose::fit_geometry;
use kinecal_host::penalised_fit::{fit, squared_errors, Problem, TablePenalty};
use kinecal_host::robot_file::RobotFile;
use kinecal_host::significance::{incomplete_beta, paired_improvement, repeat_noise, student_t_sf};
use kinecal_host::sim::{simulate, EffectArg, GeomErrors, Simulation};
use kinecal_host::VCAP;
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

fn big_stack<F: FnOnce() + Send + 'static>(f: F) {
    std::thread::Builder::new()
        .stack_size(1 << 30)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap();
}

fn effect(kind: &str, joint: usize, values: &[f64], order: u16) -> EffectArg {
    EffectArg {
        kind: kind.into(),
        joint: joint - 1,
        values: values.to_vec(),
        order,
    }
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
    big_stack(|| {
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
    big_stack(|| {
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
    big_stack(|| {
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
            let points = kinecal_host::sim::measure(&truth, &configs, sigma, &mut rng);
            for (q, p) in configs.iter().zip(points) {
                d.push(Measurement { q: *q, point: p });
            }
        }
        let r =
            kinecal_host::diagnose::diagnose(&er20(), true, &[], &d, &Default::default()).unwrap();
        assert_eq!(
            r.noise_source,
            kinecal_host::diagnose::NoiseSource::RepeatedPoses
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
    data::write(&data, &ds).unwrap();
    (data_dir().join("er20.toml"), data)
}

fn args(robot: PathBuf, data: PathBuf) -> Args {
    Args {
        robot,
        data,
        seed: 0,
        out: None,
        plots: None,
        holdout: None,
        validate: None,
        folds: 5,
        alpha: 0.05,
        max_order: 3,
        max_effects: 12,
    }
}

#[test]
fn diagnose_command_names_the_effect_writes_the_model_and_plots() {
    big_stack(|| {
        let tmp = tempfile::tempdir().unwrap();
        let (robot, data) = write_case(
            tmp.path(),
            vec![effect("joint-compliance", 2, &[2e-4], 1)],
            4,
        );
        let mut a = args(robot, data.clone());
        a.out = Some(tmp.path().join("m.toml"));
        a.plots = Some(tmp.path().join("plots"));
        let r = run(&a, true).unwrap();
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
        let d = kinecal_host::data::load::<6>(&data)
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
    big_stack(|| {
        let tmp = tempfile::tempdir().unwrap();
        let (robot, data) = write_case(tmp.path(), Vec::new(), 8);
        let r = run(&args(robot, data), true).unwrap();
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
    big_stack(|| {
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
        data::write(&data, &ds).unwrap();
        let e = run(&args(data_dir().join("er20.toml"), data), true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("too few"), "{e}");
        let mut a = args(data_dir().join("er20.toml"), tmp.path().join("missing.csv"));
        a.folds = 5;
        let e = run(&a, true).unwrap_err().to_string();
        assert!(e.contains("missing.csv"), "{e}");
    });
}
