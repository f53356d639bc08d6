//! The measurement-planning study on settings already parsed: the application function under
//! `kinecal study` (which parses the ranges, calls [`study`], draws the figure and renders the
//! report). Each arm of the grid is planned on a worker thread ([`crate::plan::study`]); the
//! table, the per-arm rows and the Monte Carlo check of the predicted covariance are built
//! here.

use crate::plan::design::CriterionArg;
use crate::plan::study::*;
use crate::reports::study::{
    ArmDesigns, ArmDesignsWithout, ArmRow, DesignStats, Designs, MonteCarloReport, SettingRow,
    StudyReport,
};
use anyhow::anyhow;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// What to study: the plan settings, the arms' upper-arm and forearm lengths (mm), the working
/// configuration, the seed, the Monte Carlo runs (0 to skip) and the worker threads.
pub struct Options {
    pub settings: StudySettings,
    pub uppers: Vec<f64>,
    pub forearms: Vec<f64>,
    /// Joint values, degrees.
    pub work: [f64; 6],
    pub seed: u64,
    pub monte_carlo: usize,
    pub threads: usize,
}

/// Runs the study; `arm_done` is called as each arm finishes (a progress bar). Returns the
/// report (`work_deg` and `figure` unset) and each arm's result (for the figure).
pub fn study(
    options: &Options,
    arm_done: &(dyn Fn() + Sync),
) -> anyhow::Result<(StudyReport, Vec<ArmResult>)> {
    let Options {
        settings,
        uppers,
        forearms,
        seed,
        ..
    } = options;
    let work = vec![options.work];
    let arms: Vec<(f64, f64)> = uppers
        .iter()
        .flat_map(|u| forearms.iter().map(move |f| (*u, *f)))
        .collect();
    let start = Instant::now();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<anyhow::Result<ArmResult>>>> =
        Mutex::new((0..arms.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..options.threads.clamp(1, 64) {
            let builder = std::thread::Builder::new();
            let _ = builder.spawn_scoped(scope, || loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&(u, f)) = arms.get(i) else { break };
                let r = study_arm(settings, u, f, &work, seed.wrapping_add(1000 * i as u64));
                if let Ok(mut g) = results.lock() {
                    g[i] = Some(r);
                }
                arm_done();
            });
        }
    });
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

    let monte_carlo = if options.monte_carlo > 0 {
        let robot = arm(780.0, 760.0)?;
        let scene = cell(780.0, 760.0)?;
        let m = monte_carlo(
            &robot,
            &scene,
            CriterionArg::Kpi,
            &work,
            settings.poses,
            3000,
            settings.noise_mm,
            options.monte_carlo,
            *seed,
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
    let report = StudyReport {
        arms: results.len(),
        poses: settings.poses,
        noise_mm: settings.noise_mm,
        work_deg: String::new(),
        table,
        monte_carlo,
        per_arm,
        seconds: study_seconds,
        threads: options.threads.clamp(1, 64),
        figure: None,
    };
    Ok((report, results))
}
