//! Online compensation against known truth: targets are the true robot's forward kinematics,
//! commands are checked on the true robot, singular / limited / unreachable targets give typed
//! errors with finite commands inside the step box, f32 agrees with f64, and the whole loop
//! (simulate → identify with LM → compensate) meets the accuracy.

use kinecal::compensate::{compensate, CompensateError, Config, Solution, Status, Target, Tracker};
use kinecal::identify::lm::{FixedLevenberg, LmConfig};
use kinecal::model::effects::EffectKind;
use kinecal::model::frame::orientation_error;
use kinecal::model::param::{apply_delta, ParamSet};
use kinecal::{ForwardKinematics, Frame, Joint, Measurement, Real, Robot};
use nalgebra::{DMatrix, Vector3};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

const V: usize = 128;
type Rng = Xoshiro256PlusPlus;

fn er20() -> Robot<f64, 6, V> {
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
        (-90.0, 140.0, 0.0, 760.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 125.0),
    ];
    let joints = rows.map(|(al, a, th, d)| Joint::mdh_deg(al, a, th, d));
    // The tracker sees the robot from a few metres away, turned and slightly tilted.
    let base = Frame::from_xyz_rpy(
        [2100.0, -850.0, -320.0],
        [
            0.3f64.to_radians(),
            -0.2f64.to_radians(),
            35f64.to_radians(),
        ],
    );
    Robot::new(base, joints, Vector3::new(12.0, -7.0, 95.0)).unwrap()
}

/// A 7-joint arm (iiwa-like) for the redundant case.
fn iiwa() -> Robot<f64, 7, V> {
    let rows = [
        (0.0, 0.0, 0.0, 340.0),
        (-90.0, 0.0, 0.0, 0.0),
        (90.0, 0.0, 0.0, 400.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 400.0),
        (-90.0, 0.0, 0.0, 0.0),
        (90.0, 0.0, 0.0, 126.0),
    ];
    let joints = rows.map(|(al, a, th, d)| Joint::mdh_deg(al, a, th, d));
    Robot::new(Frame::identity(), joints, Vector3::new(5.0, 0.0, 60.0)).unwrap()
}

/// Base, alpha/a/theta/d of every row, tool, and the tilt of joint 3 (parallel to joint 2).
fn geometry_set(n: usize) -> ParamSet<64> {
    let mut set = ParamSet::<64>::full(n, true).unwrap();
    set.push(kinecal::Param::Beta(2)).unwrap();
    set
}

