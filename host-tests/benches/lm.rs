//! Full Levenberg–Marquardt solves (50 poses, 10 µm noise, geometry errors of the paper's kind):
//! the 24-parameter MDH set and the full set (+ tool), in f64 and f32.

use criterion::{criterion_group, criterion_main, Criterion};
use kinecal::identify::lm::{FixedLevenberg, LmConfig};
use kinecal::model::param::{apply_delta, ParamSet};
use kinecal::{ForwardKinematics, Measurement, Real, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::hint::black_box;

/// The ER20-C10 stand-in of the demo (joint limits ±170°).
fn er20() -> Robot<f64, 6, kinecal::Inline<0>> {
    kinecal_cli::simulation::er20_c10()
        .with_capacity::<kinecal::Inline<0>>()
        .unwrap()
}

fn data() -> (Robot<f64, 6, kinecal::Inline<0>>, Vec<Measurement<f64, 6>>) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let nominal = er20();
    let mut truth = nominal.clone();
    let set = ParamSet::<64>::full(6, false).unwrap();
    let d: Vec<f64> = set
        .as_slice()
        .iter()
        .map(|p| {
            if p.is_length() {
                rng.random_range(-1.0..1.0)
            } else {
                rng.random_range(-0.2f64..0.2).to_radians()
            }
        })
        .collect();
    apply_delta(&mut truth, &set, &d).unwrap();
    let noise = Normal::new(0.0, 0.01).unwrap();
    let mut fk = ForwardKinematics::new();
    let ms = (0..50)
        .map(|_| {
            let q: [f64; 6] =
                core::array::from_fn(|_| rng.random_range(-170f64..170.0).to_radians());
            let p = fk.compute(&truth, &q)
                + Vector3::new(
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                );
            Measurement::new(q, p)
        })
        .collect();
    (nominal, ms)
}

fn solve<T: Real, const P: usize>(
    nominal: &Robot<T, 6, kinecal::Inline<0>>,
    set: &ParamSet<P>,
    data: &[Measurement<T, 6>],
) -> T {
    let mut lm = FixedLevenberg::<T, 6, kinecal::Inline<0>, P>::fixed(
        nominal.clone(),
        set.clone(),
        LmConfig::default(),
    )
    .unwrap();
    lm.run(data).unwrap().cost
}

fn bench(c: &mut Criterion) {
    let (nominal, ms) = data();
    let nominal32 = nominal.cast::<f32>().unwrap();
    let ms32: Vec<Measurement<f32, 6>> = ms
        .iter()
        .map(|m| Measurement::new(m.q.map(|v| v as f32), m.point.cast()))
        .collect();
    let mdh = ParamSet::<24>::mdh(6).unwrap();
    let full = ParamSet::<27>::full(6, false).unwrap();
    c.bench_function("lm_solve_24_f64_50poses", |b| {
        b.iter(|| black_box(solve(&nominal, &mdh, &ms)))
    });
    c.bench_function("lm_solve_full_f64_50poses", |b| {
        b.iter(|| black_box(solve(&nominal, &full, &ms)))
    });
    c.bench_function("lm_solve_24_f32_50poses", |b| {
        b.iter(|| black_box(solve(&nominal32, &mdh, &ms32)))
    });
    c.bench_function("lm_solve_full_f32_50poses", |b| {
        b.iter(|| black_box(solve(&nominal32, &full, &ms32)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
