//! The search's pieces: folds, the linearised screen against full refits, the table fit, repeats.

use super::*;

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
        // The round's figure, from the folds' normal sums, is the same RMS.
        let from_sums = lin.screen_rms(&cols, extra.len(), None);
        assert!(
            (from_sums / screened - 1.0).abs() < 1e-8,
            "{from_sums} vs {screened}"
        );
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
}

/// The largest difference of `b`'s errors from `a`'s, relative to `a`'s.
fn worst_relative(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs() / a.max(1e-12))
        .fold(0.0, f64::max)
}

/// The screen's two ways of solving a fold's system (the model's parameters eliminated first,
/// or a table's knots first, on their band factor) give the same held-out errors: for tables
/// with fewer and with more knots than the model has parameters, on a model without and with a
/// table of its own (whose knots are then model parameters).
#[test]
fn both_eliminations_of_the_screen_agree() {
    let knots = [2e-4, -1e-4, 3e-4, 0.0, -2e-4, 1e-4, -3e-4];
    let (_, d) = simulated(
        vec![
            effect("joint-table", 3, &knots, 1),
            effect("joint-compliance", 2, &[3e-4], 1),
        ],
        0.01,
        23,
        400,
    );
    let (geo, held) = fit_geometry(&er20(), true, &[], &d).unwrap();
    let mut params: Vec<Param> = ParamSet::<64>::full(6, false).unwrap().as_slice().to_vec();
    params.retain(|p| !held.contains(p));
    let (lo, hi) = (0..6).fold(([f64::MAX; 6], [f64::MIN; 6]), |(mut lo, mut hi), j| {
        for m in &d {
            lo[j] = lo[j].min(m.q[j]);
            hi[j] = hi[j].max(m.q[j]);
        }
        (lo, hi)
    });
    let table = |joint: usize, knots: usize| Candidate {
        kind: CandidateKind::Table {
            start: lo[joint],
            step: (hi[joint] - lo[joint]) / (knots - 1) as f64,
            knots,
        },
        joint,
    };
    // The model: the geometry alone, then with a 40-knot table on joint 3.
    let mut with_table = geo.clone();
    let own = table(2, 40).add_to(&mut with_table).unwrap();
    let mut params_t = params.clone();
    params_t.extend(own);
    for (robot, params) in [(geo.clone(), params), (with_table, params_t)] {
        let problem = Problem::new(&robot, &params, TablePenalty::default()).unwrap();
        let current = fit(&robot, &problem, &d, 20).unwrap().robot;
        let lin = Linearised::new(&current, &problem, &d, &Folds::new(&d, 5, 0));
        let p = problem.len();
        // Tables over the whole covered range, and over its middle only (the readings beyond
        // either end on the end knots).
        let middle = Candidate {
            kind: CandidateKind::Table {
                start: lo[1] + 0.3 * (hi[1] - lo[1]),
                step: 0.05 * (hi[1] - lo[1]),
                knots: 9,
            },
            joint: 1,
        };
        for c in [
            table(1, 6),
            table(1, 30),
            table(1, 90),
            table(4, 150),
            middle,
        ] {
            let mut robot_c = current.clone();
            let extra = c.add_to(&mut robot_c).unwrap();
            let m = extra.len();
            let cols = candidate_columns(&robot_c, &extra, &d);
            let pen = Some(TablePenalty::default());
            let by_model = lin.screen_by(&cols, m, pen, Some(Elimination::Model));
            // The table's shortcut (its columns along the joint's reading directions: per fold,
            // running sums over the blocks sorted by reading, formed once per joint) against the
            // general sums of the same columns.
            let mut general = PoseColumns::with_capacity(cols.poses(), 0);
            for b in 0..cols.poses() {
                general.push_pose(cols.pose(b).iter().copied());
            }
            assert!(lin.takes_table_shortcut(&cols) && !lin.takes_table_shortcut(&general));
            let by_general = lin.screen_by(&general, m, pen, Some(Elimination::Model));
            let shortcut_off = worst_relative(&by_model, &by_general);
            assert!(shortcut_off < 1e-9, "p {p}, m {m}: {shortcut_off}");
            let by_knots = lin.screen_by(&cols, m, pen, Some(Elimination::Candidate));
            let worst = worst_relative(&by_model, &by_knots);
            // The RMS from the folds' normal sums is the per-pose errors' RMS.
            let from_sums = lin.screen_rms(&cols, m, pen);
            let sums_off = (from_sums / rms(&by_model) - 1.0).abs();
            eprintln!(
                "p {p}, m {m}: worst relative difference {worst:.2e}, RMS from sums {sums_off:.2e}, shortcut {shortcut_off:.2e}"
            );
            assert!(by_model.iter().all(|e| e.is_finite()), "p {p}, m {m}");
            assert!(worst < 1e-6, "p {p}, m {m}: {worst}");
            assert!(
                sums_off < 1e-8,
                "p {p}, m {m}: {from_sums} vs {}",
                rms(&by_model)
            );
        }
    }
    // The cheaper one: the knots first only for a band with many knots.
    let band = |m: usize| DMatrix::<f64>::identity(m, m);
    assert_eq!(Elimination::cheaper(60, 10, &band(10)), Elimination::Model);
    assert_eq!(
        Elimination::cheaper(60, 150, &band(150)),
        Elimination::Candidate
    );
    let mut dense = band(150);
    dense[(140, 3)] = 0.5;
    dense[(3, 140)] = 0.5;
    assert_eq!(Elimination::cheaper(60, 150, &dense), Elimination::Model);
}

