//! `kinecal demo`: the BPNN-PSO paper's simulation end to end on built-in data.
//!
//! Gao et al. 2018 §4 with our stand-in for their ER20-C10 tables: a "factory"
//! identification by PSO trains the BP network; later the robot's errors drift a little and a
//! follow-up identification compares PSO, BPNN-PSO, LM and PSO+LM on 50 identification and
//! 50 validation poses with 10 µm tracker noise.

use crate::calibration::pso_search::{bpnn_pso_mdh, pso_mdh, train_bpnn};
use crate::calibration::{fit_lm, pose_errors, ErrorStats, Fit};
use crate::output::plots;
use crate::reports::demo::{DemoErrors, DemoReport, Drift, MethodRow};
use crate::simulation::er20_c10;
use crate::VCAP;
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::lm::LmConfig;
use kinecal::model::param::{apply_delta, ParamSet};
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kinecal demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Seed of the errors, the poses, the noise and the swarms.
    #[arg(long, default_value_t = 2018)]
    pub seed: u64,
    /// Where the SVG figures go.
    #[arg(long, default_value = "out/demo")]
    pub out_dir: PathBuf,
    /// Iteration limit of the swarms.
    #[arg(long, default_value_t = 1000)]
    pub max_iterations: u32,
    /// Drift of alpha/theta (degrees, uniform ±) between the factory and the follow-up
    /// identification. BPNN-PSO's head start shrinks as the drift grows (README).
    #[arg(long, default_value_t = 0.002)]
    pub drift_deg: f64,
    /// Drift of a/d (mm, uniform ±) between the two identifications.
    #[arg(long, default_value_t = 0.01)]
    pub drift_mm: f64,
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
    robot: &Robot<f64, 6, VCAP>,
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

/// Runs the simulation: writes the figures and returns the comparison.
pub fn run(args: &Args) -> anyhow::Result<DemoReport> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(args.seed);
    let nominal = er20_c10();
    let set = ParamSet::<24>::mdh(6).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let sigma = 0.010;

    // The robot as it left the factory, and its first ("factory") identification by PSO.
    let mut factory = nominal.clone();
    apply_delta(&mut factory, &set, &mdh_errors(&mut rng, 0.2, 1.0))
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let factory_data = measure(&factory, 50, sigma, &mut rng);
    eprintln!("factory identification (PSO) trains the BP network…");
    let factory_run = pso_mdh(
        &nominal,
        &factory_data,
        args.seed ^ 0xfac7,
        args.max_iterations,
        None,
    )?;
    let net = train_bpnn(&factory_run, args.seed)?;

    // Months later: the errors drifted a little; a follow-up identification of the same robot.
    let mut truth = factory.clone();
    apply_delta(
        &mut truth,
        &set,
        &mdh_errors(&mut rng, args.drift_deg, args.drift_mm),
    )
    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let ident = measure(&truth, 50, sigma, &mut rng);
    let valid = measure(&truth, 50, sigma, &mut rng);
    let swarm_seed = args.seed ^ 0x5eed;

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
    let mut record = |name: &str, fit: Fit<6, VCAP>, seconds: f64, extra: Extra| -> f64 {
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
    let pso = pso_mdh(&nominal, &ident, swarm_seed, args.max_iterations, None)?;
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
    let hybrid = bpnn_pso_mdh(&net, &nominal, &ident, swarm_seed, args.max_iterations)?;
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
    let first = pso_mdh(&nominal, &ident, swarm_seed, args.max_iterations, None)?;
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

    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.out_dir.display()))?;
    let fit_svg = args.out_dir.join("fitness.svg");
    let curves: Vec<(String, Vec<(f64, f64)>)> = curves
        .into_iter()
        .filter(|c| c.0 == "pso" || c.0 == "bpnn-pso")
        .collect();
    plots::line_chart(
        &fit_svg,
        "Best fitness per iteration (follow-up identification)",
        "iteration",
        "fitness Σ|e|² (mm²)",
        &curves,
        true,
    )?;
    let err_svg = args.out_dir.join("pose_errors.svg");
    plots::pose_errors(
        &err_svg,
        "Position error on the 50 validation poses",
        &errors,
    )?;

    // The calibration report of the paper's method (BPNN-PSO) on these poses.
    let page = args.out_dir.join("report.html");
    let built = crate::report_html::build(crate::report_html::Inputs {
        robot_name: "ER20-C10 stand-in (kinecal demo)".into(),
        model_name: "identified by BPNN-PSO (follow-up identification)".into(),
        sources: crate::report_html::Sources {
            files: vec![(
                "data".into(),
                format!(
                    "kinecal demo --seed {}: {} identification and {} validation poses, \
                     {} mm tracker noise",
                    args.seed,
                    ident.len(),
                    valid.len(),
                    sigma
                ),
            )],
            units: "millimetres and degrees".into(),
        },
        nominal: &nominal,
        base_fitted: false,
        tool_unknown: false,
        model: &hybrid_robot,
        start: &nominal,
        all_params: crate::calibration::model_params(&hybrid_robot, &[]),
        estimated: set.as_slice().to_vec(),
        // The demo's model comes from BPNN-PSO, which has no prior.
        prior: vec![None; set.len()],
        ident: ident.clone(),
        valid: valid.clone(),
        pose_of: (0..ident.len()).collect(),
        ident_poses: ident.len(),
        valid_poses: valid.len(),
        names: Vec::new(),
        six_d: false,
        sigma: false,
        weighting: crate::calibration::weights::Weighting {
            balance: false,
            orientation_cv: false,
            params: set.as_slice().len(),
        },
        limits_deg: vec![None; 6],
        stall_rms_mm: 5.0,
        diagnose: None,
        validation: None,
    })?;
    crate::output::atomic::write_atomic(&page, built.html.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", page.display()))?;
    eprintln!("wrote the calibration report {}", page.display());

    let ratio = hybrid_reach.map(|h| h as f64 / pso_reach.max(1) as f64);
    Ok(DemoReport {
        robot: "ER20-C10 stand-in".to_string(),
        noise_mm: sigma,
        n_identification: ident.len(),
        n_validation: valid.len(),
        factory_pso_iterations: factory_run.fit.iterations,
        drift: Drift {
            angle_deg: args.drift_deg,
            length_mm: args.drift_mm,
            validation_rms_mm: ErrorStats::of(&pose_errors(&factory, &valid)).map(|s| s.rms_mm),
        },
        methods: rows,
        bpnn_pso_iteration_ratio: ratio,
        figures: vec![fit_svg.display().to_string(), err_svg.display().to_string()],
    })
}
