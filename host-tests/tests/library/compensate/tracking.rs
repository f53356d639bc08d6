//! The tracker along a trajectory: warm starts, and `follow` creeping at most one step.

use super::*;

/// Streaming along a short trajectory: each cycle reaches its target, the warm start from the
/// previous correction needs fewer steps than cold starts from the nominal, and `follow` moves
/// at most max_step per cycle.
#[test]
fn tracker_follows_a_trajectory() {
    let mut rng = Rng::seed_from_u64(61);
    let mut truth = with_geometry_errors(&er20(), &mut rng);
    add_effects(&mut truth, Fx::All, &mut rng);
    let cfg = Config::default();
    for six in [false, true] {
        let qa = er20_config(&mut rng);
        let qb: [f64; 6] = core::array::from_fn(|j| qa[j] + deg(rng.random_range(-8.0..8.0)));
        // The nominal model's systematic error, slowly varying along the path.
        let o1 = perturb(&[0.0; 6], 0.3, &mut rng);
        let o2 = perturb(&[0.0; 6], 0.05, &mut rng);
        let steps = 200;
        let path = |i: usize| -> [f64; 6] {
            core::array::from_fn(|j| qa[j] + (qb[j] - qa[j]) * i as f64 / steps as f64)
        };
        let mut tracker = Tracker::new(cfg);
        let (mut warm, mut cold) = (0u32, 0u32);
        let mut hist = [0; 9];
        for i in 0..=steps {
            let q = path(i);
            let t = i as f64 / steps as f64;
            let nominal: [f64; 6] =
                core::array::from_fn(|j| q[j] + o1[j] + o2[j] * (3.0 * t).sin());
            let target = target_of(&truth, &q, six);
            let s = tracker.next(&truth, &target, &nominal).unwrap();
            let (dp, dw) = miss(&truth, &s.q, &target);
            assert!(dp < 1e-4 && dw < 1e-7, "cycle {i}: {dp} mm {dw} rad");
            assert_eq!(tracker.last(), Some(&s.q));
            if i > 0 {
                warm += s.iterations as u32;
                hist[s.iterations as usize] += 1;
            }
            cold += compensate(&truth, &target, &nominal, &cfg)
                .unwrap()
                .iterations as u32;
        }
        eprintln!(
            "six={six}: {:.2} steps per cycle warm {hist:?}, {:.2} cold",
            warm as f64 / steps as f64,
            cold as f64 / (steps + 1) as f64
        );
        // Warm starts save at least one step per cycle on average, and no cycle needs more
        // than two (the second only because the Jacobian leaves out compliance's slope).
        assert!(
            hist[3..].iter().all(|h| *h == 0)
                && (warm as f64) / (steps as f64) + 1.0 < cold as f64 / (steps + 1) as f64
        );

        // Follow: no nominal solution, the previous command is the seed.
        let mut tracker = Tracker::new(cfg);
        tracker.start(&qa).unwrap();
        let mut prev = qa;
        for i in 1..=steps {
            let target = target_of(&truth, &path(i), six);
            let s = tracker.follow(&truth, &target).unwrap();
            assert!(miss(&truth, &s.q, &target).0 < 1e-4);
            assert!(max_dev(&s.q, &prev) <= cfg.max_step);
            prev = s.q;
        }
        // A jump in the target: follow creeps at most max_step, reports it, keeps going.
        let far = target_of(&truth, &path(0).map(|v| v + deg(10.0)), six);
        let e = tracker.follow(&truth, &far).unwrap_err();
        assert!(matches!(e, CompensateError::Limited(_)), "{e:?}");
        check_safe(e.best().unwrap(), &prev, &cfg);
        assert_eq!(tracker.last(), Some(&e.best().unwrap().q));
    }
}
