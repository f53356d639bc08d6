//! PSO, its objective and BPNN-PSO on simulated robots built with the library itself.

use crate::pso_sim::*;
use kinecal::identify::bpnn::{Bpnn, BpnnConfig};
use kinecal::identify::bpnn_pso::{self, BpnnPsoError, MdhSeedNet, DEFAULT_EPOCHS};
use kinecal::identify::fitness::{FitnessError, JointTrig, Objective, PositionFitness};
use kinecal::identify::pso::{Pso, PsoConfig, PsoError, PsoStop};
use kinecal::model::param::{apply_delta, Param, ParamSet};
use kinecal::{EffectKind, ForwardKinematics, Frame, Measurement, Robot};
use nalgebra::Vector3;

type Swarm = Pso<f64, 200, 24>;

fn sum_sq_reference(robot: &Robot<f64, 6>, data: &[Measurement<f64, 6>]) -> f64 {
    let mut fk = ForwardKinematics::new();
    data.iter()
        .map(|m| (m.point - fk.compute(robot, &m.q)).norm_squared())
        .sum()
}

#[test]
fn fitness_is_the_sum_of_squared_errors_on_both_paths() {
    let nominal = er20_nominal();
    let truth = with_delta(&nominal, &er20_errors());
    let data = poses(&truth, 50, 0.01, 1);
    let params = mdh24();
    let mut cache: Vec<JointTrig<f64, 6>> = vec![[(0.0, 0.0); 6]; 50];
    let mut plain = PositionFitness::new(&nominal, &params, &data).unwrap();
    let mut cached = PositionFitness::with_cache(&nominal, &params, &data, &mut cache).unwrap();
    assert_eq!(plain.dimension(), 24);
    for x in [[0.0; 24], er20_errors(), er20_drift()] {
        let want = sum_sq_reference(&with_delta(&nominal, &x), &data);
        assert!((plain.fitness(&x) - want).abs() <= 1e-9 * want.max(1.0));
        assert!((cached.fitness(&x) - want).abs() <= 1e-9 * want.max(1.0));
    }
    // At the truth only the noise is left: 150 residuals of σ = 10 µm → about 0.015 mm².
    let at_truth = plain.fitness(&er20_errors());
    assert!(at_truth > 0.008 && at_truth < 0.025, "{at_truth}");
    // Wrong length or non-finite candidates are infeasible, not a panic.
    assert_eq!(plain.fitness(&[0.0; 23]), f64::INFINITY);
    assert_eq!(cached.fitness(&[f64::NAN; 24]), f64::INFINITY);
}

#[test]
fn cached_path_matches_forward_kinematics_with_tilt_base_and_tool() {
    // A 6R robot with tilted rows, a base pose and a lateral tool offset.
    let mut r = er20_nominal();
    let mut j = *r.joint(2).unwrap();
    j.beta = 0.3f64.to_radians();
    r.set_joint(2, j).unwrap();
    let mut j = *r.joint(4).unwrap();
    j.beta = -0.2f64.to_radians();
    r.set_joint(4, j).unwrap();
    r.set_base(Frame::from_xyz_rpy(
        [1500.0, -300.0, 200.0],
        [0.01, -0.02, 1.2],
    ))
    .unwrap();
    r.set_tool(Vector3::new(12.0, -7.0, 95.0)).unwrap();
    let data = poses(&r, 40, 0.05, 9);
    let params: ParamSet<40> = ParamSet::full(6, true).unwrap();
    let mut cache = vec![[(0.0, 0.0); 6]; 40];
    let mut plain = PositionFitness::new(&r, &params, &data).unwrap();
    let mut cached = PositionFitness::with_cache(&r, &params, &data, &mut cache).unwrap();
    let x: Vec<f64> = (0..params.len())
        .map(|k| 1e-3 * ((k as f64) * 1.7).sin())
        .collect();
    let (a, b) = (plain.fitness(&x), cached.fitness(&x));
    assert!((a - b).abs() <= 1e-9 * a, "{a} vs {b}");
    let mut moved = r.clone();
    apply_delta(&mut moved, &params, &x).unwrap();
    assert!((a - plain.of_robot(&moved)).abs() <= 1e-9 * a);
}

