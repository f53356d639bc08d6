//! The command stays safe: joint limits, the step bound, refused inputs, never a NaN or a jump.

use super::*;

/// Joint limits and the step bound: the command stays inside both and the result says
/// `Limited`; a redundant (point) target still reaches with one joint held at its limit.
#[test]
fn limits_and_step_bound_are_respected() {
    let mut rng = Rng::seed_from_u64(41);
    let truth0 = with_geometry_errors(&er20(), &mut rng);
    let cfg = Config::default();
    for _ in 0..20 {
        let q = er20_config(&mut rng);
        // Joint 2's upper limit 0.5° below the answer; the seed inside the limits.
        let mut truth = truth0.clone();
        let mut j2 = *truth.joint(1).unwrap();
        j2.upper = q[1] - deg(0.5);
        truth.set_joint(1, j2).unwrap();
        let mut seed = perturb(&q, 0.3, &mut rng);
        seed[1] = q[1] - deg(1.0);
        let target = target_of(&truth, &q, true);
        match compensate(&truth, &target, &seed, &cfg) {
            Err(CompensateError::Limited(s)) => {
                check_safe(&s, &seed, &cfg);
                assert!(truth.within_limits(&s.q));
                assert_eq!(
                    s.q[1], j2.upper,
                    "the limited joint should sit at its limit"
                );
            }
            other => panic!("expected Limited, got {other:?}"),
        }
        // Point target: the other five joints make up for it (the wrist needs a few degrees
        // for that, more than the default bound).
        let target = target_of(&truth, &q, false);
        let wide = Config {
            max_step: deg(8.0),
            iterations: 12,
            ..cfg
        };
        let s = compensate(&truth, &target, &seed, &wide).expect("redundant point target");
        assert!(truth.within_limits(&s.q) && miss(&truth, &s.q, &target).0 < 1e-4);

        // Step bound: the seed 5° off on joint 1 with a 2° bound.
        let mut seed = perturb(&q, 0.3, &mut rng);
        seed[0] = q[0] + deg(5.0);
        let target = target_of(&truth0, &q, true);
        match compensate(&truth0, &target, &seed, &cfg) {
            Err(CompensateError::Limited(s)) => {
                check_safe(&s, &seed, &cfg);
                assert!((s.q[0] - (seed[0] - cfg.max_step)).abs() < 1e-12);
            }
            other => panic!("expected Limited by the step bound, got {other:?}"),
        }
        // A looser bound reaches it.
        let loose = Config {
            max_step: deg(8.0),
            iterations: 12,
            ..cfg
        };
        let s = compensate(&truth0, &target, &seed, &loose).unwrap();
        assert!(miss(&truth0, &s.q, &target).0 < 1e-4);
    }
    // A seed beyond a limit by more than the bound: moved max_step towards the range, Limited.
    let q = [0.0, 0.0, 0.0, 0.0, deg(45.0), 0.0];
    let mut seed = q;
    seed[0] = deg(190.0);
    let target = target_of(&truth0, &q, false);
    match compensate(&truth0, &target, &seed, &cfg) {
        Err(CompensateError::Limited(s)) => {
            check_safe(&s, &seed, &cfg);
            assert!((s.q[0] - (seed[0] - cfg.max_step)).abs() < 1e-12);
        }
        other => panic!("expected Limited, got {other:?}"),
    }
}

#[test]
fn non_finite_inputs_are_refused() {
    let truth = er20();
    let q = er20_config(&mut Rng::seed_from_u64(1));
    let good = target_of(&truth, &q, true);
    let cfg = Config::default();
    let mut bad_pose = pose(&truth, &q);
    bad_pose.x.y = f64::NAN;
    let bad_targets = [
        Target::Point(Vector3::new(f64::NAN, 0.0, 0.0)),
        Target::Point(Vector3::new(0.0, f64::INFINITY, 0.0)),
        Target::Pose(bad_pose),
    ];
    for t in bad_targets {
        assert_eq!(
            compensate(&truth, &t, &q, &cfg),
            Err(CompensateError::InvalidInput)
        );
    }
    let mut seed = q;
    seed[3] = f64::NEG_INFINITY;
    assert_eq!(
        compensate(&truth, &good, &seed, &cfg),
        Err(CompensateError::InvalidInput)
    );
    for bad in [
        Config {
            max_step: 0.0,
            ..cfg
        },
        Config {
            max_step: f64::NAN,
            ..cfg
        },
        Config {
            damping: -1.0,
            ..cfg
        },
        Config {
            accept: f64::INFINITY,
            ..cfg
        },
        Config {
            orientation_scale: Some(0.0),
            ..cfg
        },
        Config {
            singular: f64::NAN,
            ..cfg
        },
    ] {
        assert_eq!(
            compensate(&truth, &good, &q, &bad),
            Err(CompensateError::InvalidInput)
        );
    }
    let mut tr = Tracker::<f64, 6>::new(cfg);
    assert_eq!(tr.follow(&truth, &good), Err(CompensateError::InvalidInput));
    assert_eq!(Status::of(&tr.follow(&truth, &good)), Status::Invalid);
    assert!(tr.start(&seed).is_err() && tr.last().is_none());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]
    /// Whatever the numbers: no panic, and either `InvalidInput` or a finite command in the box.
    #[test]
    fn never_nan_never_a_jump(
        xyz in prop::array::uniform3(prop_oneof![-1e7..1e7f64, prop::num::f64::ANY]),
        rpy in prop::array::uniform3(-10.0..10.0f64),
        seed in prop::array::uniform6(prop_oneof![-20.0..20.0f64, prop::num::f64::ANY]),
        six in any::<bool>(),
        max_step in prop_oneof![1e-6..1.0f64, Just(f64::NAN), Just(-1.0)],
        iterations in 0u8..20,
    ) {
        let mut rng = Rng::seed_from_u64(71);
        let mut truth = with_geometry_errors(&er20(), &mut rng);
        add_effects(&mut truth, Fx::All, &mut rng);
        let cfg = Config { max_step, iterations, ..Config::default() };
        let target = if six { Target::Pose(Frame::from_xyz_rpy(xyz, rpy)) } else { Target::Point(Vector3::from(xyz)) };
        let near = (target.point() - truth.base().o).norm() <= kinecal::compensate::FAR * truth.reach();
        let valid = target.is_finite() && near && seed.iter().all(|v| v.is_finite()) && cfg.is_valid();
        match compensate(&truth, &target, &seed, &cfg) {
            Err(CompensateError::InvalidInput) => prop_assert!(!valid),
            r => {
                prop_assert!(valid);
                let s = match &r { Ok(s) => s, Err(e) => e.best().unwrap() };
                prop_assert!(s.q.iter().all(|v| v.is_finite()));
                prop_assert!(s.position_error.is_finite() && s.sigma.is_finite());
                for (j, lim) in truth.joints().iter().enumerate() {
                    let inside = s.q[j] >= lim.lower && s.q[j] <= lim.upper;
                    // Within max_step of the seed (to the rounding of seed ± max_step), and inside
                    // the limits or, for a seed beyond them, moved max_step towards them.
                    let rounding = 4.0 * f64::EPSILON * (max_step + seed[j].abs());
                    let dev = (s.q[j] - seed[j]).abs();
                    prop_assert!(dev <= max_step + rounding);
                    prop_assert!(inside || (dev - max_step).abs() <= rounding);
                }
            }
        }
    }
}
