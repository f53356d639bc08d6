//! Singular and unreachable targets: a bent-flat wrist, a stretched arm, points beyond reach.

use super::*;

/// Wrist-singular pose targets (q5 = 0: axes 4 and 6 parallel) give `Singular` with a finite
/// command inside the step box; a bend of 10° does not.
#[test]
fn wrist_singular_pose_is_reported() {
    let mut rng = Rng::seed_from_u64(21);
    let mut truth = with_geometry_errors(&er20(), &mut rng);
    add_effects(&mut truth, Fx::Compliance, &mut rng);
    let cfg = Config::default();
    for i in 0..20 {
        let mut q = er20_config(&mut rng);
        q[4] = if i % 2 == 0 { 0.0 } else { deg(0.3) };
        let target = target_of(&truth, &q, true);
        let seed = perturb(&q, 0.3, &mut rng);
        let r = compensate(&truth, &target, &seed, &cfg);
        match r {
            Err(CompensateError::Singular(s)) => {
                check_safe(&s, &seed, &cfg);
                assert!(s.sigma < cfg.singular * truth.reach());
            }
            other => panic!("expected Singular, got {other:?}"),
        }
        q[4] = deg(10.0);
        let target = target_of(&truth, &q, true);
        let seed = perturb(&q, 0.3, &mut rng);
        assert!(compensate(&truth, &target, &seed, &cfg).is_ok());
    }
}

/// Fully stretches the ER20-like arm: joints 3–6 moved (numerically, coordinate by
/// coordinate) to put the point as far as possible from joint 2's origin. There the point
/// cannot move along the arm: the edge of the workspace, a singularity of point targets.
fn stretched(r: &Robot<f64, 6, V>, q: &mut [f64; 6]) {
    let mut fk = ForwardKinematics::new();
    let mut dist = |q: &[f64; 6]| {
        let p = fk.compute(r, q);
        (p - fk.frames[1].o).norm()
    };
    q[2] = deg(-80.0);
    q[4] = 0.0;
    for range in [90.0, 30.0, 10.0, 3.0, 1.0, 0.3] {
        for j in [2, 4, 3, 5, 2, 4] {
            // Grid, then ternary refinement around the best grid point.
            let c = q[j];
            let mut best = (f64::MIN, c);
            for k in -20..=20 {
                let mut t = *q;
                t[j] = c + deg(range) * k as f64 / 20.0;
                let d = dist(&t);
                if d > best.0 {
                    best = (d, t[j]);
                }
            }
            let (mut lo, mut hi) = (best.1 - deg(range) / 20.0, best.1 + deg(range) / 20.0);
            for _ in 0..100 {
                let (a, b) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
                let (mut ta, mut tb) = (*q, *q);
                ta[j] = a;
                tb[j] = b;
                if dist(&ta) < dist(&tb) {
                    lo = a
                } else {
                    hi = b
                }
            }
            let x = 0.5 * (lo + hi);
            q[j] = x.sin().atan2(x.cos());
        }
    }
}

/// Fully stretched arm (point target at the edge of the workspace) → `Singular`; a target
/// beyond reach → `Unreachable`; a point just outside the stretched arm → a typed error. All
/// with finite commands inside the step box.
#[test]
fn stretched_and_out_of_reach_targets_are_reported() {
    let mut rng = Rng::seed_from_u64(31);
    let mut truth = with_geometry_errors(&er20(), &mut rng);
    add_effects(&mut truth, Fx::All, &mut rng);
    let cfg = Config::default();
    for _ in 0..10 {
        let mut q = er20_config(&mut rng);
        stretched(&truth, &mut q);
        let seed = perturb(&q, 0.3, &mut rng);
        // On the stretched configuration itself.
        let target = target_of(&truth, &q, false);
        match compensate(&truth, &target, &seed, &cfg) {
            Err(CompensateError::Singular(s)) => check_safe(&s, &seed, &cfg),
            other => panic!("stretched: expected Singular, got {other:?}"),
        }
        // 30 mm further out along the arm: no solution exists.
        let mut fk = ForwardKinematics::new();
        let p = fk.compute(&truth, &q);
        let out = p + (p - fk.frames[1].o).normalize() * 30.0;
        let r = compensate(&truth, &Target::Point(out), &seed, &cfg);
        let s = r.expect_err("a point beyond the stretched arm cannot be reached");
        check_safe(s.best().unwrap(), &seed, &cfg);
        // Far beyond the reach bound.
        let far = truth.base().o + Vector3::new(1.0, 2.0, 0.5).normalize() * (1.2 * truth.reach());
        for six in [false, true] {
            let target = if six {
                Target::Pose(Frame {
                    o: far,
                    ..pose(&truth, &q)
                })
            } else {
                Target::Point(far)
            };
            match compensate(&truth, &target, &seed, &cfg) {
                Err(CompensateError::Unreachable(s)) => check_safe(&s, &seed, &cfg),
                other => panic!("far: expected Unreachable, got {other:?}"),
            }
        }
    }
}
