//! The BPNN-PSO paper's simulation on built-in data: the application function under `kinecal
//! demo` (which calls [`demo`], draws the figures and writes the calibration report).
//!
//! Gao et al. 2018 §4 with our stand-in for their ER20-C10 tables: a "factory"
//! identification by PSO trains the BP network; later the robot's errors drift a little and a
//! follow-up identification compares PSO, BPNN-PSO, LM and PSO+LM on 50 identification and
//! 50 validation poses with 10 µm tracker noise.

use crate::calibration::pso_search::{bpnn_pso_mdh, pso_mdh, train_bpnn};
use crate::calibration::{fit_lm, pose_errors, ErrorStats, Fit};
use crate::reports::demo::{DemoErrors, DemoReport, Drift, MethodRow};
use crate::simulation::er20_c10;
use crate::HostRobot;
use crate::{HostValues, Tell};
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::lm::LmConfig;
use kinecal::model::param::{apply_delta, ParamSet};
use kinecal::{ForwardKinematics, Measurement, Param};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Instant;

/// The demo's settings (`kinecal demo`'s options without the output folder).
pub struct Options {
    /// Seed of the errors, the poses, the noise and the swarms.
    pub seed: u64,
    /// Iteration limit of the swarms.
    pub max_iterations: u32,
    /// Drift of alpha/theta (degrees, uniform ±) and of a/d (mm) between the factory and the
    /// follow-up identification.
    pub drift_deg: f64,
    pub drift_mm: f64,
}

/// What the demo found: the report (`figures` empty) and what its figures and calibration
/// report show.
pub struct Demo {
    pub report: DemoReport,
    /// Best fitness per iteration of PSO and BPNN-PSO.
    pub curves: Vec<(String, Vec<(f64, f64)>)>,
    /// Position errors on the validation poses before and after each method.
    pub errors: Vec<(String, Vec<f64>)>,
    pub nominal: HostRobot<6>,
    /// The model BPNN-PSO identified, the paper's method.
    pub model: HostRobot<6>,
    pub estimated: Vec<Param>,
    pub ident: Vec<Measurement<f64, 6>>,
    pub valid: Vec<Measurement<f64, 6>>,
    /// The tracker noise, mm.
    pub sigma: f64,
}

/// MDH errors: alpha/theta uniform within ±`angle_deg`, a/d within ±`length_mm`.
fn mdh_errors(rng: &mut Xoshiro256PlusPlus, angle_deg: f64, length_mm: f64) -> Vec<f64> {
    let set = ParamSet::<24>::mdh(6).expect("24 parameters");
    set.as_slice()
        .iter()
        .map(|p| {
            if p.is_length() {
                rng.random_range(-length_mm..length_mm)
            } else {
                rng.random_range(-angle_deg..angle_deg).to_radians()
            }
        })
        .collect()
}

fn measure(
    robot: &HostRobot<6>,
    n: usize,
    sigma: f64,
    rng: &mut Xoshiro256PlusPlus,
) -> Vec<Measurement<f64, 6>> {
    let noise = Normal::new(0.0, sigma).expect("sigma");
    let mut fk = ForwardKinematics::new();
    (0..n)
        .map(|_| {
            let q: [f64; 6] = core::array::from_fn(|j| {
                rng.random_range(robot.joints()[j].lower..robot.joints()[j].upper)
            });
            let p = fk.compute(robot, &q);
            Measurement {
                q,
                point: p + Vector3::new(noise.sample(rng), noise.sample(rng), noise.sample(rng)),
                ..Default::default()
            }
        })
        .collect()
}

