//! One PSO iteration of the paper's size (200 particles × 50 poses, 24 MDH parameters) in f32
//! and f64, with and without the per-pose trigonometry cache; plus the BPNN's training epoch.
//! The goal is the paper's 404 iterations in under 1 s: < 2.5 ms per iteration.

use criterion::{criterion_group, criterion_main, Criterion};
use kinecal::identify::bpnn::{Bpnn, BpnnConfig};
use kinecal::identify::bpnn_pso::MdhSeedNet;
use kinecal::identify::fitness::{JointTrig, PositionFitness};
use kinecal::identify::pso::{Pso, PsoConfig};
use kinecal::model::param::{apply_delta, ParamSet};
use kinecal::{ForwardKinematics, Frame, Joint, Measurement, Real, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::hint::black_box;

fn er20<T: Real>() -> Robot<T, 6> {
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
        (-90.0, 140.0, 0.0, 760.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 125.0),
    ];
    Robot::new(
        Frame::identity(),
        rows.map(|(al, a, th, d)| Joint::mdh_deg(al, a, th, d)),
        Vector3::new(T::zero(), T::zero(), T::of(100.0)),
    )
    .unwrap()
}

/// 50 poses of the ER20 stand-in with errors of the paper's size.
fn data<T: Real>(params: &ParamSet<24>) -> Vec<Measurement<T, 6>> {
    let mut truth = er20::<f64>();
    let delta: Vec<f64> = (0..24)
        .map(|k| {
            if k % 2 == 1 {
                0.8 * ((k as f64) * 0.7).sin()
            } else {
                0.003 * ((k as f64) * 1.3).cos()
            }
        })
        .collect();
    apply_delta(&mut truth, params, &delta).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut fk = ForwardKinematics::new();
    (0..50)
        .map(|_| {
            let q: [f64; 6] = core::array::from_fn(|_| rng.random_range(-2.5..2.5));
            let p = fk.compute(&truth, &q);
            Measurement::new(q.map(T::of), p.map(T::of))
        })
        .collect()
}

fn iteration<T: Real>(c: &mut Criterion, name: &str) {
    let params = ParamSet::<24>::mdh(6).unwrap();
    let nominal = er20::<T>();
    let data = data::<T>(&params);
    let mut cfg = PsoConfig::<T, 24>::calibration(params.as_slice()).unwrap();
    cfg.max_iterations = u32::MAX;
    cfg.stagnation_window = 0;
    let mut cache: Vec<JointTrig<T, 6>> = vec![[(T::zero(), T::zero()); 6]; data.len()];
    let mut cached = PositionFitness::with_cache(&nominal, &params, &data, &mut cache).unwrap();
    let mut pso = Box::new(Pso::<T, 200, 24>::new(cfg, 1).unwrap());
    c.bench_function(&format!("pso iteration 200x50 {name} (cached trig)"), |b| {
        b.iter(|| black_box(pso.step(&mut cached, 200).unwrap()))
    });
    let mut plain = PositionFitness::new(&nominal, &params, &data).unwrap();
    let mut pso = Box::new(Pso::<T, 200, 24>::new(cfg, 1).unwrap());
    c.bench_function(
        &format!("pso iteration 200x50 {name} (ForwardKinematics)"),
        |b| b.iter(|| black_box(pso.step(&mut plain, 200).unwrap())),
    );
}

fn bench(c: &mut Criterion) {
    iteration::<f64>(c, "f64");
    iteration::<f32>(c, "f32");

    // Training the BPNN-PSO network on a finished run: 200 pairs, 24 → 12 → 24.
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let xs: Vec<[f64; 24]> = (0..200)
        .map(|_| core::array::from_fn(|_| rng.random_range(-1.0..1.0)))
        .collect();
    let ys: Vec<[f64; 24]> = xs
        .iter()
        .map(|x| core::array::from_fn(|k| 0.1 * x[k] + 0.01 * x[(k + 1) % 24]))
        .collect();
    let mut net: MdhSeedNet<f64> = Bpnn::new(BpnnConfig::default(), 0).unwrap();
    net.fit_ranges(&xs, &ys).unwrap();
    c.bench_function("bpnn train_epoch 200 pairs 24-12-24 f64", |b| {
        b.iter(|| black_box(net.train_epoch(&xs, &ys).unwrap()))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