#[test]
fn effects_take_the_general_path() {
    let mut r: Robot<f64, 6, kinecal::Inline<4>> = er20_nominal()
        .with_capacity::<kinecal::Inline<4>>()
        .unwrap();
    r.effects_mut()
        .push(EffectKind::Scale, 1, 6, 1, 0.0, 0.0, &[1e-3])
        .unwrap();
    let data = {
        let mut fk = ForwardKinematics::new();
        let plain = poses(&er20_nominal(), 30, 0.0, 4);
        plain
            .iter()
            .map(|m| Measurement {
                q: m.q,
                point: fk.compute(&r, &m.q),
                ..Default::default()
            })
            .collect::<Vec<_>>()
    };
    let params = mdh24();
    let mut cache = vec![[(0.0, 0.0); 6]; 30];
    let mut cached = PositionFitness::with_cache(&r, &params, &data, &mut cache).unwrap();
    // The model reproduces its own data exactly only if the joint correction is applied.
    assert!(cached.fitness(&[0.0; 24]) < 1e-12);
}

#[test]
fn fitness_construction_errors() {
    let nominal = er20_nominal();
    let params = mdh24();
    let data = poses(&nominal, 5, 0.0, 1);
    assert_eq!(
        PositionFitness::new(&nominal, &params, &[]).unwrap_err(),
        FitnessError::NoMeasurements
    );
    let mut bad = data.clone();
    bad[3].point.y = f64::NAN;
    assert_eq!(
        PositionFitness::new(&nominal, &params, &bad).unwrap_err(),
        FitnessError::NonFiniteMeasurement
    );
    let mut seven: ParamSet<25> = ParamSet::mdh(6).unwrap();
    seven.push(Param::D(6)).unwrap();
    assert!(matches!(
        PositionFitness::new(&nominal, &seven, &data),
        Err(FitnessError::Params(_))
    ));
    let mut small = vec![[(0.0, 0.0); 6]; 4];
    assert_eq!(
        PositionFitness::with_cache(&nominal, &params, &data, &mut small).unwrap_err(),
        FitnessError::CacheTooSmall
    );
}

#[test]
fn calibration_box_and_config_errors() {
    let params = mdh24();
    let cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();
    assert_eq!((cfg.inertia, cfg.cognitive, cfg.social), (0.9, 0.5, 1.25));
    for (k, p) in params.as_slice().iter().enumerate() {
        let want = if p.is_length() {
            2.0
        } else {
            0.5f64.to_radians()
        };
        assert_eq!((cfg.lower[k], cfg.upper[k]), (-want, want), "{p:?}");
    }
    assert_eq!(
        PsoConfig::<f64, 23>::calibration(params.as_slice()).unwrap_err(),
        PsoError::Dimension
    );
    assert_eq!(
        PsoConfig::<f64, 2>::new([0.0, 1.0], [1.0, 1.0]).unwrap_err(),
        PsoError::Bounds
    );
    assert_eq!(
        PsoConfig::<f64, 1>::new([f64::NAN], [1.0]).unwrap_err(),
        PsoError::Bounds
    );
    let mut c = PsoConfig::<f64, 1>::new([0.0], [1.0]).unwrap();
    c.inertia = -0.1;
    assert_eq!(
        Pso::<f64, 4, 1>::new(c, 0).unwrap_err(),
        PsoError::Coefficient
    );
    c.inertia = 0.9;
    c.max_velocity = 0.0;
    assert_eq!(
        Pso::<f64, 4, 1>::new(c, 0).unwrap_err(),
        PsoError::Coefficient
    );
    c.max_velocity = 0.1;
    assert_eq!(Pso::<f64, 0, 1>::new(c, 0).unwrap_err(), PsoError::Empty);
}

