//! `kinecal study`: the measurement-planning study of Jost et al. 2017 (their §3.3, Table 8,
//! Figure 8), and the Monte Carlo check of the predicted covariance.
//!
//! **Manipulators.** The ER20-C10-like arm of `examples/cell` with the upper arm (segment 2,
//! the `a` of row 3) from 650 to 1100 mm and the forearm (segment 4, the `d` of row 4) from
//! 600 to 1000 mm in 50 mm steps: 10 × 9 = 90 arms. **Cell.** The example cell, adapted per
//! arm: the upper-arm and forearm capsules follow the link lengths, and the car body keeps
//! its distance relative to the arm's horizontal reach (its near side at 56.5 % of the reach,
//! as in the example cell), so every arm works against the car. **Working configuration**: the
//! same joint values for every arm (default 0, 30, 10, 0, −40, 0°, the tool facing the car).
//!
//! For each arm, with and without collision avoidance (without: limits and incidence only),
//! `--poses` poses are planned by: random feasible poses (the mean KPI of `--random-designs`
//! draws), the D-optimal design (= O1, Borm–Menq), and the KPI design; all from the same pool.
//! The table gives the mean, min and max predicted TCP covariance trace and the KPI design's
//! improvement `1 − KPI/other`. Designs made without collision avoidance are also checked
//! against the full scene: the share of their poses that collide is reported.
//!
//! **Monte Carlo** (`--monte-carlo R`, 0 to skip): for the example arm (780/760 mm) and its
//! KPI design, a true robot with geometric errors (alpha/theta ±0.1°, a/d ±0.8 mm, tool
//! ±0.5 mm) is measured R times with Gaussian noise σ at the planned poses, each data set is
//! identified by Levenberg–Marquardt from the nominal model (full parameter set, base
//! unknown), and the spread of the identified tool points at the working configuration is
//! compared with the plan's prediction σ²·trace C_s.

use crate::calibration::fit_lm;
use crate::commands::plan::{
    self, optimise, CriterionArg, HostCandidate, Neighbourhood, PoseRowsHost, Refinement,
};
use crate::formats::cell::{HostScene, SceneFile};
use crate::simulation::{self, GeomErrors};
use anyhow::{anyhow, bail};
use kinecal::identify::lm::LmConfig;
use kinecal::planning::capsule::Capsule;
use kinecal::planning::cell::{Scene, Tracker};
use kinecal::planning::selection::Criterion;
use kinecal::{ForwardKinematics, Frame, Joint, Measurement, Robot};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use serde_json::json;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Arguments of `kinecal study`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Upper-arm lengths (segment 2) MIN:MAX:STEP in mm.
    #[arg(long, default_value = "650:1100:50")]
    pub upper_arm_mm: String,
    /// Forearm lengths (segment 4) MIN:MAX:STEP in mm.
    #[arg(long, default_value = "600:1000:50")]
    pub forearm_mm: String,
    /// Measurement poses per design.
    #[arg(long, default_value_t = 60)]
    pub poses: usize,
    /// Feasible candidate poses per arm and setting.
    #[arg(long, default_value_t = 1500)]
    pub pool: usize,
    /// Random designs averaged per arm and setting.
    #[arg(long, default_value_t = 3)]
    pub random_designs: usize,
    /// Most Fedorov exchange passes per design.
    #[arg(long, default_value_t = 10)]
    pub passes: u32,
    /// Working configuration q1,…,q6 in degrees.
    #[arg(
        long = "work",
        default_value = "0,30,10,0,-40,0",
        allow_hyphen_values = true
    )]
    pub work: String,
    /// Measurement noise, standard deviation per axis (mm).
    #[arg(long, default_value_t = 0.01)]
    pub noise_mm: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Monte Carlo runs of simulate + identify for the example arm's KPI design (0 = skip).
    #[arg(long, default_value_t = 1000)]
    pub monte_carlo: usize,
    /// Also polish the D and KPI designs by local refinement (poses near the selected ones
    /// added to the pool, as `kinecal plan` does by default); about 5× slower.
    #[arg(long)]
    pub refine: bool,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Write the figure (SVG): the KPI design's improvement per arm.
    #[arg(long)]
    pub svg: Option<PathBuf>,
}

