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

use crate::application::study::{study, Options};
use crate::plan::design;
use crate::plan::study::{length_range, StudySettings};
use crate::reports::study::StudyReport;
use std::path::PathBuf;

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
    let uppers = length_range(&args.upper_arm_mm, "--upper-arm-mm")?;
    let forearms = length_range(&args.forearm_mm, "--forearm-mm")?;
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
    let work = design::parse_configuration::<6>(&args.work)?;
    if let Some(w) = design::radians_warning(&work, &args.work) {
        eprintln!("kinecal study: {w}");
    }
    let options = Options {
        settings,
        uppers,
        forearms,
        work,
        seed: args.seed,
        monte_carlo: args.monte_carlo,
        threads: args.threads,
    };
    let arms = (options.uppers.len() * options.forearms.len()) as u64;
    let bar = indicatif::ProgressBar::new(arms);
    bar.set_style(
        indicatif::ProgressStyle::with_template("study {bar:40} {pos}/{len} arms {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let done = study(&options, &|| bar.inc(1));
    bar.finish_and_clear();
    let (mut report, results) = done?;
    if let Some(path) = &args.svg {
        crate::plan::study_figure::kpi_improvements(path, &results)?;
    }
    report.work_deg = args.work.clone();
    report.figure = args.svg.as_ref().map(|p| p.display().to_string());
    Ok(report)
}