/// Sum of squares around a point, in any dimension.
struct Bowl<const D: usize> {
    centre: [f64; D],
}

impl<const D: usize> Objective<f64> for Bowl<D> {
    fn dimension(&self) -> usize {
        D
    }
    fn fitness(&mut self, x: &[f64]) -> f64 {
        x.iter()
            .zip(self.centre.iter())
            .map(|(a, b)| (a - b) * (a - b))
            .sum()
    }
}

#[test]
fn bounds_and_velocity_limits_hold_with_the_optimum_outside_the_box() {
    let cfg = PsoConfig::<f64, 3>::new([-1.0, -2.0, 0.0], [1.0, 2.0, 0.5]).unwrap();
    let mut pso = Pso::<f64, 30, 3>::new(cfg, 5).unwrap();
    let mut f = Bowl {
        centre: [5.0, -9.0, 0.25],
    };
    let vmax = *pso.velocity_limits();
    assert_eq!(vmax, [0.2, 0.4, 0.05]);
    for _ in 0..100 {
        pso.step(&mut f, 17).unwrap();
        for (x, v) in pso.positions().iter().zip(pso.velocities()) {
            for d in 0..3 {
                assert!(x[d] >= cfg.lower[d] && x[d] <= cfg.upper[d]);
                assert!(v[d].abs() <= vmax[d]);
            }
        }
    }
    // The best point is the box's nearest corner to the centre.
    let b = pso.best_position();
    assert!(
        (b[0] - 1.0).abs() < 1e-9 && (b[1] + 2.0).abs() < 1e-9 && (b[2] - 0.25).abs() < 1e-4,
        "{b:?}"
    );
}

#[test]
fn termination_by_target_iterations_and_stagnation() {
    let mut cfg = PsoConfig::<f64, 2>::new([-1.0; 2], [1.0; 2]).unwrap();
    cfg.stagnation_window = 0;
    cfg.max_iterations = 7;
    let mut pso = Pso::<f64, 10, 2>::new(cfg, 1).unwrap();
    let p = pso
        .run(&mut Bowl {
            centre: [0.3, -0.2],
        })
        .unwrap();
    assert_eq!(
        (p.iteration, p.evaluations, p.stopped),
        (7, 80, Some(PsoStop::MaxIterations))
    );
    assert_eq!(pso.history().len(), 8);
    assert!(pso.history().windows(2).all(|w| w[1] <= w[0]));

    cfg.max_iterations = 1000;
    cfg.target_fitness = 1e-6;
    let mut pso = Pso::<f64, 10, 2>::new(cfg, 1).unwrap();
    let p = pso
        .run(&mut Bowl {
            centre: [0.3, -0.2],
        })
        .unwrap();
    assert_eq!(p.stopped, Some(PsoStop::Target));
    assert!(p.best_fitness <= 1e-6 && p.iteration < 1000);
    assert!(pso.history()[p.iteration as usize - 1] > 1e-6);

    // A flat objective never improves after the first swarm: stops after exactly the window.
    struct Flat;
    impl Objective<f64> for Flat {
        fn dimension(&self) -> usize {
            2
        }
        fn fitness(&mut self, _: &[f64]) -> f64 {
            1.0
        }
    }
    cfg.target_fitness = 0.0;
    cfg.stagnation_window = 12;
    let mut pso = Pso::<f64, 10, 2>::new(cfg, 1).unwrap();
    let p = pso.run(&mut Flat).unwrap();
    assert_eq!((p.iteration, p.stopped), (12, Some(PsoStop::Stagnated)));
    // Finished: further steps do nothing.
    assert_eq!(pso.step(&mut Flat, 100).unwrap(), p);
    // Wrong dimension is refused.
    assert_eq!(
        pso.step(&mut Bowl { centre: [0.0; 3] }, 1).unwrap_err(),
        PsoError::Dimension
    );
}