/// The example arm with upper arm `upper` and forearm `forearm` (mm).
pub fn arm(upper: f64, forearm: f64) -> anyhow::Result<Robot<f64, 6, 0>> {
    let lim = |j: Joint<f64>, lo: f64, hi: f64| Joint {
        lower: lo.to_radians(),
        upper: hi.to_radians(),
        ..j
    };
    let rows = [
        lim(Joint::mdh_deg(0.0, 0.0, 0.0, 504.0), -170.0, 170.0),
        lim(Joint::mdh_deg(-90.0, 170.0, -90.0, 0.0), -90.0, 150.0),
        lim(Joint::mdh_deg(0.0, upper, 0.0, 0.0), -80.0, 160.0),
        lim(Joint::mdh_deg(-90.0, 140.0, 0.0, forearm), -180.0, 180.0),
        lim(Joint::mdh_deg(90.0, 0.0, 0.0, 0.0), -135.0, 135.0),
        lim(Joint::mdh_deg(-90.0, 0.0, 0.0, 125.0), -360.0, 360.0),
    ];
    Robot::new(Frame::identity(), rows, Vector3::new(0.0, 0.0, 100.0))
        .map_err(|e| anyhow!("arm: {e:?}"))
}

/// Horizontal reach of an arm of this family (mm): shoulder offset, upper arm, forearm with
/// its offset, flange and tool.
fn reach(upper: f64, forearm: f64) -> f64 {
    170.0 + upper + (140.0f64 * 140.0 + forearm * forearm).sqrt() + 225.0
}

/// The example cell (examples/cell/scene.toml) adapted to an arm of this family.
pub fn cell(upper: f64, forearm: f64) -> anyhow::Result<HostScene> {
    let v = Vector3::new;
    let c = |a: Vector3<f64>, b: Vector3<f64>, r: f64| Capsule::new(a, b, r);
    let tracker = Tracker {
        position: v(1000.0, -2700.0, 300.0),
        max_incidence: 30f64.to_radians(),
        beam_radius: 5.0,
    };
    let mut s: HostScene = Scene::new(tracker, Some(-450.0)).map_err(|e| anyhow!("{e:?}"))?;
    let links = [
        (0, c(v(0.0, 0.0, 0.0), v(0.0, 0.0, 150.0), 200.0)),
        (1, c(v(0.0, 0.0, -250.0), v(170.0, 0.0, 0.0), 170.0)),
        (2, c(v(0.0, 0.0, 0.0), v(upper, 0.0, 0.0), 130.0)),
        (
            3,
            c(v(70.0, -100.0, 0.0), v(140.0, forearm - 140.0, 0.0), 110.0),
        ),
        (5, c(v(0.0, -60.0, 0.0), v(0.0, 70.0, 0.0), 85.0)),
        (6, c(v(0.0, 0.0, 0.0), v(0.0, 0.0, 40.0), 45.0)),
    ];
    for (f, cap) in links {
        s.add_link_capsule(f, cap).map_err(|e| anyhow!("{e:?}"))?;
    }
    // The example cell's car side is at x = 1100, 56.5 % of the example arm's reach.
    let shift = 1100.0 / reach(780.0, 760.0) * (reach(upper, forearm) - reach(780.0, 760.0));
    for cap in [
        c(
            v(1900.0 + shift, -2000.0, 100.0),
            v(1900.0 + shift, 2000.0, 100.0),
            800.0,
        ),
        c(
            v(2000.0 + shift, -900.0, 800.0),
            v(2000.0 + shift, 900.0, 800.0),
            600.0,
        ),
        c(v(-1700.0, -3500.0, 500.0), v(-1700.0, 3500.0, 500.0), 800.0),
    ] {
        s.add_obstacle(cap).map_err(|e| anyhow!("{e:?}"))?;
    }
    Ok(s)
}

fn parse_range(text: &str, what: &str) -> anyhow::Result<Vec<f64>> {
    let p: Vec<f64> = text
        .split(':')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow!("{what} `{text}`: expected MIN:MAX:STEP in mm"))?;
    let [lo, hi, step] = p[..] else {
        bail!("{what} `{text}`: expected MIN:MAX:STEP in mm")
    };
    if !(lo.is_finite() && hi.is_finite() && step > 0.0 && lo <= hi && lo > 0.0) {
        bail!("{what} `{text}`: need 0 < MIN ≤ MAX and STEP > 0");
    }
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    if n > 1000 {
        bail!("{what} `{text}`: more than 1000 values");
    }
    Ok((0..n).map(|i| lo + step * i as f64).collect())
}

