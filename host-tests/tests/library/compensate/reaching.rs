//! Targets reached on the true model: every effect inverted, conditioning, small arms, f32.

use super::*;

/// True robots with geometry errors and each kind of effect: random targets are reached within
/// 1e-4 mm (and 1e-7 rad for poses) from seeds off by 0.3°, inside the step box.
#[test]
fn reaches_targets_on_the_true_model_with_every_effect() {
    let cfg = Config::default();
    for (k, fx) in [
        Fx::None,
        Fx::Compliance,
        Fx::Cyclic,
        Fx::Scale,
        Fx::Table,
        Fx::All,
    ]
    .into_iter()
    .enumerate()
    {
        let mut rng = Rng::seed_from_u64(100 + k as u64);
        let mut truth = with_geometry_errors(&er20(), &mut rng);
        add_effects(&mut truth, fx, &mut rng);
        let thr = cfg.singular * truth.reach();
        for six in [false, true] {
            let (mut worst_p, mut worst_w, mut steps, mut n) = (0.0f64, 0.0f64, 0u32, 0);
            while n < 60 {
                let q = er20_config(&mut rng);
                if sigma_min(&truth, &q, six) < 3.0 * thr {
                    continue;
                }
                n += 1;
                let target = target_of(&truth, &q, six);
                let seed = perturb(&q, 0.3, &mut rng);
                let sol = compensate(&truth, &target, &seed, &cfg)
                    .unwrap_or_else(|e| panic!("{fx:?} six={six}: {e:?}"));
                let (dp, dw) = miss(&truth, &sol.q, &target);
                assert!(
                    dp < 1e-4 && dw < 1e-7,
                    "{fx:?} six={six}: missed by {dp} mm, {dw} rad"
                );
                assert!(max_dev(&sol.q, &seed) <= cfg.max_step);
                assert!((sol.position_error - dp).abs() < 1e-9);
                worst_p = worst_p.max(dp);
                worst_w = worst_w.max(dw);
                steps += sol.iterations as u32;
            }
            eprintln!(
                "{fx:?} {}: worst {worst_p:.2e} mm {worst_w:.2e} rad, {:.2} steps per call",
                if six { "6-D" } else { "3-D" },
                steps as f64 / n as f64
            );
        }
    }
}

/// The effects really are inverted: the same targets on the geometry-only part of the model
/// miss by far more than the tolerance, so the test above is not passing by accident.
#[test]
fn ignoring_the_effects_misses_the_target() {
    let mut rng = Rng::seed_from_u64(7);
    let geometric = with_geometry_errors(&er20(), &mut rng);
    let mut truth = geometric.clone();
    add_effects(&mut truth, Fx::All, &mut rng);
    let cfg = Config::default();
    let mut worst = 0.0f64;
    for _ in 0..20 {
        let q = er20_config(&mut rng);
        let target = target_of(&truth, &q, false);
        let seed = perturb(&q, 0.3, &mut rng);
        let wrong = compensate(&geometric, &target, &seed, &cfg)
            .map(|s| s.q)
            .unwrap_or(seed);
        worst = worst.max(miss(&truth, &wrong, &target).0);
    }
    eprintln!("geometry-only model: worst miss {worst:.3} mm");
    assert!(worst > 0.05, "effects too small to matter: {worst}");
}

/// σ_h reported in the solution bounds the smallest singular value: σ_h ≤ σ_min ≤ √m σ_h.
#[test]
fn conditioning_bounds_the_smallest_singular_value() {
    let mut rng = Rng::seed_from_u64(3);
    let mut truth = with_geometry_errors(&er20(), &mut rng);
    add_effects(&mut truth, Fx::Cyclic, &mut rng);
    let cfg = Config {
        singular: 0.0,
        ..Config::default()
    };
    for i in 0..40 {
        let six = i % 2 == 0;
        let mut q = er20_config(&mut rng);
        if i % 4 == 0 {
            q[4] = deg(rng.random_range(-3.0..3.0)); // near the wrist singularity too
        }
        let target = target_of(&truth, &q, six);
        let sol = match compensate(&truth, &target, &q, &cfg) {
            Ok(s) => s,
            Err(e) => *e.best().unwrap(),
        };
        let smin = sigma_min(&truth, &sol.q, six);
        let m: f64 = if six { 6.0 } else { 3.0 };
        assert!(
            sol.sigma <= smin * (1.0 + 1e-5) + 1e-6
                && smin <= m.sqrt() * sol.sigma * (1.0 + 1e-5) + 1e-6,
            "σ_h {} vs σ_min {smin}",
            sol.sigma
        );
    }
}

