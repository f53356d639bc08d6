//! The discrepancy-search test matrices (configurations in tests/data/).
//!
//! Fast subset (runs with `cargo test`): a few cases of every kind, asserted one by one.
//! Full matrices (print the naming rate, the false-alarm rate and the gap to the noise floor):
//!
//!     cargo test -p kinecal-host --test diagnose matrix:: -- --ignored --nocapture
//!
//! `full_matrix` runs diagnose_matrix.toml (the matrix the search was developed on);
//! `unseen_matrix` runs diagnose_matrix_unseen.toml (robots, joints, amplitudes, noise levels
//! and seeds the search was never tuned on, a 7-joint arm, and cases with raw effect values as
//! `kinecal simulate --effect` takes them); `grid_matrix` runs diagnose_matrix_grid.toml (joint
//! tables with knots on a fixed angle pitch aligned to multiples of the pitch or at a phase, as
//! gear and encoder tables are, on joints whose limits are not multiples of the pitch):
//!
//!     KINECAL_MATRIX_THREADS=2 cargo test -p kinecal-host --test diagnose matrix::grid_matrix -- --ignored --nocapture
//!
//! (The test profile is optimised: no `--release` needed. `KINECAL_MATRIX_FILE=other.toml` makes
//! `full_matrix` run another configuration, relative to tests/data or absolute;
//! `KINECAL_MATRIX_THREADS=2` runs two cases at a time; `KINECAL_MATRIX_ONLY=SEED,…` only the
//! cases with these seeds; `KINECAL_MATRIX_VERBOSE=1` prints every case's JSON report.)

use kinecal::{Frame, Measurement};
use kinecal_cli::diagnose::{diagnose, fit_geometry, Config, Diagnosis};
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::simulation::{simulate, EffectArg, GeomErrors, Simulation};
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::Deserialize;
use std::path::PathBuf;
use std::time::Instant;

mod cases;
mod config;
mod fast;

use cases::*;
use config::*;

/// The matrix the search was developed on: naming rate, false-alarm rate, gap to the floor.
#[test]
#[ignore = "the full matrix takes minutes: cargo test -p kinecal-host --test diagnose matrix:: -- --ignored --nocapture"]
fn full_matrix() {
    let file =
        std::env::var("KINECAL_MATRIX_FILE").unwrap_or_else(|_| "diagnose_matrix.toml".into());
    run_matrix(&file)
}

/// Cases the search was never tuned on.
#[test]
#[ignore = "the full matrix takes minutes: cargo test -p kinecal-host --test diagnose matrix:: -- --ignored --nocapture"]
fn unseen_matrix() {
    run_matrix("diagnose_matrix_unseen.toml");
}

/// Joint tables on fixed angle pitches and phases, with null cases.
#[test]
#[ignore = "the grid matrix takes a minute or more: KINECAL_MATRIX_THREADS=2 cargo test -p kinecal-host --test diagnose matrix::grid_matrix -- --ignored --nocapture"]
fn grid_matrix() {
    run_matrix("diagnose_matrix_grid.toml");
}