#[test]
fn set_start_only_before_the_first_evaluation() {
    let cfg = PsoConfig::<f64, 2>::new([-1.0; 2], [1.0; 2]).unwrap();
    let mut pso = Pso::<f64, 4, 2>::new(cfg, 3).unwrap();
    pso.set_start(1, &[5.0, -0.5], &[9.0, 0.0]).unwrap();
    assert_eq!(pso.positions()[1], [1.0, -0.5]); // clamped into the box
    assert_eq!(pso.velocities()[1], [0.2, 0.0]); // clamped to the velocity limit
    assert_ne!(pso.initial_positions()[1], [1.0, -0.5]); // the draw is kept
    assert_eq!(
        pso.set_start(4, &[0.0; 2], &[0.0; 2]).unwrap_err(),
        PsoError::Start
    );
    assert_eq!(
        pso.set_start(0, &[f64::NAN, 0.0], &[0.0; 2]).unwrap_err(),
        PsoError::Start
    );
    pso.step(&mut Bowl { centre: [0.0; 2] }, 1).unwrap();
    assert_eq!(
        pso.set_start(2, &[0.0; 2], &[0.0; 2]).unwrap_err(),
        PsoError::Start
    );
    // A restart draws a fresh swarm in place, identical to a new one.
    pso.restart(cfg, 3).unwrap();
    let fresh = Pso::<f64, 4, 2>::new(cfg, 3).unwrap();
    assert_eq!(pso.positions(), fresh.positions());
    assert_eq!(pso.progress(), fresh.progress());
}

#[test]
fn pso_identifies_the_er20_and_converges() {
    let nominal = er20_nominal();
    let truth = with_delta(&nominal, &er20_errors());
    let data = poses(&truth, 50, 0.01, 1);
    let params = mdh24();
    let mut cache = vec![[(0.0, 0.0); 6]; 50];
    let mut f = PositionFitness::with_cache(&nominal, &params, &data, &mut cache).unwrap();
    let nominal_fitness = f.fitness(&[0.0; 24]);
    let truth_fitness = f.fitness(&er20_errors());
    let mut cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();
    cfg.max_iterations = 600;
    let mut pso = Swarm::new(cfg, 7).unwrap();
    let p = pso.run(&mut f).unwrap();
    let h = pso.history();
    assert_eq!(h.len(), p.iteration as usize + 1);
    assert!(
        h.windows(2).all(|w| w[1] <= w[0]),
        "the global best never gets worse"
    );
    assert!(
        h[0] > 100.0 * h[100] && h[100] > h[600],
        "{} {} {}",
        h[0],
        h[100],
        h[600]
    );
    // From 1675 mm² at the nominal model to within a few times the noise floor.
    assert!(nominal_fitness > 1000.0);
    assert!(
        p.best_fitness < 10.0 * truth_fitness,
        "{} vs {}",
        p.best_fitness,
        truth_fitness
    );
    // The identified model predicts held-out poses far better than the nominal one.
    let valid = poses(&truth, 50, 0.0, 99);
    let found = f.robot(pso.best_position()).unwrap();
    let rms = |r: &Robot<f64, 6>| (sum_sq_reference(r, &valid) / 50.0).sqrt();
    assert!(
        rms(&found) < 0.05 * rms(&nominal),
        "{} vs {}",
        rms(&found),
        rms(&nominal)
    );
}

#[test]
fn pso_recovers_the_truth_in_an_easy_low_dimensional_case() {
    // Four well-determined parameters, the rest exact; noise-free measurements.
    let nominal = er20_nominal();
    let mut set = ParamSet::<4>::new();
    for p in [Param::D(0), Param::A(1), Param::Theta(1), Param::A(2)] {
        set.push(p).unwrap();
    }
    let truth_delta = [0.8, -0.6, 0.15f64.to_radians(), 0.9];
    let mut truth = nominal.clone();
    apply_delta(&mut truth, &set, &truth_delta).unwrap();
    let data = poses(&truth, 30, 0.0, 3);
    let mut f = PositionFitness::new(&nominal, &set, &data).unwrap();
    let mut cfg = PsoConfig::<f64, 4>::calibration(set.as_slice()).unwrap();
    cfg.max_iterations = 400;
    cfg.stagnation_window = 0;
    let mut pso = Pso::<f64, 40, 4>::new(cfg, 11).unwrap();
    pso.run(&mut f).unwrap();
    let b = pso.best_position();
    assert!((b[0] - truth_delta[0]).abs() < 1e-3, "{b:?}");
    assert!((b[1] - truth_delta[1]).abs() < 1e-3, "{b:?}");
    assert!((b[2] - truth_delta[2]).abs() < 1e-6, "{b:?}");
    assert!((b[3] - truth_delta[3]).abs() < 1e-3, "{b:?}");
}