/// KPI traces (mm²) of the three designs of one arm in one setting.
#[derive(Clone, Debug, Default)]
struct Cell {
    random: f64,
    d: f64,
    kpi: f64,
    /// Share of the D and KPI designs' poses that collide (settings without avoidance).
    colliding: f64,
}

#[derive(Clone, Debug)]
struct ArmResult {
    upper: f64,
    forearm: f64,
    /// [with collision avoidance, without].
    settings: [Cell; 2],
}

fn colliding_share<const N: usize, const V: usize>(
    robot: &Robot<f64, N, V>,
    scene: &HostScene,
    poses: &[[f64; N]],
) -> f64 {
    let mut fk = ForwardKinematics::new();
    let bad = poses
        .iter()
        .filter(|q| {
            fk.compute(robot, q);
            !scene.check(robot, &fk, true).feasible()
        })
        .count();
    bad as f64 / poses.len().max(1) as f64
}

fn study_arm(
    args: &Args,
    upper: f64,
    forearm: f64,
    work: &[[f64; 6]],
    seed: u64,
) -> anyhow::Result<ArmResult> {
    let robot = arm(upper, forearm)?;
    let scene = cell(upper, forearm)?;
    let params = plan::plan_params(6)?;
    let params = params.as_slice();
    let mut settings: [Cell; 2] = Default::default();
    for (k, collisions) in [true, false].into_iter().enumerate() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ ((k as u64) << 40));
        let max_draws = 4_000_000;
        let mut random = 0.0;
        for _ in 0..args.random_designs.max(1) {
            let (poses, _) = plan::random_design(
                &robot, &scene, params, args.poses, collisions, &mut rng, max_draws,
            )?;
            let qs: Vec<[f64; 6]> = poses.iter().map(|c| c.q).collect();
            random += plan::evaluate(&robot, params, &qs, work, args.noise_mm)?.kpi_trace_mm2;
        }
        random /= args.random_designs.max(1) as f64;
        let pool = plan::build_pool(
            &robot,
            &scene,
            params,
            args.pool.max(args.poses),
            collisions,
            &mut rng,
            max_draws,
        );
        if pool.candidates.len() < args.poses {
            bail!(
                "arm {upper}/{forearm} mm: only {} feasible poses in {} draws",
                pool.candidates.len(),
                pool.draws
            );
        }
        let mut cands: Vec<HostCandidate<6>> = pool.candidates;
        let basis = plan::pool_basis(&cands, params.len())?;
        basis.reduce_pool(&mut cands);
        let wr: Vec<PoseRowsHost> = plan::work_rows(&robot, params, work)?
            .iter()
            .map(|g| basis.reduce(g))
            .collect();
        let mut traces = [0.0; 2];
        let mut colliding = 0.0;
        let hood = Neighbourhood {
            robot: &robot,
            scene: &scene,
            params,
            collisions,
        };
        let refinement = Refinement::default();
        for (t, criterion) in traces.iter_mut().zip([Criterion::D, Criterion::Kpi]) {
            // Each design starts from the same pool and refines with its own neighbours.
            let mut own = cands.clone();
            let refine = args.refine.then_some((&hood, &refinement, &mut rng));
            let (design, _) = optimise(
                &mut own,
                &basis,
                &wr,
                criterion,
                args.poses,
                args.passes,
                refine,
            )?;
            let qs: Vec<[f64; 6]> = design.iter().map(|i| own[*i].q).collect();
            *t = plan::evaluate(&robot, params, &qs, work, args.noise_mm)?.kpi_trace_mm2;
            if !collisions {
                colliding += 0.5 * colliding_share(&robot, &scene, &qs);
            }
        }
        settings[k] = Cell {
            random,
            d: traces[0],
            kpi: traces[1],
            colliding,
        };
    }
    Ok(ArmResult {
        upper,
        forearm,
        settings,
    })
}

