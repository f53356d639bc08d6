//! Simulated ER20-C10 stand-in for the PSO, BPNN and BPNN-PSO tests: built from the
//! library directly (nominal robot, known parameter errors, random poses, Gaussian noise).
#![allow(dead_code)]

use kinecal::model::param::{apply_delta, ParamSet};
use kinecal::{ForwardKinematics, Frame, Joint, Measurement, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The ER20-C10 stand-in: rows (alpha°, a mm, theta°, d mm), tool (0, 0, 100) mm.
pub fn er20_nominal() -> Robot<f64, 6> {
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
        (-90.0, 140.0, 0.0, 760.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 125.0),
    ];
    let joints = rows.map(|(al, a, th, d)| Joint::mdh_deg(al, a, th, d));
    Robot::new(Frame::identity(), joints, Vector3::new(0.0, 0.0, 100.0)).unwrap()
}

/// The 24 MDH parameters (alpha, a, theta, d per joint).
pub fn mdh24() -> ParamSet<24> {
    ParamSet::mdh(6).unwrap()
}

/// Fixed errors of the paper's kind (alpha/theta within ±0.2°, a/d within ±1 mm), in the order
/// of [`mdh24`], in rad and mm.
pub fn er20_errors() -> [f64; 24] {
    let table = [
        (0.12, -0.60, 0.15, 0.80),
        (-0.08, 0.90, -0.18, -0.40),
        (0.15, -0.75, 0.10, 0.50),
        (-0.17, 0.40, -0.12, -0.90),
        (0.06, -0.30, 0.19, 0.70),
        (-0.11, 0.55, -0.07, -0.35),
    ];
    let mut e = [0.0; 24];
    for (j, (al, a, th, d)) in table.iter().enumerate() {
        e[4 * j] = f64::to_radians(*al);
        e[4 * j + 1] = *a;
        e[4 * j + 2] = f64::to_radians(*th);
        e[4 * j + 3] = *d;
    }
    e
}

/// A small drift after some time in service: alpha/theta within ±0.02°, a/d within ±0.1 mm.
pub fn er20_drift() -> [f64; 24] {
    let table = [
        (0.015, -0.08, -0.010, 0.06),
        (0.010, 0.05, 0.020, -0.09),
        (-0.020, 0.07, -0.015, 0.04),
        (0.012, -0.10, 0.018, 0.08),
        (-0.008, 0.06, -0.020, -0.05),
        (0.018, -0.04, 0.010, 0.10),
    ];
    let mut e = [0.0; 24];
    for (j, (al, a, th, d)) in table.iter().enumerate() {
        e[4 * j] = f64::to_radians(*al);
        e[4 * j + 1] = *a;
        e[4 * j + 2] = f64::to_radians(*th);
        e[4 * j + 3] = *d;
    }
    e
}

/// `nominal ⊕ delta` over the 24 MDH parameters.
pub fn with_delta(nominal: &Robot<f64, 6>, delta: &[f64; 24]) -> Robot<f64, 6> {
    let mut r = nominal.clone();
    apply_delta(&mut r, &mdh24(), delta).unwrap();
    r
}

/// `n` poses with joint readings uniform in a typical working range, measured on `truth`
/// with isotropic Gaussian noise of `sigma_mm` per axis.
pub fn poses(
    truth: &Robot<f64, 6>,
    n: usize,
    sigma_mm: f64,
    seed: u64,
) -> Vec<Measurement<f64, 6>> {
    let ranges_deg = [
        (-170.0, 170.0),
        (-80.0, 60.0),
        (-70.0, 80.0),
        (-170.0, 170.0),
        (-115.0, 115.0),
        (-180.0, 180.0),
    ];
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma_mm).unwrap();
    let mut fk = ForwardKinematics::new();
    (0..n)
        .map(|_| {
            let q = ranges_deg.map(|(lo, hi): (f64, f64)| rng.random_range(lo..hi).to_radians());
            let p = fk.compute(truth, &q);
            let point = p + Vector3::new(
                noise.sample(&mut rng),
                noise.sample(&mut rng),
                noise.sample(&mut rng),
            );
            Measurement::new(q, point)
        })
        .collect()
}