#[test]
fn same_seed_same_result_whatever_the_slicing() {
    let nominal = er20_nominal();
    let truth = with_delta(&nominal, &er20_errors());
    let data = poses(&truth, 50, 0.01, 1);
    let params = mdh24();
    let mut f = PositionFitness::new(&nominal, &params, &data).unwrap();
    let mut cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();
    cfg.max_iterations = 25;
    let run =
        |f: &mut PositionFitness<'_, f64, 6, kinecal::Inline<0>, 24>, seed: u64, budget: usize| {
            let mut pso = Box::new(Swarm::new(cfg, seed).unwrap());
            while pso.step(f, budget).unwrap().stopped.is_none() {}
            pso
        };
    let a = run(&mut f, 42, usize::MAX);
    for budget in [1, 7, 199, 200, 201] {
        let b = run(&mut f, 42, budget);
        assert_eq!(a.progress(), b.progress());
        assert_eq!(
            a.best_position().map(f64::to_bits),
            b.best_position().map(f64::to_bits)
        );
        assert_eq!(
            a.history().iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            b.history().iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert!(a
            .positions()
            .iter()
            .flatten()
            .zip(b.positions().iter().flatten())
            .all(|(x, y)| x.to_bits() == y.to_bits()));
    }
    let c = run(&mut f, 43, usize::MAX);
    assert_ne!(a.best_position(), c.best_position());
    // Budget 0 does nothing.
    let mut d = Swarm::new(cfg, 42).unwrap();
    assert_eq!(d.step(&mut f, 0).unwrap().evaluations, 0);
}

#[test]
fn pso_runs_in_f32() {
    let nominal = er20_nominal();
    let truth = with_delta(&nominal, &er20_errors());
    let data64 = poses(&truth, 50, 0.01, 1);
    let nominal32: Robot<f32, 6> = nominal.cast().unwrap();
    let data: Vec<Measurement<f32, 6>> = data64
        .iter()
        .map(|m| Measurement::new(m.q.map(|v| v as f32), m.point.map(|v| v as f32)))
        .collect();
    let params = mdh24();
    let mut cache = vec![[(0.0f32, 0.0f32); 6]; 50];
    let mut f = PositionFitness::with_cache(&nominal32, &params, &data, &mut cache).unwrap();
    let mut cfg = PsoConfig::<f32, 24>::calibration(params.as_slice()).unwrap();
    cfg.max_iterations = 300;
    let mut pso = Pso::<f32, 200, 24>::new(cfg, 7).unwrap();
    let p = pso.run(&mut f).unwrap();
    let h = pso.history();
    assert!(h.windows(2).all(|w| w[1] <= w[0]));
    assert!(
        p.best_fitness < 0.01 * h[0],
        "{} from {}",
        p.best_fitness,
        h[0]
    );
}

