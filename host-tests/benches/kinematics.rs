//! Forward kinematics and the identification Jacobian (full parameter set: base, alpha, a,
//! theta, d per joint, tool = 33 columns), f32 and f64, on a 6-joint arm placed 2.5 m from
//! the tracker. Each iteration evaluates one configuration of a fixed set of 64.

use criterion::{criterion_group, criterion_main, Criterion};
use kinecal::forward::ForwardKinematics;
use kinecal::model::param::ParamSet;
use kinecal::{Frame, Joint, Real, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::hint::black_box;

/// The ER20-C10 stand-in of the issue, with a small tilt and a placed base.
fn robot<T: Real>() -> Robot<T, 6, kinecal::Inline<0>> {
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
        (-90.0, 140.0, 0.0, 760.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 125.0),
    ];
    let mut joints = rows.map(|(al, a, th, d)| Joint::<T>::mdh_deg(al, a, th, d));
    joints[2].beta = T::of(0.001);
    let base = Frame::from_xyz_rpy(
        [T::of(2500.0), T::of(-300.0), T::of(100.0)],
        [T::of(0.01), T::of(-0.02), T::of(2.0)],
    );
    Robot::new(
        base,
        joints,
        Vector3::new(T::zero(), T::zero(), T::of(100.0)),
    )
    .expect("valid robot")
}

fn configs<T: Real>() -> Vec<[T; 6]> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
    (0..64)
        .map(|_| std::array::from_fn(|_| T::of(rng.random_range(-3.0..3.0))))
        .collect()
}

fn bench_type<T: Real>(c: &mut Criterion, name: &str) {
    let r = robot::<T>();
    let qs = configs::<T>();
    let mut fk = ForwardKinematics::<T, 6>::new();
    let mut i = 0usize;
    c.bench_function(&format!("fk_{name}"), |b| {
        b.iter(|| {
            i = (i + 1) & 63;
            black_box(fk.compute(black_box(&r), black_box(&qs[i])))
        })
    });
    let set = ParamSet::<64>::full(6, true).expect("fits");
    let params = set.as_slice();
    let mut cols = vec![Vector3::<T>::zeros(); params.len()];
    c.bench_function(&format!("jacobian_full{}_{name}", params.len()), |b| {
        b.iter(|| {
            i = (i + 1) & 63;
            fk.compute(black_box(&r), black_box(&qs[i]));
            fk.identification_jacobian(&r, params, &mut cols)
                .expect("valid set");
            black_box(&cols);
        })
    });
}

fn kinematics(c: &mut Criterion) {
    bench_type::<f64>(c, "f64");
    bench_type::<f32>(c, "f32");
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
