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

mod end_to_end;
mod reaching;
mod safety;
mod singularities;
mod tracking;

type V = kinecal::Inline<128>;
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

fn pose<T: Real, const N: usize, W: kinecal::ValueStorage>(
    r: &Robot<T, N, W>,
    q: &[T; N],
) -> Frame<T> {
    let mut fk = ForwardKinematics::new();
    fk.compute(r, q);
    fk.flange_pose()
}

/// Position (mm) and orientation (rad) error of the robot's tool at `q` against `target`.
fn miss<const N: usize, W: kinecal::ValueStorage>(
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