/// A table on the grid the data were made with is recovered: the residual drops to the noise
/// and the knot values match the truth up to the part `theta` takes (a constant).
#[test]
fn penalised_fit_recovers_a_table() {
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
}

/// With repeated poses the noise floor comes from their scatter (the model plays no part), and
/// the search stops once the held-out error reaches it.
#[test]
fn noise_floor_comes_from_repeated_poses() {
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
    let r = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &d, &Default::default()).unwrap();
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
}

/// The table shortcut on 6-D observations with point and orientation weights (two blocks per
/// pose: the point's along the joint's weighted reading column, the orientation's along its
/// axis times the orientation weight): the same held-out errors as the general sums of the same
/// columns, for tables on a wrist joint and on an arm joint.
#[test]
fn the_table_shortcut_takes_orientations_and_weights() {
    let (_, mut d) = simulated(Vec::new(), 0.01, 29, 200);
    let (geo, held) = fit_geometry(&er20(), true, &[], &d).unwrap();
    for (i, m) in d.iter_mut().enumerate() {
        m.orientation = Some(kinecal::Frame::identity());
        m.orientation_weight = 40.0 + (i % 3) as f64;
        m.weight = nalgebra::Vector3::new(1.0, 0.5 + (i % 4) as f64 * 0.25, 2.0);
    }
    let mut params: Vec<Param> = ParamSet::<64>::full(6, false).unwrap().as_slice().to_vec();
    params.retain(|p| !held.contains(p));
    let problem = Problem::new(&geo, &params, TablePenalty::default()).unwrap();
    let lin = Linearised::new(&geo, &problem, &d, &Folds::new(&d, 5, 0));
    for joint in [5, 1] {
        let c = Candidate {
            kind: CandidateKind::Table {
                start: (-180f64).to_radians(),
                step: 12f64.to_radians(),
                knots: 31,
            },
            joint,
        };
        let mut robot_c = geo.clone();
        let extra = c.add_to(&mut robot_c).unwrap();
        let m = extra.len();
        let cols = candidate_columns(&robot_c, &extra, &d);
        assert_eq!(
            cols.poses(),
            2 * d.len(),
            "a point and an orientation block per pose"
        );
        let mut general = PoseColumns::with_capacity(cols.poses(), 0);
        for b in 0..cols.poses() {
            general.push_pose(cols.pose(b).iter().copied());
        }
        assert!(lin.takes_table_shortcut(&cols) && !lin.takes_table_shortcut(&general));
        let pen = Some(TablePenalty::default());
        let by_shortcut = lin.screen_by(&cols, m, pen, Some(Elimination::Model));
        let by_general = lin.screen_by(&general, m, pen, Some(Elimination::Model));
        assert!(by_shortcut.iter().all(|e| e.is_finite()), "joint {joint}");
        let off = worst_relative(&by_general, &by_shortcut);
        assert!(off < 1e-9, "joint {joint}: {off}");
    }
}