/// Seven joints: the minimum-norm step keeps the redundancy at the seed. At the answer,
/// q − seed must be (nearly) orthogonal to the Jacobian's null space: the first-order
/// condition of min |q − seed| subject to reaching the target.
#[test]
fn redundant_arm_stays_near_the_seed() {
    let mut rng = Rng::seed_from_u64(11);
    let mut truth = with_geometry_errors(&iiwa(), &mut rng);
    add_effects(&mut truth, Fx::All, &mut rng);
    let cfg = Config::default();
    for six in [false, true] {
        let mut n = 0;
        while n < 30 {
            let q: [f64; 7] = core::array::from_fn(|j| {
                if j % 2 == 1 {
                    deg(rng.random_range(25.0..100.0))
                        * if rng.random_bool(0.5) { 1.0 } else { -1.0 }
                } else {
                    deg(rng.random_range(-150.0..150.0))
                }
            });
            if sigma_min(&truth, &q, six) < 0.05 * truth.reach() {
                continue;
            }
            n += 1;
            let target = target_of(&truth, &q, six);
            let seed = perturb(&q, 0.3, &mut rng);
            let sol = compensate(&truth, &target, &seed, &cfg).unwrap();
            let (dp, dw) = miss(&truth, &sol.q, &target);
            assert!(dp < 1e-4 && dw < 1e-7, "missed by {dp} mm {dw} rad");
            // Null-space component of q − seed, with the finite-difference Jacobian.
            let m = if six { 6 } else { 3 };
            let mut j = DMatrix::zeros(m, 7);
            let f0 = pose(&truth, &sol.q);
            for k in 0..7 {
                let (mut qp, mut qm) = (sol.q, sol.q);
                qp[k] += 1e-6;
                qm[k] -= 1e-6;
                let (fp, fm) = (pose(&truth, &qp), pose(&truth, &qm));
                let dp = (fp.o - fm.o) / 2e-6;
                let dw = (orientation_error(&fp, &f0) - orientation_error(&fm, &f0)) / 2e-6;
                for i in 0..3 {
                    j[(i, k)] = dp[i];
                    if six {
                        j[(3 + i, k)] = dw[i];
                    }
                }
            }
            let d = nalgebra::DVector::from_iterator(7, (0..7).map(|k| sol.q[k] - seed[k]));
            let svd = j.svd(false, true);
            let vt = svd.v_t.unwrap();
            let row_part = &vt * &d;
            let null_sq = d.norm_squared() - row_part.norm_squared();
            assert!(
                null_sq.max(0.0).sqrt() < 1e-3 * d.norm(),
                "null-space drift {} of {}",
                null_sq.max(0.0).sqrt(),
                d.norm()
            );
        }
    }
}

