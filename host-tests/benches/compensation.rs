//! Cost of one compensation call (the servo-cycle budget): a 6-D pose target and a 3-D point
//! target on an identified-looking ER20-class model with geometry errors and effects
//! (compliance, cyclic, scale, table), seeds 0.3° off, in f64 and f32. Also the warm-started
//! streaming form, the cost per cycle along a trajectory.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use kinecal::compensate::{compensate, Config, Target, Tracker};
use kinecal::model::effects::EffectKind;
use kinecal::model::param::{apply_delta, ParamSet};
use kinecal::{ForwardKinematics, Frame, Joint, Real, Robot};
use nalgebra::Vector3;
use std::hint::black_box;

type V = kinecal::Inline<64>;

fn model() -> Robot<f64, 6, V> {
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
        (-90.0, 140.0, 0.0, 760.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 125.0),
    ];
    let base = Frame::from_xyz_rpy([2100.0, -850.0, -320.0], [0.005, -0.003, 0.6]);
    let mut r = Robot::new(
        base,
        rows.map(|(a, b, c, d)| Joint::mdh_deg(a, b, c, d)),
        Vector3::new(12.0, -7.0, 95.0),
    )
    .unwrap();
    // Deterministic "identified" geometry errors (±0.5 mm, ±0.05°).
    let set = ParamSet::<64>::full(6, true).unwrap();
    let delta: Vec<f64> = (0..set.len())
        .map(|k| {
            let u = ((k * 7919 % 101) as f64 / 50.0) - 1.0;
            if set.as_slice()[k].is_length() {
                0.5 * u
            } else {
                0.05f64.to_radians() * u
            }
        })
        .collect();
    apply_delta(&mut r, &set, &delta).unwrap();
    let e = r.effects_mut();
    e.push(EffectKind::Compliance, 1, 6, 0, 0.0, 0.0, &[3e-4])
        .unwrap();
    e.push(EffectKind::Cyclic, 0, 6, 1, 0.0, 0.0, &[1.5e-4, -8e-5])
        .unwrap();
    e.push(EffectKind::Scale, 2, 6, 0, 0.0, 0.0, &[4e-4])
        .unwrap();
    let knots: Vec<f64> = (0..37).map(|k| 1e-4 * ((k as f64) * 0.7).sin()).collect();
    e.push(
        EffectKind::Table,
        3,
        6,
        0,
        -std::f64::consts::PI,
        10f64.to_radians(),
        &knots,
    )
    .unwrap();
    r
}

/// Ten configurations, targets from the model, seeds 0.3° off.
fn cases<T: Real>(r: &Robot<T, 6, V>, six: bool) -> Vec<(Target<T>, [T; 6])> {
    let mut fk = ForwardKinematics::new();
    (0..10)
        .map(|i| {
            let x = i as f64;
            let q: [f64; 6] = [
                0.3 * x - 1.2,
                0.1 * x - 0.3,
                0.4 - 0.08 * x,
                1.0 - 0.2 * x,
                0.6 + 0.05 * x,
                0.5 * x - 2.0,
            ];
            let qt = q.map(T::of);
            fk.compute(r, &qt);
            let f = fk.flange_pose();
            let target = if six {
                Target::Pose(f)
            } else {
                Target::Point(f.o)
            };
            let seed: [T; 6] = core::array::from_fn(|j| {
                T::of(q[j] + (0.3f64).to_radians() * if (i + j) % 2 == 0 { 1.0 } else { -1.0 })
            });
            (target, seed)
        })
        .collect()
}

/// 2,000 cycles of a slow joint-space sweep (0.1 mrad per cycle), targets from the model, the
/// nominal joints 0.3° off the answer.
fn trajectory<T: Real>(r: &Robot<T, 6, V>, six: bool) -> Vec<(Target<T>, [T; 6])> {
    let mut fk = ForwardKinematics::new();
    (0..2000)
        .map(|k| {
            let t = k as f64 * 1e-4;
            let q: [f64; 6] = [t - 1.0, 0.2 + 0.1 * t, 0.1 - 0.2 * t, 0.5 + t, 0.8, t];
            fk.compute(r, &q.map(T::of));
            let f = fk.flange_pose();
            let target = if six {
                Target::Pose(f)
            } else {
                Target::Point(f.o)
            };
            (target, q.map(|v| T::of(v + 0.3f64.to_radians())))
        })
        .collect()
}

fn bench_scalar<T: Real>(c: &mut Criterion, name: &str) {
    let r: Robot<T, 6, V> = model().cast().unwrap();
    let cfg = Config::<T>::default();
    let mut g = c.benchmark_group(format!("compensate_{name}"));
    for six in [true, false] {
        let cases = cases(&r, six);
        let label = if six { "pose_6d" } else { "point_3d" };
        g.bench_function(BenchmarkId::new("cold_0.3deg", label), |b| {
            let mut i = 0;
            b.iter(|| {
                let (t, s) = &cases[i % cases.len()];
                i += 1;
                black_box(compensate(black_box(&r), t, s, &cfg)).ok()
            })
        });
        // Streaming: a slow trajectory, one cycle per iteration (warm start from the previous
        // correction), the nominal joints 0.3° off the answer.
        g.bench_function(BenchmarkId::new("tracker_cycle", label), |b| {
            let path = trajectory(&r, six);
            let mut tracker = Tracker::new(cfg);
            let mut k = 0;
            b.iter(|| {
                let (t, nominal) = &path[k % path.len()];
                k += 1;
                black_box(tracker.next(&r, t, nominal)).ok()
            })
        });
    }
    g.finish();
}

fn benches(c: &mut Criterion) {
    bench_scalar::<f64>(c, "f64");
    bench_scalar::<f32>(c, "f32");
}

criterion_group!(compensation, benches);
criterion_main!(compensation);