/// The paper's claim (the paper's claim): after a factory identification by PSO trains the
/// network, BPNN-PSO reaches plain PSO's final fitness in at most a quarter of PSO's iterations
/// in a follow-up identification of the same robot after a small drift.
///
/// Drift: alpha/theta within ±0.002°, a/d within ±0.01 mm (a tenth of [`er20_drift`], 1 % of the
/// factory errors; it moves the tool by ≈ 0.07 mm RMS). Single runs are noisy (when plain PSO
/// happens to converge right to the noise floor, BPNN-PSO needs up to ≈ 0.45 of its iterations),
/// so the claim is checked over 8 swarm seeds fixed in advance: the total and the median ratio.
/// The denominator is the iteration at which PSO first reached its final fitness (not its later
/// stop). `kinecal::identify::bpnn_pso`'s module docs give the ratios for larger drifts, where it fails.
#[test]
fn bpnn_pso_reaches_pso_final_fitness_in_a_quarter_of_the_iterations() {
    let nominal = er20_nominal();
    let params = mdh24();
    let cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();

    // Factory identification.
    let factory_truth = with_delta(&nominal, &er20_errors());
    let factory_data = poses(&factory_truth, 50, 0.01, 100);
    let mut cache = vec![[(0.0, 0.0); 6]; 50];
    let mut f = PositionFitness::with_cache(&nominal, &params, &factory_data, &mut cache).unwrap();
    let mut factory = Box::new(Swarm::new(cfg, 0).unwrap());
    let mut net: MdhSeedNet<f64> = Bpnn::new(BpnnConfig::default(), 0).unwrap();
    assert_eq!(
        bpnn_pso::train(&mut net, &factory, 1).unwrap_err(),
        BpnnPsoError::NotFinished
    );
    factory.run(&mut f).unwrap();
    net.fit_ranges(factory.initial_positions(), factory.personal_bests())
        .unwrap();
    let before = net
        .loss(factory.initial_positions(), factory.personal_bests())
        .unwrap();
    let loss = bpnn_pso::train(&mut net, &factory, DEFAULT_EPOCHS).unwrap();
    assert!(
        loss < 0.25 * before,
        "training lowers the loss: {before} → {loss}"
    );

    // Follow-up after a small drift.
    let mut drifted = er20_errors();
    for (e, d) in drifted.iter_mut().zip(er20_drift()) {
        *e += 0.1 * d;
    }
    let truth = with_delta(&nominal, &drifted);
    let data = poses(&truth, 50, 0.01, 200);
    let mut cache = vec![[(0.0, 0.0); 6]; 50];
    let mut f = PositionFitness::with_cache(&nominal, &params, &data, &mut cache).unwrap();
    let (mut total_pso, mut total_hybrid) = (0u32, 0u32);
    let mut ratios = Vec::new();
    for seed in 1..=8u64 {
        let mut pso = Box::new(Swarm::new(cfg, seed).unwrap());
        let p = pso.run(&mut f).unwrap();
        let pso_iterations = pso.iterations_to_reach(p.best_fitness).unwrap();

        let mut with_target = cfg;
        with_target.target_fitness = p.best_fitness;
        let mut hybrid = Box::new(Swarm::new(with_target, seed).unwrap());
        bpnn_pso::seed(&mut hybrid, &net).unwrap();
        let h = hybrid.run(&mut f).unwrap();
        assert_eq!(
            h.stopped,
            Some(PsoStop::Target),
            "seed {seed}: BPNN-PSO never reached {}",
            p.best_fitness
        );
        eprintln!("seed {seed}: PSO {pso_iterations} iterations to {:.5} mm²; BPNN-PSO {} (starts at {:.4})", p.best_fitness, h.iteration, hybrid.history()[0]);
        total_pso += pso_iterations;
        total_hybrid += h.iteration;
        ratios.push(h.iteration as f64 / pso_iterations as f64);
        // Seeding is only possible on a fresh swarm.
        assert!(matches!(
            bpnn_pso::seed(&mut hybrid, &net),
            Err(BpnnPsoError::Swarm(PsoError::Start))
        ));
    }
    ratios.sort_by(f64::total_cmp);
    let median = 0.5 * (ratios[3] + ratios[4]);
    eprintln!("total: PSO {total_pso}, BPNN-PSO {total_hybrid}; median ratio {median:.3}");
    assert!(
        4 * total_hybrid <= total_pso,
        "{total_hybrid} vs {total_pso}"
    );
    assert!(median <= 0.25, "{ratios:?}");
}