/// Runs every case of a matrix file and prints the rates.
pub fn run_matrix(file: &str) {
    let m = load_matrix_file(file);
    let robots: Vec<Arm> = m.robots.iter().map(load_arm).collect();
    let mut cases = all_cases(&m);
    // KINECAL_MATRIX_ONLY=1040,1041 runs only the cases with these seeds.
    if let Ok(only) = std::env::var("KINECAL_MATRIX_ONLY") {
        let seeds: Vec<u64> = only
            .split(',')
            .filter_map(|s| s.trim().parse().ok())
            .collect();
        cases.retain(|c| seeds.contains(&c.seed));
    }
    let threads: usize = std::env::var("KINECAL_MATRIX_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
        .max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: std::sync::Mutex<Vec<(usize, Outcome)>> = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..threads {
            // Each worker needs a big stack too.
            let work = || loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(c) = cases.get(i) else { break };
                let o = robots[c.robot].run(poses_of(&m, c), c, true);
                eprintln!(
                    "{}{}{}{}: named {:?}; held-out {:.4} → {:.4} mm = {:.2}× floor (est {:.4}, true {:.4}: {:.2}×), true effects cross-validated {}, fresh poses {:.2}× true floor (true effects {}), least gain {:.1} %, {:.2} s",
                    if (c.hidden.is_empty() && !o.named.is_empty()) || (!c.hidden.is_empty() && !o.exact) { "MISS " } else { "" },
                    if o.final_rms > 1.25 * o.floor_true { "FAR " } else { "" },
                    if o.beyond.is_empty() { String::new() } else { format!("BEYOND {:?} ", o.beyond) },
                    describe(&m, c),
                    o.named,
                    o.baseline_rms,
                    o.final_rms,
                    o.final_rms / o.floor_est,
                    o.floor_est,
                    o.floor_true,
                    o.final_rms / o.floor_true,
                    o.oracle.map_or("-".to_string(), |(r, _)| format!("{:.2}×", r / o.floor_true)),
                    o.fresh_rms.unwrap_or(f64::NAN) / o.floor_true,
                    o.oracle.map_or("-".to_string(), |(_, r)| format!("{:.2}×", r / o.floor_true)),
                    100.0 * o.least_gain,
                    o.seconds
                );
                if let Some(why) = &o.too_small {
                    eprintln!("  stopped: {why}");
                }
                results.lock().unwrap().push((i, o));
            };
            std::thread::Builder::new().spawn_scoped(s, work).unwrap();
        }
    });
    let results = results.into_inner().unwrap();
    let mut hidden_n = 0;
    let mut hidden_exact = 0;
    let mut nothing_n = 0;
    let mut false_alarms = 0;
    let mut gaps_est = Vec::new();
    let mut gaps_true = Vec::new();
    let mut gaps_hidden = Vec::new();
    // The hidden cases' final model on fresh poses, and of those above 1.25× the true floor in
    // cross-validation: the true effects' cross-validated figure and the fresh poses'.
    let mut fresh_hidden: Vec<(f64, Option<f64>)> = Vec::new();
    let mut far: Vec<(Option<f64>, f64)> = Vec::new();
    let mut secs = Vec::new();
    // The smallest held-out RMS drop of an effect named in a case where it was hidden.
    let mut least_gain = 1.0f64;
    // Per kind: cases, named exactly, final held-out / true floor of each.
    let mut by_kind: std::collections::BTreeMap<String, (usize, usize, Vec<f64>)> =
        Default::default();
    // Cases where a significant candidate was too small to be added (diagnose::Config's margin).
    let too_small = results
        .iter()
        .filter(|(_, o)| o.too_small.is_some())
        .count();
    // Cases with a hidden effect beyond the plausibility limits at its true size: right when it
    // is refused and the others are named exactly (the final RMS then stays above the floor by
    // what was refused).
    let mut beyond_n = 0;
    let mut beyond_ok = 0;
    for (i, o) in &results {
        let c = &cases[*i];
        secs.push(o.seconds);
        if !o.beyond.is_empty() {
            beyond_n += 1;
            beyond_ok += usize::from(o.exact);
            continue;
        }
        if c.hidden.is_empty() {
            nothing_n += 1;
            false_alarms += usize::from(!o.named.is_empty());
        } else {
            hidden_n += 1;
            hidden_exact += usize::from(o.exact);
            if o.exact {
                least_gain = least_gain.min(o.least_gain);
            }
            let key = if c.hidden.len() > 1 {
                "two effects".to_string()
            } else {
                match c.hidden[0].grid {
                    Some((pitch, _)) => format!("joint-table every {pitch}° (grid)"),
                    None => c.hidden[0].kind.clone(),
                }
            };
            let key = if c.raw.is_some() {
                format!("{key} (raw values)")
            } else {
                key
            };
            let e = by_kind.entry(key).or_default();
            e.0 += 1;
            e.1 += usize::from(o.exact);
            e.2.push(o.final_rms / o.floor_true);
            gaps_hidden.push(o.final_rms / o.floor_true);
            fresh_hidden.push((
                o.fresh_rms.unwrap_or(f64::NAN) / o.floor_true,
                o.oracle.map(|(_, r)| r / o.floor_true),
            ));
            if o.final_rms > 1.25 * o.floor_true {
                far.push((
                    o.oracle.map(|(r, _)| r / o.floor_true),
                    o.fresh_rms.unwrap_or(f64::NAN) / o.floor_true,
                ));
            }
        }
        gaps_est.push(o.final_rms / o.floor_est);
        gaps_true.push(o.final_rms / o.floor_true);
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let within = v.iter().filter(|g| **g <= 1.25).count() as f64 / v.len() as f64;
        (mean, v[v.len() / 2], v[v.len() - 1], within)
    };
    let (ge_mean, ge_med, ge_max, ge_in) = stats(&mut gaps_est);
    let (gt_mean, gt_med, gt_max, gt_in) = stats(&mut gaps_true);
    let hidden_stats = (!gaps_hidden.is_empty()).then(|| stats(&mut gaps_hidden));
    secs.sort_by(f64::total_cmp);
    let per_robot: Vec<String> = m
        .robots
        .iter()
        .filter_map(|r| r.poses.map(|p| format!("{} {p}", r.name)))
        .collect();
    println!(
        "\n=== {file}: {} cases, {} poses each{} ===",
        results.len(),
        m.poses,
        if per_robot.is_empty() {
            String::new()
        } else {
            format!(" (but {})", per_robot.join(", "))
        }
    );
    println!(
        "naming rate (plausible hidden effects named exactly, nothing else): {hidden_exact}/{hidden_n} = {:.1} %",
        100.0 * hidden_exact as f64 / hidden_n.max(1) as f64
    );
    for (k, (n, ok, gaps)) in &by_kind {
        let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
        let max = gaps.iter().copied().fold(0.0, f64::max);
        let within = gaps.iter().filter(|g| **g <= 1.25).count();
        println!(
            "  {k:30} {ok}/{n}   final/true floor mean {mean:.3}, max {max:.3}, ≤ 1.25 in {within}/{n}"
        );
    }
    if !fresh_hidden.is_empty() {
        let within = fresh_hidden.iter().filter(|(g, _)| *g <= 1.25).count();
        let max = fresh_hidden.iter().map(|(g, _)| *g).fold(0.0, f64::max);
        let truth: Vec<f64> = fresh_hidden.iter().filter_map(|(_, t)| *t).collect();
        let truth_within = truth.iter().filter(|t| **t <= 1.25).count();
        let truth_max = truth.iter().copied().fold(0.0, f64::max);
        println!(
            "on {} fresh poses, of the cases with something hidden: the final model ≤ 1.25× the true floor in {within}/{}, max {max:.3}; the true effects fitted to the same data in {truth_within}/{}, max {truth_max:.3}",
            cases::FRESH_POSES,
            fresh_hidden.len(),
            truth.len()
        );
        for (g, t) in fresh_hidden.iter().filter(|(g, _)| *g > 1.25) {
            println!(
                "  final model {g:.2}×, true effects {}",
                t.map_or("-".to_string(), |t| format!("{t:.2}×"))
            );
        }
    }
    if !far.is_empty() {
        let oracle_far = far
            .iter()
            .filter(|(o, _)| o.is_some_and(|o| o > 1.25))
            .count();
        let fresh_far = far.iter().filter(|(_, f)| *f > 1.25).count();
        let with_truth = far.iter().filter(|(o, _)| o.is_some()).count();
        println!(
            "of the {} hidden cases above 1.25× the true floor cross-validated: the true effects on their true grids (fitted in {with_truth} of them) are above it too in {oracle_far}, and the final model is above it on fresh poses in {fresh_far}",
            far.len()
        );
        for (o, f) in &far {
            println!(
                "  true effects cross-validated {}, final model on fresh poses {f:.2}×",
                o.map_or("-".to_string(), |o| format!("{o:.2}×"))
            );
        }
    }
    println!(
        "hidden effects beyond the plausibility limits (not counted above): refused, the others named exactly, in {beyond_ok}/{beyond_n} cases"
    );
    println!("cases stopped by a significant candidate below the practical margin: {too_small}");
    println!(
        "smallest held-out RMS drop of a hidden effect named exactly: {:.1} %",
        100.0 * least_gain
    );
    println!(
        "false-alarm rate (something named, nothing hidden): {false_alarms}/{nothing_n} = {:.1} %",
        100.0 * false_alarms as f64 / nothing_n.max(1) as f64
    );
    println!("final held-out RMS / estimated noise floor: mean {ge_mean:.3}, median {ge_med:.3}, max {ge_max:.3}; ≤ 1.25 in {:.1} % of cases", 100.0 * ge_in);
    println!("final held-out RMS / true noise floor √3σ:  mean {gt_mean:.3}, median {gt_med:.3}, max {gt_max:.3}; ≤ 1.25 in {:.1} % of cases", 100.0 * gt_in);
    if let Some((mean, med, max, within)) = hidden_stats {
        println!("  … of the cases with something hidden:    mean {mean:.3}, median {med:.3}, max {max:.3}; ≤ 1.25 in {:.1} % of cases", 100.0 * within);
    }
    println!(
        "seconds per case (diagnose only): median {:.2}, max {:.2}",
        secs[secs.len() / 2],
        secs[secs.len() - 1]
    );
}