/// Fewer joints than equations (planar 2R, point targets in its plane) and exactly as many
/// (the ER20's first three joints, point targets).
#[test]
fn small_arms_square_and_overdetermined() {
    let planar = Robot::<f64, 2, V>::new(
        Frame::identity(),
        [
            Joint::mdh_deg(0.0, 0.0, 0.0, 0.0),
            Joint::mdh_deg(0.0, 300.0, 0.0, 0.0),
        ],
        Vector3::new(250.0, 0.0, 0.0),
    )
    .unwrap();
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
    ];
    let mut arm3 = Robot::<f64, 3, V>::new(
        Frame::identity(),
        rows.map(|(a, b, c, d)| Joint::mdh_deg(a, b, c, d)),
        Vector3::new(700.0, 80.0, 0.0),
    )
    .unwrap();
    arm3.effects_mut()
        .push(EffectKind::Cyclic, 0, 3, 1, 0.0, 0.0, &[2e-4, 1e-4])
        .unwrap();
    let mut rng = Rng::seed_from_u64(5);
    let cfg = Config::default();
    let mut n = 0;
    while n < 30 {
        let q = [
            deg(rng.random_range(-150.0..150.0)),
            deg(rng.random_range(20.0..150.0)),
        ];
        let t = target_of(&planar, &q, false);
        let sol = compensate(&planar, &t, &perturb(&q, 0.3, &mut rng), &cfg).unwrap();
        assert!(miss(&planar, &sol.q, &t).0 < 1e-4);
        let q = [
            deg(rng.random_range(-150.0..150.0)),
            deg(rng.random_range(-40.0..60.0)),
            deg(rng.random_range(-40.0..80.0)),
        ];
        // Away from the shoulder (point on axis 1) and elbow (stretched) singularities.
        if sigma_min(&arm3, &q, false) < 3.0 * cfg.singular * arm3.reach() {
            continue;
        }
        n += 1;
        let t = target_of(&arm3, &q, false);
        let sol = compensate(&arm3, &t, &perturb(&q, 0.3, &mut rng), &cfg).unwrap();
        assert!(miss(&arm3, &sol.q, &t).0 < 1e-4);
    }
    // A pose target for an arm with fewer than six joints is refused.
    let t = Target::Pose(pose(&arm3, &[0.1, 0.2, 0.3]));
    assert_eq!(
        compensate(&arm3, &t, &[0.1, 0.2, 0.3], &cfg),
        Err(CompensateError::InvalidInput)
    );
}

/// The same model cast to f32 (Robot::cast), same targets and seeds: the f32 command puts the
/// true (f64) robot within 1 µm of where the f64 command puts it, and of the target.
#[test]
fn f32_agrees_with_f64_within_a_micrometre() {
    let mut rng = Rng::seed_from_u64(51);
    let mut truth = with_geometry_errors(&er20(), &mut rng);
    add_effects(&mut truth, Fx::All, &mut rng);
    let t32: Robot<f32, 6, V> = truth.cast().unwrap();
    let (c64, c32) = (Config::<f64>::default(), Config::<f32>::default());
    let (mut worst, mut worst_w) = (0.0f64, 0.0f64);
    for six in [false, true] {
        let mut n = 0;
        while n < 50 {
            let q = er20_config(&mut rng);
            if sigma_min(&truth, &q, six) < 3.0 * c64.singular * truth.reach() {
                continue;
            }
            n += 1;
            let target = target_of(&truth, &q, six);
            let seed = perturb(&q, 0.3, &mut rng);
            let s64 = compensate(&truth, &target, &seed, &c64).unwrap();
            let target32 = match target {
                Target::Point(p) => Target::Point(p.cast::<f32>()),
                Target::Pose(f) => Target::Pose(f.cast().unwrap()),
            };
            let s32 = compensate(&t32, &target32, &seed.map(|v| v as f32), &c32).unwrap();
            let q32 = s32.q.map(|v| v as f64);
            let p64 = pose(&truth, &s64.q).o;
            let p32 = pose(&truth, &q32).o;
            let d = (p32 - p64).norm();
            let (dp, dw) = miss(&truth, &q32, &target);
            worst = worst.max(d);
            assert!(
                d < 1e-3 && dp < 1e-3,
                "six={six}: f32 command {d} mm from the f64 one, {dp} mm from the target"
            );
            if six {
                // 1 µm at a metre of lever arm.
                assert!(dw < 1e-6, "f32 orientation off by {dw} rad");
                worst_w = worst_w.max(dw);
            }
        }
    }
    eprintln!(
        "f32 vs f64: worst {:.3} µm, orientation {:.2e} rad",
        worst * 1e3,
        worst_w
    );
}