/// Geometry errors on every row, the base and the tool (±0.8 mm, ±0.1°, tilt on the parallel
/// pair 2–3).
fn with_geometry_errors<const N: usize>(
    nominal: &Robot<f64, N, V>,
    rng: &mut Rng,
) -> Robot<f64, N, V> {
    let mut t = nominal.clone();
    let set = geometry_set(N);
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

#[derive(Clone, Copy, Debug, PartialEq)]
enum Fx {
    None,
    Compliance,
    Cyclic,
    Scale,
    Table,
    All,
}

fn add_effects<const N: usize>(r: &mut Robot<f64, N, V>, fx: Fx, rng: &mut Rng) {
    let e = r.effects_mut();
    if matches!(fx, Fx::Compliance | Fx::All) {
        e.push(EffectKind::Compliance, 1, N, 0, 0.0, 0.0, &[3e-4])
            .unwrap();
    }
    if matches!(fx, Fx::Cyclic | Fx::All) {
        e.push(EffectKind::Cyclic, 0, N, 1, 0.0, 0.0, &[1.5e-4, -8e-5])
            .unwrap();
        e.push(EffectKind::Cyclic, 2, N, 3, 0.0, 0.0, &[6e-5, 4e-5])
            .unwrap();
    }
    if matches!(fx, Fx::Scale | Fx::All) {
        e.push(EffectKind::Scale, 2, N, 0, 0.0, 0.0, &[4e-4])
            .unwrap();
    }
    if matches!(fx, Fx::Table | Fx::All) {
        // Knots every 10° over ±180° on joint 4 (and 2 for All), random ±0.1 mrad.
        let knots: Vec<f64> = (0..37).map(|_| rng.random_range(-1e-4..1e-4)).collect();
        e.push(
            EffectKind::Table,
            3,
            N,
            0,
            -std::f64::consts::PI,
            10f64.to_radians(),
            &knots,
        )
        .unwrap();
        if fx == Fx::All {
            let knots: Vec<f64> = (0..37).map(|_| rng.random_range(-1e-4..1e-4)).collect();
            e.push(
                EffectKind::Table,
                1,
                N,
                0,
                -std::f64::consts::PI,
                10f64.to_radians(),
                &knots,
            )
            .unwrap();
        }
    }
}

fn deg(x: f64) -> f64 {
    x.to_radians()
}

/// A random configuration of the ER20-like arm away from its singularities (wrist bent ≥ 20°,
/// elbow ≥ 20° from stretched).
fn er20_config(rng: &mut Rng) -> [f64; 6] {
    let q5 = rng.random_range(20.0..110.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    [
        deg(rng.random_range(-150.0..150.0)),
        deg(rng.random_range(-50.0..60.0)),
        deg(rng.random_range(-50.0..60.0)),
        deg(rng.random_range(-150.0..150.0)),
        deg(q5),
        deg(rng.random_range(-170.0..170.0)),
    ]
}

fn perturb<const N: usize>(q: &[f64; N], sigma_deg: f64, rng: &mut Rng) -> [f64; N] {
    let n = Normal::new(0.0, deg(sigma_deg)).unwrap();
    core::array::from_fn(|j| q[j] + n.sample(rng))
}

fn pose<T: Real, const N: usize, const W: usize>(r: &Robot<T, N, W>, q: &[T; N]) -> Frame<T> {
    let mut fk = ForwardKinematics::new();
    fk.compute(r, q);
    fk.flange_pose()
}

/// Position (mm) and orientation (rad) error of the robot's tool at `q` against `target`.
fn miss<const N: usize, const W: usize>(
    r: &Robot<f64, N, W>,
    q: &[f64; N],
    target: &Target<f64>,
) -> (f64, f64) {
    let f = pose(r, q);
    let dp = (f.o - target.point()).norm();
    let dw = match target {
        Target::Point(_) => 0.0,
        Target::Pose(t) => orientation_error(t, &f).norm(),
    };
    (dp, dw)
}

fn max_dev<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Smallest singular value of the scaled Jacobian by central differences and an SVD:
/// independent of the library's analytic Jacobian and of its σ_h bound.
fn sigma_min<const N: usize>(r: &Robot<f64, N, V>, q: &[f64; N], six: bool) -> f64 {
    let s = r.reach();
    let m = if six { 6 } else { 3 };
    let h = 1e-6;
    let f0 = pose(r, q);
    let mut j = DMatrix::zeros(m, N);
    for k in 0..N {
        let (mut qp, mut qm) = (*q, *q);
        qp[k] += h;
        qm[k] -= h;
        let (fp, fm) = (pose(r, &qp), pose(r, &qm));
        let dp = (fp.o - fm.o) / (2.0 * h);
        for i in 0..3 {
            j[(i, k)] = dp[i];
        }
        if six {
            let w = (orientation_error(&fp, &f0) - orientation_error(&fm, &f0)) / (2.0 * h) * s;
            for i in 0..3 {
                j[(3 + i, k)] = w[i];
            }
        }
    }
    j.singular_values()
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min)
}

fn target_of<const N: usize>(r: &Robot<f64, N, V>, q: &[f64; N], six: bool) -> Target<f64> {
    let f = pose(r, q);
    if six {
        Target::Pose(f)
    } else {
        Target::Point(f.o)
    }
}

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

fn check_safe<const N: usize>(sol: &Solution<f64, N>, seed: &[f64; N], cfg: &Config<f64>) {
    assert!(
        sol.q.iter().all(|v| v.is_finite()),
        "non-finite command {:?}",
        sol.q
    );
    assert!(
        sol.position_error.is_finite()
            && sol.orientation_error.is_finite()
            && sol.sigma.is_finite()
    );
    assert!(
        max_dev(&sol.q, seed) <= cfg.max_step * (1.0 + 1e-12),
        "jump of {} rad",
        max_dev(&sol.q, seed)
    );
}

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

/// Simulated laser-tracker data (80 poses, 10 µm noise) from a robot with hidden geometry
/// errors and a hidden effect; LM identifies geometry + the effect's values; then 100 random
/// targets with seeds off by 0.3° are compensated on the identified model and checked on the
/// true robot: RMS ≤ 0.03 mm, max ≤ 0.1 mm (the "done when"), in f64 and f32.
#[test]
fn identified_model_compensates_the_true_robot() {
    // A thread with the stack of a main thread (8 MiB), as the `kinecal` binary has.
    let h = std::thread::Builder::new()
        .stack_size(8 << 20)
        .spawn(end_to_end)
        .unwrap();
    h.join().unwrap();
}

fn end_to_end() {
    for (case, fx) in [
        (0u64, Fx::None),
        (1, Fx::Compliance),
        (2, Fx::Cyclic),
        (3, Fx::Table),
    ] {
        let mut rng = Rng::seed_from_u64(900 + case);
        let nominal = er20();
        let mut truth = with_geometry_errors(&nominal, &mut rng);
        // The table here: knots every 30° on joint 2, ±0.2 mrad (few enough values for 80 poses).
        match fx {
            Fx::Table => {
                let knots: Vec<f64> = (0..13).map(|_| rng.random_range(-2e-4..2e-4)).collect();
                truth
                    .effects_mut()
                    .push(
                        EffectKind::Table,
                        1,
                        6,
                        0,
                        -std::f64::consts::PI,
                        30f64.to_radians(),
                        &knots,
                    )
                    .unwrap();
            }
            fx => add_effects(&mut truth, fx, &mut rng),
        }
        // The model to identify: nominal geometry, the same effect structure with zero values,
        // and the base roughly known (a few mm, 0.2°: e.g. from the circle-point method).
        let mut model = nominal.clone();
        let b = *truth.base();
        let mut base = Frame::from_xyz_rpy([b.o.x + 3.0, b.o.y - 2.0, b.o.z + 4.0], b.rpy());
        base.rotate_in_parent(&Vector3::new(0.002, -0.003, 0.001));
        model.set_base(base).unwrap();
        for (i, e) in truth.effects().iter().enumerate() {
            let zeros = vec![0.0; truth.effects().values_of(i).len()];
            model
                .effects_mut()
                .push(
                    e.kind,
                    e.joint as usize,
                    6,
                    e.order,
                    e.start,
                    e.step,
                    &zeros,
                )
                .unwrap();
        }
        let noise = Normal::new(0.0, 0.01).unwrap();
        let mut fk = ForwardKinematics::new();
        let data: Vec<Measurement<f64, 6>> = (0..80)
            .map(|_| {
                let q: [f64; 6] = core::array::from_fn(|_| deg(rng.random_range(-170.0..170.0)));
                let p = fk.compute(&truth, &q);
                Measurement {
                    q,
                    point: p + Vector3::new(
                        noise.sample(&mut rng),
                        noise.sample(&mut rng),
                        noise.sample(&mut rng),
                    ),
                    ..Default::default()
                }
            })
            .collect();
        let set = geometry_set(6).with_effects(&model).unwrap();
        let mut lm = Box::new(
            FixedLevenberg::<f64, 6, V, 64>::fixed(model.clone(), set, LmConfig::default())
                .unwrap(),
        );
        let p = lm.run(&data).unwrap();
        let identified = lm.robot().clone();
        let id32: Robot<f32, 6, V> = identified.cast().unwrap();

        let cfg = Config::default();
        let (mut before, mut nominal_err, mut after, mut after32) =
            (vec![], vec![], vec![], vec![]);
        let mut n = 0;
        while n < 100 {
            let q = er20_config(&mut rng);
            let target = target_of(&truth, &q, false);
            let seed = perturb(&q, 0.3, &mut rng);
            // Targets where the identified model is singular are not what this measures.
            let sol = match compensate(&identified, &target, &seed, &cfg) {
                Ok(s) => s,
                Err(CompensateError::Singular(_)) => continue,
                Err(e) => panic!("case {case}: {e:?}"),
            };
            n += 1;
            before.push(miss(&truth, &seed, &target).0);
            nominal_err.push(
                miss(
                    &truth,
                    &compensate(&model, &target, &seed, &cfg)
                        .map(|s| s.q)
                        .unwrap_or(seed),
                    &target,
                )
                .0,
            );
            after.push(miss(&truth, &sol.q, &target).0);
            let t32 = Target::Point(target.point().cast::<f32>());
            let s32 = compensate(&id32, &t32, &seed.map(|v| v as f32), &Config::default()).unwrap();
            after32.push(miss(&truth, &s32.q.map(|v| v as f64), &target).0);
        }
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        eprintln!(
            "{fx:?}: LM {} iterations ({:?}); seed error RMS {:.3} mm; nominal-model compensation RMS {:.3} max {:.3}; identified: RMS {:.4} max {:.4} mm (f32: RMS {:.4} max {:.4})",
            p.iteration, p.stopped, rms(&before), rms(&nominal_err), max(&nominal_err), rms(&after), max(&after), rms(&after32), max(&after32)
        );
        assert!(
            rms(&after) <= 0.03 && max(&after) <= 0.1,
            "{fx:?}: RMS {} max {}",
            rms(&after),
            max(&after)
        );
        assert!(rms(&after32) <= 0.03 && max(&after32) <= 0.1);
        assert!(
            rms(&nominal_err) > 0.3,
            "the nominal model should be far off"
        );
    }
}

/// `kinecal compensate` end to end on files: a model written with the robot-file writer, a
/// targets file with seeds, points and orientations (plus a wrist-singular and an out-of-reach
/// row), the output read back: every `ok` row's command puts the model on its target.
#[test]
fn command_line_writes_commands_that_reach_the_targets() {
    use kinecal_cli::compensation::{run, Job};
    use kinecal_cli::formats::robot_file::RobotFile;
    use std::fmt::Write as _;
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng::seed_from_u64(81);
    let mut truth = with_geometry_errors(&er20(), &mut rng);
    add_effects(&mut truth, Fx::All, &mut rng);
    let model_path = dir.path().join("model.toml");
    RobotFile::from_robot("identified", &truth, true, &[2])
        .save(&model_path)
        .unwrap();
    let model = RobotFile::load(&model_path)
        .unwrap()
        .to_robot::<6>()
        .unwrap();

    for six in [false, true] {
        let mut csv = String::from("# seeds are the nominal joints\nq1,q2,q3,q4,q5,q6,x,y,z");
        csv.push_str(if six { ",rx,ry,rz\n" } else { "\n" });
        let mut targets = Vec::new();
        for i in 0..32 {
            let mut q = er20_config(&mut rng);
            if i == 30 {
                q[4] = 0.0; // wrist singular: matters only for the pose
            }
            let mut f = pose(&model, &q);
            if i == 31 {
                f.o = model.base().o + Vector3::new(0.0, 0.0, 1.5 * model.reach());
            }
            let seed = perturb(&q, 0.3, &mut rng);
            for v in seed {
                write!(csv, "{:.12},", v.to_degrees()).unwrap();
            }
            write!(csv, "{:.9},{:.9},{:.9}", f.o.x, f.o.y, f.o.z).unwrap();
            let rpy = f.rpy();
            if six {
                write!(
                    csv,
                    ",{:.12},{:.12},{:.12}",
                    rpy[0].to_degrees(),
                    rpy[1].to_degrees(),
                    rpy[2].to_degrees()
                )
                .unwrap();
            }
            csv.push('\n');
            let rad = rpy
                .map(|a| (a.to_degrees() * 1e12).round() / 1e12)
                .map(f64::to_radians);
            let t = Frame::from_xyz_rpy([f.o.x, f.o.y, f.o.z], rad);
            targets.push(if six {
                Target::Pose(t)
            } else {
                Target::Point(f.o)
            });
        }
        let t_path = dir.path().join("targets.csv");
        std::fs::write(&t_path, csv).unwrap();
        let out = dir.path().join("q.csv");
        let job = Job::new(&model_path, &t_path, &out);
        let j = run(&job).unwrap();
        assert_eq!(j.targets, 32);
        let text = std::fs::read_to_string(&out).unwrap();
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(&head[..7], &["q1", "q2", "q3", "q4", "q5", "q6", "status"]);
        let mut statuses = Vec::new();
        for (k, line) in lines.enumerate() {
            let cells: Vec<&str> = line.split(',').collect();
            let q: [f64; 6] =
                core::array::from_fn(|j| cells[j].parse::<f64>().unwrap().to_radians());
            assert!(
                cells[0].split('.').nth(1).unwrap().len() >= 6,
                "at least 6 decimals"
            );
            statuses.push(cells[6].to_string());
            if cells[6] == "ok" {
                let (dp, dw) = miss(&model, &q, &targets[k]);
                assert!(dp < 1e-4 && dw < 1e-7, "row {k}: {dp} mm {dw} rad");
            }
        }
        assert_eq!(statuses.len(), 32);
        assert_eq!(statuses[31], "unreachable");
        if six {
            assert_eq!(statuses[30], "singular");
        }
        let ok = statuses.iter().filter(|s| *s == "ok").count();
        assert!(ok >= 30 - 1, "{statuses:?}");
        assert_eq!(j.ok, ok);
        assert_eq!(j.failed, 32 - ok);

        // Streaming the same rows and the f32 path give the same statuses for the ok rows.
        for (stream, f32) in [(true, false), (false, true)] {
            let mut job = job.clone();
            job.settings.stream = stream;
            job.settings.f32 = f32;
            let j2 = run(&job).unwrap();
            assert_eq!(j2.ok, j.ok, "stream={stream} f32={f32}");
        }
    }

    // Malformed targets files: one line naming the file and the place.
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "q1,q2,q3,q4,q5,q6,x,y,z,rx,ry\n0,0,0,0,0,0,1,2,3,4,5\n",
    )
    .unwrap();
    let job = Job::new(&model_path, &bad, dir.path().join("q.csv"));
    let e = run(&job).unwrap_err().to_string();
    assert!(e.contains("bad.csv:1:") && e.contains("rz"), "{e}");
    std::fs::write(
        &bad,
        "q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n0,0,0,0,0,0,1,2,3,4,5,6\n0,0,0,0,0,0,1,2,3,4,,6\n",
    )
    .unwrap();
    let e = run(&job).unwrap_err().to_string();
    assert!(e.contains("bad.csv:3:11") && e.contains("ry"), "{e}");
    std::fs::write(&bad, "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,zero,1,2,3\n").unwrap();
    let e = run(&job).unwrap_err().to_string();
    assert!(e.contains("bad.csv:2:6"), "{e}");
}