/// Monte Carlo of simulate + identify against the plan's prediction.
pub struct MonteCarlo {
    pub runs: usize,
    pub predicted_trace_mm2: f64,
    /// Σ_s trace of the sample covariance of the identified tool points.
    pub empirical_trace_mm2: f64,
    /// Σ_s mean squared error of the identified tool points against the truth.
    pub empirical_mse_mm2: f64,
    pub seconds: f64,
}

impl MonteCarlo {
    pub fn ratio(&self) -> f64 {
        self.empirical_trace_mm2 / self.predicted_trace_mm2
    }
}

/// Plans a design (`criterion`) of `poses` poses for `robot` in `scene`, then identifies `runs`
/// noisy data sets of a true robot with geometric errors and compares the spread of the
/// identified tool points at `work` with the prediction.
#[allow(clippy::too_many_arguments)]
pub fn monte_carlo<const V: usize>(
    robot: &Robot<f64, 6, V>,
    scene: &HostScene,
    criterion: CriterionArg,
    work: &[[f64; 6]],
    poses: usize,
    pool: usize,
    sigma: f64,
    runs: usize,
    seed: u64,
) -> anyhow::Result<MonteCarlo> {
    if runs < 2 {
        bail!("the Monte Carlo check needs at least 2 runs, got {runs}");
    }
    let start = Instant::now();
    let nominal = plan::in_base_frame(robot);
    let req = plan::PlanRequest {
        scene,
        criterion,
        poses,
        work,
        sigma,
        pool,
        collisions: true,
        passes: 30,
        seed,
        refine: true,
    };
    let p = plan::plan(&nominal, &req)?;
    let qs: Vec<[f64; 6]> = p.poses.iter().map(|c| c.q).collect();
    let params = plan::plan_params(6)?;
    let mut streams = simulation::Streams::new(seed);
    let truth = simulation::perturb_geometry(&nominal, &GeomErrors::default(), &mut streams.errors);
    let mut fk = ForwardKinematics::new();
    let true_tcp: Vec<Vector3<f64>> = work.iter().map(|q| fk.compute(&truth, q)).collect();
    let mut sum = vec![Vector3::zeros(); work.len()];
    let mut sum2 = vec![Matrix3::zeros(); work.len()];
    let mut mse = 0.0;
    let cfg = LmConfig::default();
    for _ in 0..runs {
        let points = simulation::measure(&truth, &qs, sigma, &mut streams.noise);
        let data: Vec<Measurement<f64, 6>> = qs
            .iter()
            .zip(&points)
            .map(|(q, p)| Measurement { q: *q, point: *p })
            .collect();
        let fit = fit_lm(&nominal, params.as_slice(), &data, cfg)?;
        for (s, q) in work.iter().enumerate() {
            let e = fk.compute(&fit.robot, q) - true_tcp[s];
            sum[s] += e;
            sum2[s] += e * e.transpose();
            mse += e.norm_squared();
        }
    }
    let r = runs as f64;
    let mut empirical = 0.0;
    for (s1, s2) in sum.iter().zip(&sum2) {
        let mean = s1 / r;
        let cov = (s2 - mean * mean.transpose() * r) / (r - 1.0);
        empirical += cov.trace();
    }
    Ok(MonteCarlo {
        runs,
        predicted_trace_mm2: p.evaluation.kpi_trace_mm2,
        empirical_trace_mm2: empirical,
        empirical_mse_mm2: mse / r,
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn stats(v: &[f64]) -> (f64, f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let max = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    (mean, min, max)
}

/// Runs the subcommand; returns the JSON report (printed when `--json` is given).
pub fn run(args: &Args, json: bool) -> anyhow::Result<serde_json::Value> {
    let uppers = parse_range(&args.upper_arm_mm, "--upper-arm-mm")?;
    let forearms = parse_range(&args.forearm_mm, "--forearm-mm")?;
    if args.poses == 0 {
        bail!("--poses must be at least 1");
    }
    if !(args.noise_mm.is_finite() && args.noise_mm > 0.0) {
        bail!("--noise-mm must be a positive number");
    }
    let work = vec![plan::parse_configuration::<6>(&args.work)?];
    let arms: Vec<(f64, f64)> = uppers
        .iter()
        .flat_map(|u| forearms.iter().map(move |f| (*u, *f)))
        .collect();
    let start = Instant::now();
    let bar = indicatif::ProgressBar::new(arms.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("study {bar:40} {pos}/{len} arms {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<anyhow::Result<ArmResult>>>> =
        Mutex::new((0..arms.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..args.threads.clamp(1, 64) {
            let builder = std::thread::Builder::new().stack_size(8 << 20);
            let _ = builder.spawn_scoped(scope, || loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&(u, f)) = arms.get(i) else { break };
                let r = study_arm(args, u, f, &work, args.seed.wrapping_add(1000 * i as u64));
                if let Ok(mut g) = results.lock() {
                    g[i] = Some(r);
                }
                bar.inc(1);
            });
        }
    });
    bar.finish_and_clear();
    let results: Vec<ArmResult> = results
        .into_inner()
        .map_err(|_| anyhow!("internal error: a worker panicked"))?
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Err(anyhow!("internal error: an arm was not studied"))))
        .collect::<anyhow::Result<_>>()?;
    let study_seconds = start.elapsed().as_secs_f64();

    let mut table = Vec::new();
    let mut text = String::new();
    text.push_str(&format!(
        "{} arms × {} poses, σ = {} mm, working configuration {}°\n",
        results.len(),
        args.poses,
        args.noise_mm,
        args.work
    ));
    text.push_str("setting                      design   mean TCP trace (mm²)   min        max        KPI improvement mean [min, max]\n");
    for (k, name) in ["with collision avoidance", "without collision avoidance"]
        .iter()
        .enumerate()
    {
        let kpi: Vec<f64> = results.iter().map(|r| r.settings[k].kpi).collect();
        let mut designs = serde_json::Map::new();
        for (design, vals) in [
            (
                "random",
                results
                    .iter()
                    .map(|r| r.settings[k].random)
                    .collect::<Vec<_>>(),
            ),
            ("d_o1", results.iter().map(|r| r.settings[k].d).collect()),
            ("kpi", kpi.clone()),
        ] {
            let (mean, min, max) = stats(&vals);
            let imp: Vec<f64> = vals.iter().zip(&kpi).map(|(o, k)| 1.0 - k / o).collect();
            let (im, imin, imax) = stats(&imp);
            let imp_text = if design == "kpi" {
                String::new()
            } else {
                format!(
                    "{:5.1} % [{:.1}, {:.1}]",
                    100.0 * im,
                    100.0 * imin,
                    100.0 * imax
                )
            };
            text.push_str(&format!(
                "{name:28} {design:8} {mean:12.4e}          {min:.3e}  {max:.3e}  {imp_text}\n"
            ));
            designs.insert(
                design.to_string(),
                json!({ "mean_kpi_trace_mm2": mean, "min_kpi_trace_mm2": min, "max_kpi_trace_mm2": max,
                        "kpi_improvement_mean": if design == "kpi" { serde_json::Value::Null } else { json!(im) },
                        "kpi_improvement_min": if design == "kpi" { serde_json::Value::Null } else { json!(imin) },
                        "kpi_improvement_max": if design == "kpi" { serde_json::Value::Null } else { json!(imax) } }),
            );
        }
        let colliding = if k == 1 {
            Some(
                stats(
                    &results
                        .iter()
                        .map(|r| r.settings[1].colliding)
                        .collect::<Vec<_>>(),
                )
                .0,
            )
        } else {
            None
        };
        if let Some(c) = colliding {
            text.push_str(&format!("  (designs planned without collision avoidance: {:.0} % of their poses collide in the full cell)\n", 100.0 * c));
        }
        table.push(json!({ "collision_avoidance": k == 0, "designs": designs, "colliding_share": colliding }));
    }
    text.push_str(&format!(
        "study: {:.1} s on {} threads\n",
        study_seconds,
        args.threads.clamp(1, 64)
    ));

    let mc = if args.monte_carlo > 0 {
        let robot = arm(780.0, 760.0)?;
        let scene = cell(780.0, 760.0)?;
        let m = monte_carlo(
            &robot,
            &scene,
            CriterionArg::Kpi,
            &work,
            args.poses,
            3000,
            args.noise_mm,
            args.monte_carlo,
            args.seed,
        )?;
        text.push_str(&format!(
            "Monte Carlo ({} runs of simulate + LM identify, example arm, KPI design): predicted TCP trace {:.4e} mm², \
             sample covariance trace {:.4e} mm² (ratio {:.3}), mean squared error {:.4e} mm²; {:.1} s\n",
            m.runs,
            m.predicted_trace_mm2,
            m.empirical_trace_mm2,
            m.ratio(),
            m.empirical_mse_mm2,
            m.seconds
        ));
        Some(
            json!({ "runs": m.runs, "predicted_trace_mm2": m.predicted_trace_mm2, "empirical_trace_mm2": m.empirical_trace_mm2,
                     "ratio": m.ratio(), "empirical_mse_mm2": m.empirical_mse_mm2, "seconds": m.seconds }),
        )
    } else {
        None
    };

    if let Some(path) = &args.svg {
        let series: Vec<(String, Vec<f64>)> = vec![
            (
                "vs random, with collision avoidance".into(),
                results
                    .iter()
                    .map(|r| 100.0 * (1.0 - r.settings[0].kpi / r.settings[0].random))
                    .collect(),
            ),
            (
                "vs D/O1, with collision avoidance".into(),
                results
                    .iter()
                    .map(|r| 100.0 * (1.0 - r.settings[0].kpi / r.settings[0].d))
                    .collect(),
            ),
            (
                "vs random, without".into(),
                results
                    .iter()
                    .map(|r| 100.0 * (1.0 - r.settings[1].kpi / r.settings[1].random))
                    .collect(),
            ),
            (
                "vs D/O1, without".into(),
                results
                    .iter()
                    .map(|r| 100.0 * (1.0 - r.settings[1].kpi / r.settings[1].d))
                    .collect(),
            ),
        ];
        crate::plan::study_figure::improvements(
            path,
            &format!(
                "KPI design: TCP variance improvement, {} arms",
                results.len()
            ),
            &series,
        )?;
        text.push_str(&format!("figure written to {}\n", path.display()));
    }
    if !json {
        print!("{text}");
    }
    let arms_json: Vec<serde_json::Value> = results
        .iter()
        .map(|r| {
            json!({ "upper_arm_mm": r.upper, "forearm_mm": r.forearm,
                    "with": { "random": r.settings[0].random, "d_o1": r.settings[0].d, "kpi": r.settings[0].kpi },
                    "without": { "random": r.settings[1].random, "d_o1": r.settings[1].d, "kpi": r.settings[1].kpi,
                                 "colliding_share": r.settings[1].colliding } })
        })
        .collect();
    Ok(json!({
        "arms": results.len(),
        "poses": args.poses,
        "noise_mm": args.noise_mm,
        "work_deg": args.work,
        "table": table,
        "monte_carlo": mc,
        "per_arm": arms_json,
        "seconds": study_seconds,
    }))
}

/// The example cell as a scene file (what examples/cell/scene.toml holds).
pub fn example_scene_file() -> anyhow::Result<SceneFile> {
    let s = cell(780.0, 760.0)?;
    let v3 = |v: &Vector3<f64>| [v.x, v.y, v.z];
    Ok(SceneFile {
        tracker: crate::formats::cell::TrackerSpec {
            xyz_mm: v3(&s.tracker().position),
            max_incidence_deg: (s.tracker().max_incidence.to_degrees() * 1e9).round() / 1e9,
            beam_radius_mm: s.tracker().beam_radius,
        },
        floor: s
            .floor_z()
            .map(|z| crate::formats::cell::FloorSpec { z_mm: z }),
        link_capsules: s
            .link_capsules()
            .iter()
            .map(|l| crate::formats::cell::LinkCapsuleSpec {
                frame: l.frame as usize,
                a_mm: v3(&l.capsule.a),
                b_mm: v3(&l.capsule.b),
                radius_mm: l.capsule.radius,
            })
            .collect(),
        obstacles: s
            .obstacles()
            .iter()
            .map(|o| crate::formats::cell::ObstacleSpec {
                a_mm: v3(&o.a),
                b_mm: v3(&o.b),
                radius_mm: o.radius,
            })
            .collect(),
    })
}
