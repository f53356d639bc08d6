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

use crate::plan::design::{self, CriterionArg};
use crate::reports::study::{
    ArmDesigns, ArmDesignsWithout, ArmRow, DesignStats, Designs, MonteCarloReport, SettingRow,
    StudyReport,
};
use anyhow::{anyhow, bail};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::plan::study::*;

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

fn parse_range(text: &str, what: &str) -> anyhow::Result<Vec<f64>> {
    let p: Vec<f64> = text
        .split(':')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow!("{what} `{text}`: expected MIN:MAX:STEP in mm"))?;
    let [lo, hi, step] = p[..] else {
        bail!("{what} `{text}`: expected MIN:MAX:STEP in mm")
    };
    if !(lo.is_finite()
        && hi.is_finite()
        && step.is_finite()
        && step > 0.0
        && lo <= hi
        && lo > 0.0
        && hi <= crate::MAX_LENGTH_MM)
    {
        crate::refuse!(
            "{what} `{text}`: need 0 < MIN ≤ MAX ≤ {} and a finite STEP > 0",
            crate::MAX_LENGTH_MM
        );
    }
    // Counted in f64 first: a tiny step must not wrap the count.
    let n_f = ((hi - lo) / step + 1e-9).floor() + 1.0;
    if n_f.is_nan() || n_f > 1000.0 {
        crate::refuse!("{what} `{text}`: more than 1000 values: use a larger STEP");
    }
    let n = n_f as usize;
    Ok((0..n).map(|i| lo + step * i as f64).collect())
}

/// Runs the subcommand: the study's table (and figure with `--svg`).
pub fn run(args: &Args) -> anyhow::Result<StudyReport> {
    let settings = StudySettings {
        poses: args.poses,
        pool: args.pool,
        random_designs: args.random_designs,
        passes: args.passes,
        noise_mm: args.noise_mm,
        refine: args.refine,
    };
    let uppers = parse_range(&args.upper_arm_mm, "--upper-arm-mm")?;
    let forearms = parse_range(&args.forearm_mm, "--forearm-mm")?;
    crate::check_count("--poses", args.poses, 1, crate::MAX_PLAN_POSES)?;
    crate::check_count("--pool", args.pool, 1, crate::MAX_POOL)?;
    crate::check_count("--random-designs", args.random_designs, 0, 1000)?;
    crate::check_count(
        "--passes",
        args.passes as usize,
        0,
        crate::MAX_PASSES as usize,
    )?;
    crate::check_count("--monte-carlo", args.monte_carlo, 0, 1_000_000)?;
    crate::check_count("--threads", args.threads, 1, 256)?;
    crate::check_positive("--noise-mm", args.noise_mm, crate::MAX_NOISE_MM)?;
    let work = vec![design::parse_configuration::<6>(&args.work)?];
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
                let r = study_arm(
                    &settings,
                    u,
                    f,
                    &work,
                    args.seed.wrapping_add(1000 * i as u64),
                );
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
    for k in 0..2 {
        let kpi: Vec<f64> = results.iter().map(|r| r.settings[k].kpi).collect();
        let design = |vals: Vec<f64>, is_kpi: bool| {
            let (mean, min, max) = stats(&vals);
            let imp: Vec<f64> = vals.iter().zip(&kpi).map(|(o, k)| 1.0 - k / o).collect();
            let (im, imin, imax) = stats(&imp);
            let not_kpi = |x: f64| (!is_kpi).then_some(x);
            DesignStats {
                mean_kpi_trace_mm2: mean,
                min_kpi_trace_mm2: min,
                max_kpi_trace_mm2: max,
                kpi_improvement_mean: not_kpi(im),
                kpi_improvement_min: not_kpi(imin),
                kpi_improvement_max: not_kpi(imax),
            }
        };
        let designs = Designs {
            random: design(
                results.iter().map(|r| r.settings[k].random).collect(),
                false,
            ),
            d_o1: design(results.iter().map(|r| r.settings[k].d).collect(), false),
            kpi: design(kpi.clone(), true),
        };
        let colliding_share = (k == 1).then(|| {
            stats(
                &results
                    .iter()
                    .map(|r| r.settings[1].colliding)
                    .collect::<Vec<_>>(),
            )
            .0
        });
        table.push(SettingRow {
            collision_avoidance: k == 0,
            designs,
            colliding_share,
        });
    }

    let monte_carlo = if args.monte_carlo > 0 {
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
        Some(MonteCarloReport {
            runs: m.runs,
            predicted_trace_mm2: m.predicted_trace_mm2,
            empirical_trace_mm2: m.empirical_trace_mm2,
            ratio: m.ratio(),
            empirical_mse_mm2: m.empirical_mse_mm2,
            seconds: m.seconds,
        })
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
    }
    let per_arm = results
        .iter()
        .map(|r| {
            let (w, wo) = (&r.settings[0], &r.settings[1]);
            ArmRow {
                upper_arm_mm: r.upper,
                forearm_mm: r.forearm,
                with: ArmDesigns {
                    random: w.random,
                    d_o1: w.d,
                    kpi: w.kpi,
                },
                without: ArmDesignsWithout {
                    random: wo.random,
                    d_o1: wo.d,
                    kpi: wo.kpi,
                    colliding_share: wo.colliding,
                },
            }
        })
        .collect();
    Ok(StudyReport {
        arms: results.len(),
        poses: args.poses,
        noise_mm: args.noise_mm,
        work_deg: args.work.clone(),
        table,
        monte_carlo,
        per_arm,
        seconds: study_seconds,
        threads: args.threads.clamp(1, 64),
        figure: args.svg.as_ref().map(|p| p.display().to_string()),
    })
}