/// Runs the simulation and the four identifications; `tell` hears the stage.
pub fn demo(options: &Options, tell: &mut dyn Tell) -> anyhow::Result<Demo> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(options.seed);
    let nominal = er20_c10();
    let set = ParamSet::<24>::mdh(6).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let sigma = 0.010;

    // The robot as it left the factory, and its first ("factory") identification by PSO.
    let mut factory = nominal.clone();
    apply_delta(&mut factory, &set, &mdh_errors(&mut rng, 0.2, 1.0))
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let factory_data = measure(&factory, 50, sigma, &mut rng);
    tell.line("factory identification (PSO) trains the BP network…");
    let factory_run = pso_mdh(
        &nominal,
        &factory_data,
        options.seed ^ 0xfac7,
        options.max_iterations,
        None,
    )?;
    let net = train_bpnn(&factory_run, options.seed)?;

    // Months later: the errors drifted a little; a follow-up identification of the same robot.
    let mut truth = factory.clone();
    apply_delta(
        &mut truth,
        &set,
        &mdh_errors(&mut rng, options.drift_deg, options.drift_mm),
    )
    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let ident = measure(&truth, 50, sigma, &mut rng);
    let valid = measure(&truth, 50, sigma, &mut rng);
    let swarm_seed = options.seed ^ 0x5eed;

    let mut rows = Vec::new();
    let mut curves = Vec::new();
    let mut errors = vec![(
        "before identification".to_string(),
        pose_errors(&nominal, &valid),
    )];
    let before = ErrorStats::of(&pose_errors(&nominal, &valid)).expect("50 poses");
    let before_ident = ErrorStats::of(&pose_errors(&nominal, &ident)).expect("50 poses");

    /// What only some methods report.
    #[derive(Default)]
    struct Extra {
        iterations_to_final: Option<usize>,
        iterations_to_pso_final: Option<Option<usize>>,
    }
    let mut record = |name: &str, fit: Fit<6, HostValues>, seconds: f64, extra: Extra| -> f64 {
        let mut fitness = PositionFitness::new(&fit.robot, &set, &ident).expect("valid data");
        let best = fitness.of_robot(&fit.robot);
        let after = ErrorStats::of(&pose_errors(&fit.robot, &valid)).expect("50 poses");
        let after_ident = ErrorStats::of(&pose_errors(&fit.robot, &ident)).expect("50 poses");
        if !fit.history.is_empty() {
            curves.push((
                name.to_string(),
                fit.history
                    .iter()
                    .enumerate()
                    .map(|(i, f)| (i as f64, *f))
                    .collect::<Vec<_>>(),
            ));
        }
        errors.push((format!("after {name}"), pose_errors(&fit.robot, &valid)));
        rows.push(MethodRow {
            method: name.to_string(),
            iterations: fit.iterations,
            evaluations: fit.evaluations,
            best_fitness: best,
            seconds,
            before: DemoErrors::of(&before_ident, &before),
            after: DemoErrors::of(&after_ident, &after),
            iterations_to_final: extra.iterations_to_final,
            iterations_to_pso_final: extra.iterations_to_pso_final,
        });
        best
    };

    let t = Instant::now();
    let pso = pso_mdh(&nominal, &ident, swarm_seed, options.max_iterations, None)?;
    let pso_seconds = t.elapsed().as_secs_f64();
    let pso_final = pso.fit.history.last().copied().unwrap_or(f64::INFINITY);
    let pso_reach = pso
        .fit
        .history
        .iter()
        .position(|f| *f <= pso_final)
        .unwrap_or(0);
    record(
        "pso",
        pso.fit,
        pso_seconds,
        Extra {
            iterations_to_final: Some(pso_reach),
            ..Extra::default()
        },
    );

    let t = Instant::now();
    let hybrid = bpnn_pso_mdh(&net, &nominal, &ident, swarm_seed, options.max_iterations)?;
    let hybrid_seconds = t.elapsed().as_secs_f64();
    let hybrid_reach = hybrid.fit.history.iter().position(|f| *f <= pso_final);
    let hybrid_robot = hybrid.fit.robot.clone();
    record(
        "bpnn-pso",
        hybrid.fit,
        hybrid_seconds,
        Extra {
            iterations_to_pso_final: Some(hybrid_reach),
            ..Extra::default()
        },
    );

    let t = Instant::now();
    let lm = fit_lm(&nominal, set.as_slice(), &ident, LmConfig::default())?;
    record("lm", lm, t.elapsed().as_secs_f64(), Extra::default());

    let t = Instant::now();
    let first = pso_mdh(&nominal, &ident, swarm_seed, options.max_iterations, None)?;
    let mut polished = fit_lm(
        &first.fit.robot,
        set.as_slice(),
        &ident,
        LmConfig::default(),
    )?;
    polished.iterations += first.fit.iterations;
    polished.evaluations += first.fit.evaluations;
    let mut h = first.fit.history.clone();
    h.extend(polished.history.iter().copied());
    polished.history = h;
    record(
        "pso+lm",
        polished,
        t.elapsed().as_secs_f64(),
        Extra::default(),
    );

    let curves: Vec<(String, Vec<(f64, f64)>)> = curves
        .into_iter()
        .filter(|c| c.0 == "pso" || c.0 == "bpnn-pso")
        .collect();
    let ratio = hybrid_reach.map(|h| h as f64 / pso_reach.max(1) as f64);
    let report = DemoReport {
        robot: "ER20-C10 stand-in".to_string(),
        noise_mm: sigma,
        n_identification: ident.len(),
        n_validation: valid.len(),
        factory_pso_iterations: factory_run.fit.iterations,
        drift: Drift {
            angle_deg: options.drift_deg,
            length_mm: options.drift_mm,
            validation_rms_mm: ErrorStats::of(&pose_errors(&factory, &valid)).map(|s| s.rms_mm),
        },
        methods: rows,
        bpnn_pso_iteration_ratio: ratio,
        figures: Vec::new(),
    };
    Ok(Demo {
        report,
        curves,
        errors,
        nominal,
        model: hybrid_robot,
        estimated: set.as_slice().to_vec(),
        ident,
        valid,
        sigma,
    })
}
