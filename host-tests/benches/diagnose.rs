//! `diagnose`'s stages on the real UR10 series (data/ur10/ur10_random_poses.csv, 2,773 poses,
//! all candidates): the geometric fit, the baseline's fold refits, one round's linearised
//! screen of the whole catalogue, and the whole search.
//!
//!     cargo bench -p kinecal-host --bench diagnose

use criterion::{criterion_group, criterion_main, Criterion};
use kinecal::model::param::{Param, ParamSet};
use kinecal_cli::diagnose::candidates::{catalogue, CandidateKind};
use kinecal_cli::diagnose::cross_validation::{refit_errors, rms, Folds, Linearised};
use kinecal_cli::diagnose::linear::Problem;
use kinecal_cli::diagnose::pose_columns::PoseKinematics;
use kinecal_cli::diagnose::refit::fit;
use kinecal_cli::diagnose::{diagnose, fit_geometry, Config};
use kinecal_cli::formats::measurements;
use kinecal_cli::formats::robot_file::load_robot;
use std::hint::black_box;
use std::path::PathBuf;

fn bench(c: &mut Criterion) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/ur10");
    let (file, nominal) = load_robot::<6>(&dir.join("robot.toml")).unwrap();
    let data = measurements::load::<6>(&dir.join("ur10_random_poses.csv"))
        .unwrap()
        .measurements::<f64>();
    let (base_known, tilt) = (file.base_known(), file.tilt_joints());
    let cfg = Config::default();
    let mut g = c.benchmark_group("diagnose_ur10_2773");
    g.sample_size(10);
    g.bench_function("geometry", |b| {
        b.iter(|| fit_geometry(&nominal, base_known, &tilt, black_box(&data)).unwrap())
    });
    let (geometric, held) = fit_geometry(&nominal, base_known, &tilt, &data).unwrap();
    let mut params: Vec<Param> = ParamSet::<64>::full(6, !base_known)
        .unwrap()
        .as_slice()
        .to_vec();
    params.retain(|p| !held.contains(p));
    let problem = Problem::new(&geometric, &params, cfg.penalty).unwrap();
    let current = fit(&geometric, &problem, &data, cfg.refit_iterations)
        .unwrap()
        .robot;
    let folds = Folds::new(&data, cfg.folds, cfg.seed);
    g.bench_function("baseline_refits", |b| {
        b.iter(|| refit_errors(&current, &problem, &data, &folds, cfg.refit_iterations).unwrap())
    });
    let cands = catalogue(&current, base_known, &data, &cfg.catalogue);
    g.bench_function("screen_round", |b| {
        b.iter(|| {
            let lin = Linearised::new(&current, &problem, &data, &folds);
            let kinematics = PoseKinematics::new(&current, &data);
            cands
                .iter()
                .filter_map(|cand| {
                    let mut robot_c = current.clone();
                    let extra = cand.add_to(&mut robot_c).ok()?;
                    let cols = kinematics.columns(&robot_c, &extra);
                    let table =
                        matches!(cand.kind, CandidateKind::Table { .. }).then_some(cfg.penalty);
                    Some(rms(&lin.screen(&cols, extra.len(), table)))
                })
                .sum::<f64>()
        })
    });
    g.bench_function("whole", |b| {
        b.iter(|| diagnose(&nominal, base_known, &tilt, black_box(&data), &cfg).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
