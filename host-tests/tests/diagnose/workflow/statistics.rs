//! The statistics of the search: the t distribution, the paired test's level and power, χ².

use super::*;

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

/// A finding must lower the held-out RMS by a margin a user notices, not only pass the test:
/// on 20,000 poses a candidate that lowers it by 1 % is overwhelmingly significant and is not
/// added (and [`too_small`] names it with its 1 % for the stop reason); one that lowers it by
/// 3 % is; with none significant, nothing is reported as too small.
#[test]
fn a_finding_must_lower_the_held_out_rms_noticeably() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
    let sq = Normal::new(0.0, 0.01).unwrap();
    let before: Vec<f64> = (0..20_000)
        .map(|_| {
            (0..3)
                .map(|_| f64::powi(sq.sample(&mut rng), 2))
                .sum::<f64>()
        })
        .collect();
    let rms = |e: &[f64]| (e.iter().sum::<f64>() / e.len() as f64).sqrt();
    let start = rms(&before);
    // A drop of the held-out RMS by `d`: every squared error scaled by (1 − d)².
    let lowered = |d: f64| -> Vec<f64> { before.iter().map(|x| x * (1.0 - d).powi(2)).collect() };
    let tested = |kind, e: &[f64]| Tested {
        candidate: Candidate { kind, joint: 1 },
        parameters: 1,
        validation_rms_mm: rms(e),
        test: paired_improvement(&before, e),
    };
    let (small, large) = (lowered(0.01), lowered(0.03));
    let cands = [
        tested(CandidateKind::Scale, &small),
        tested(CandidateKind::Compliance, &large),
    ];
    let threshold = 0.05 / 300.0;
    assert!(cands.iter().all(|t| t.test.p < 1e-12), "both significant");
    let max_rms = (1.0 - Config::default().min_rms_drop) * start;
    assert_eq!(
        choose(&cands, &[&small, &large], threshold, max_rms),
        Some(1)
    );
    assert_eq!(choose(&cands[..1], &[&small], threshold, max_rms), None);
    let (t, drop) = too_small(&cands[..1], threshold, start).expect("the 1 % candidate");
    assert_eq!(t.candidate.kind, CandidateKind::Scale);
    assert!((drop - 0.01).abs() < 1e-9, "{drop}");
    // Not significant: not "too small" either.
    let noisy: Vec<f64> = before
        .iter()
        .map(|x| x * (1.0 + 0.5 * sq.sample(&mut rng) / 0.01))
        .collect();
    let unsure = [tested(CandidateKind::Scale, &noisy)];
    assert!(unsure[0].test.p > threshold, "{:?}", unsure[0].test);
    assert!(too_small(&unsure, threshold, start).is_none());
}

/// A family refused as implausible is held back until another effect has been added, then
/// offered once more; refused a second time, it is held back for good. Other families are not.
#[test]
fn a_refused_family_is_offered_once_more_after_a_finding() {
    let on = |kind, joint| Candidate { kind, joint };
    let compliance = on(CandidateKind::Compliance, 3);
    let other = on(CandidateKind::Compliance, 2);
    assert!(!held_back(&[], &compliance, 0));
    let once = [(compliance, 0)];
    assert!(held_back(&once, &compliance, 0), "nothing added since");
    assert!(!held_back(&once, &compliance, 1), "a table added since");
    assert!(!held_back(&once, &other, 0), "another joint");
    let twice = [(compliance, 0), (compliance, 1)];
    assert!(held_back(&twice, &compliance, 2));
    assert!(held_back(&twice, &compliance, 5));
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

/// The whole search stops at the margin and says why: with `min_rms_drop` raised to 99.9 % no
/// candidate can be added, so a hidden joint-2 compliance that passes the test is reported as
/// below the margin (`Diagnosis::below_margin`, the stop reason with its figure) and nothing is
/// found; at the default margin the same data name it.
#[test]
fn the_search_reports_a_significant_candidate_below_the_margin() {
    let (_, d) = simulated(
        vec![effect("joint-compliance", 2, &[3e-4], 1)],
        0.01,
        41,
        200,
    );
    let strict = Config {
        min_rms_drop: 0.999,
        ..Config::default()
    };
    let r = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &d, &strict).unwrap();
    assert!(r.found.is_empty(), "{:?}", r.found.len());
    let (c, drop) = r
        .below_margin
        .expect("a significant candidate below the margin");
    assert!(drop > 0.02 && drop < 0.999, "{drop}");
    assert!(
        r.stop_reason.contains(&c.label()) && r.stop_reason.contains("by only"),
        "{}",
        r.stop_reason
    );
    let r = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &d, &Config::default()).unwrap();
    assert!(r.below_margin.is_none());
    let names: Vec<(&str, usize)> = r
        .found
        .iter()
        .map(|f| (f.candidate.id(), f.candidate.joint))
        .collect();
    assert!(names.contains(&("joint-compliance", 1)), "{names:?}");
}
