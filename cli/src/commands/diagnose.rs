//! `kinecal diagnose`: the discrepancy workflow (see [`crate::diagnose`]): fits the geometry,
//! finds where model and data disagree, names the missing effects, adds them and shows the
//! held-out gap shrink.

use crate::calibration::split_holdout;
use crate::diagnose::candidates::CandidateKind;
use crate::diagnose::penalised_fit::squared_errors;
use crate::diagnose::{
    diagnose, distinct_figures, floor_phrase, percent, Config, Diagnosis, NoiseSource,
};
use crate::formats::robot_file::{load_robot, RobotFile};
use crate::output::numfmt::sig;
use crate::with_joints;
use kinecal::Measurement;
use serde_json::{json, Value};
use std::path::PathBuf;

/// Arguments of `kinecal diagnose` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot description (TOML); without `[base]` the base pose is estimated too.
    #[arg(long)]
    pub robot: PathBuf,
    /// Measurements (CSV: q1…qN, x, y, z).
    #[arg(long)]
    pub data: PathBuf,
    /// Seed of the cross-validation folds.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write the extended model (robot TOML with its effects).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write SVG plots (residuals against each named effect, per-pose errors) into this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Also keep the last poses out of the whole search and report the errors on them: a
    /// fraction (< 1) or a count (≥ 1).
    #[arg(long, conflicts_with = "validate")]
    pub holdout: Option<f64>,
    /// Also report the errors on a separate measurement file.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Cross-validation folds.
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Family-wise false-alarm rate of each round.
    #[arg(long, default_value_t = 0.05)]
    pub alpha: f64,
    /// Highest joint-cyclic order in the catalogue.
    #[arg(long, default_value_t = 3)]
    pub max_order: u16,
    /// Most effects to add.
    #[arg(long, default_value_t = 12)]
    pub max_effects: usize,
    /// A geometric fit whose held-out RMS stays above this has not found the robot (units, a
    /// coupled joint, the tool, the base): nothing is diagnosed from it and the command exits 3.
    #[arg(long, default_value_t = 5.0)]
    pub stall_rms_mm: f64,
    /// Units of the data and --validate files (never second-guessed when given).
    #[command(flatten)]
    pub units: crate::formats::units::UnitArgs,
}

pub fn run(args: &Args, json: bool) -> anyhow::Result<Value> {
    crate::output::atomic::refuse_model_over_inputs(
        args.out.as_deref(),
        &args.robot,
        &args.data,
        args.validate.as_deref(),
    )?;
    let n = RobotFile::load(&args.robot)?.joint_count();
    with_joints!(n, N => run_n::<N>(args, json))
}

fn run_n<const N: usize>(args: &Args, json: bool) -> anyhow::Result<Value> {
    let (file, nominal) = load_robot::<N>(&args.robot)?;
    let load = |p: &std::path::Path| {
        crate::formats::units::load_measurements(p, &args.units, &nominal, file.base_known())
            .map(|d| d.measurements::<f64>())
    };
    let all = load(&args.data)?;
    anyhow::ensure!(!all.is_empty(), "{}: no measurements", args.data.display());
    let (search, held) = match (&args.validate, args.holdout) {
        (Some(v), _) => (all, load(v)?),
        (None, Some(h)) => split_holdout(&all, h)?,
        (None, None) => (all, Vec::new()),
    };
    anyhow::ensure!(args.folds >= 2, "--folds must be at least 2");
    anyhow::ensure!(
        args.alpha > 0.0 && args.alpha < 1.0,
        "--alpha must be between 0 and 1"
    );
    anyhow::ensure!(args.max_order >= 1, "--max-order must be at least 1");
    let mut cfg = Config {
        folds: args.folds,
        alpha: args.alpha,
        max_effects: args.max_effects,
        seed: args.seed,
        ..Config::default()
    };
    cfg.catalogue.max_cyclic_order = args.max_order;
    let mut d = diagnose(
        &nominal,
        file.base_known(),
        &file.tilt_joints(),
        &search,
        &cfg,
    )?;
    let mut holdout = None;
    if !held.is_empty() {
        let rms = |sq: Vec<f64>| (sq.iter().sum::<f64>() / sq.len() as f64).sqrt();
        // The starting model as the search fitted it (the same fit as the final model when
        // nothing is added), and the final model.
        let baseline = rms(squared_errors(&d.baseline_model, &held));
        let fin = rms(squared_errors(&d.model, &held));
        let capped = d.cap_noise_floor(fin);
        holdout = Some(json!({
            "poses": held.len(),
            "geometric_rms_mm": baseline,
            "final_rms_mm": fin,
            "noise_floor_capped": capped,
        }));
    }
    let mut report = report(&d);
    if let Some(h) = holdout {
        report["holdout"] = h;
    }
    report["poses"] = json!(search.len());
    // A geometric model that cannot reach the data is not "missing an effect": the data or the
    // model are wrong, and a noise floor of metres is no finding (interfaces.md §4: exit 3).
    let fitted = d.baseline_validation_rms_mm.is_finite()
        && d.baseline_validation_rms_mm <= args.stall_rms_mm;
    report["converged"] = json!(fitted);
    if !fitted {
        eprintln!(
            "error: the geometric model does not fit the data (held-out RMS {} mm, above \
             --stall-rms-mm {}): check the units (--length-unit, --angle-unit), coupled joints \
             ([[couplings]], see `kinecal check`), the tool and the base; nothing is diagnosed \
             (exit 3)",
            sig(d.baseline_validation_rms_mm, 4),
            sig(args.stall_rms_mm, 3)
        );
    }
    if let Some(out) = &args.out {
        let f = RobotFile::from_robot(
            &format!("{} (diagnosed)", file.name),
            &d.model,
            true,
            &d.free_tilt,
        );
        f.save(out)?;
        report["out"] = json!(out.display().to_string());
    }
    if let Some(dir) = &args.plots {
        let files = crate::diagnose::residual_plots::write_all(dir, &d, &search)?;
        report["plots"] = json!(files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>());
    }
    if !json {
        print_human(&report, &d, &search);
    }
    Ok(report)
}

/// The JSON report (keys of interfaces.md §4 plus the reasoning behind them).
pub fn report<const N: usize>(d: &Diagnosis<N>) -> Value {
    let found: Vec<Value> = d
        .found
        .iter()
        .map(|f| {
            let c = &f.candidate;
            let mut o = json!({
                "effect": c.id(),
                "joint": c.joint + 1,
                "values": c.values(&d.model),
                "validation_rms_mm": f.validation_rms_mm,
                "before_validation_rms_mm": f.before_rms_mm,
                "p_value": f.test.p,
                "p_threshold": f.threshold,
                "candidates_compared": f.candidates_compared,
                "sentence": f.sentence(d.noise_floor_mm),
            });
            match c.kind {
                CandidateKind::Cyclic(n) => o["order"] = json!(n),
                CandidateKind::Table { start, step, knots } => {
                    o["step_deg"] = json!(step.to_degrees());
                    o["start_deg"] = json!(start.to_degrees());
                    o["knots"] = json!(knots);
                }
                _ => {}
            }
            o
        })
        .collect();
    let rounds: Vec<Value> = d
        .rounds
        .iter()
        .map(|r| {
            json!({
                "start_validation_rms_mm": r.start_rms_mm,
                "candidates": r.screened.len(),
                "p_threshold": r.threshold,
                "screen_best": r.screened.iter().take(5).map(|s| json!({"candidate": s.candidate.label(), "linearised_validation_rms_mm": s.linear_rms_mm})).collect::<Vec<_>>(),
                "refitted": r.tested.iter().map(|t| json!({"candidate": t.candidate.label(), "validation_rms_mm": t.validation_rms_mm, "p_value": t.test.p})).collect::<Vec<_>>(),
                "added": r.chosen.map(|i| r.tested[i].candidate.label()),
                "seconds": r.seconds,
            })
        })
        .collect();
    let sentences: Vec<String> = d
        .found
        .iter()
        .map(|f| f.sentence(d.noise_floor_mm))
        .collect();
    json!({
        "baseline_validation_rms_mm": d.baseline_validation_rms_mm,
        "found": found,
        "final_validation_rms_mm": d.final_validation_rms_mm,
        "noise_floor_mm": d.noise_floor_mm,
        "noise_floor_source": match d.noise_source { NoiseSource::RepeatedPoses => "repeated poses", NoiseSource::HeldOut => "held-out errors of the final model less the fold fits' share, sum |r|^2 / (3n + sum tr B_f)" },
        "noise_floor_interval_mm": d.noise_floor_interval_mm,
        "noise_floor_dof": d.noise_dof,
        "noise_sigma_mm": d.noise_sigma_mm,
        "summary": summary(d),
        "sentences": sentences,
        "folds": d.folds.k,
        "fit_rms_mm": d.fit_rms_mm,
        "effective_parameters": d.effective_parameters,
        "unidentifiable": d.unidentifiable.iter().map(|p| p.name(&d.geometric).to_string()).collect::<Vec<_>>(),
        "stop_reason": d.stop_reason,
        "rounds": rounds,
        "geometry_seconds": d.geometry_seconds,
        "seconds": d.seconds,
    })
}

/// The headline: what is missing, or that nothing is.
pub fn summary<const N: usize>(d: &Diagnosis<N>) -> String {
    let [base, fin, floor] = distinct_figures([
        d.baseline_validation_rms_mm,
        d.final_validation_rms_mm,
        d.noise_floor_mm,
    ]);
    let floor = floor_phrase(d.noise_floor_mm, &floor);
    if d.found.is_empty() {
        // Why nothing was added: the test found nothing, or the search did not get to test.
        let why = if d.rounds.is_empty() {
            format!("no candidate was tested: {}", d.stop_reason)
        } else {
            format!(
                "no candidate improved the held-out error at the {} % family-wise level",
                percent(d.alpha)
            )
        };
        format!("Nothing significant is missing from the model: held-out RMS {base} mm, {floor} ({why}).")
    } else {
        format!(
            "{} effect(s) missing from the model: held-out RMS {base} → {fin} mm, {floor}.",
            d.found.len(),
        )
    }
}

fn print_human<const N: usize>(r: &Value, d: &Diagnosis<N>, data: &[Measurement<f64, N>]) {
    println!("{} poses, {}-fold cross-validation", data.len(), d.folds.k);
    if r["converged"] == false {
        println!(
            "The geometric model does not fit these data (held-out RMS {} mm): nothing can be \
             diagnosed until the units, couplings, tool or base are right.",
            sig(d.baseline_validation_rms_mm, 4)
        );
        return;
    }
    println!("{}", summary(d));
    for (k, f) in d.found.iter().enumerate() {
        println!("  {}. {}", k + 1, f.sentence(d.noise_floor_mm));
    }
    if d.noise_floor_mm.is_finite() {
        let [floor, lo, hi] = distinct_figures([
            d.noise_floor_mm,
            d.noise_floor_interval_mm[0],
            d.noise_floor_interval_mm[1],
        ]);
        let interval = if d.noise_floor_interval_mm.iter().all(|x| x.is_finite()) {
            format!(" (approximately 95 % within {lo}–{hi} mm)")
        } else {
            String::new()
        };
        let source = match d.noise_source {
            NoiseSource::RepeatedPoses => "from the scatter of the repeated poses",
            NoiseSource::HeldOut => {
                "from the held-out errors less what the fold fits add to them (it also holds whatever the model still misses)"
            }
        };
        println!("noise floor {floor} mm{interval}, {source}");
    }
    println!("stopped: {}", d.stop_reason);
    if let Some(h) = r.get("holdout") {
        let g = h["geometric_rms_mm"].as_f64().unwrap_or(f64::NAN);
        let f = h["final_rms_mm"].as_f64().unwrap_or(f64::NAN);
        if d.found.is_empty() {
            // One model: nothing was added to the starting model as refitted.
            println!(
                "held-out poses ({}): {} mm with the starting model refitted (nothing added)",
                h["poses"],
                sig(g, 4)
            );
        } else {
            let [g, f] = distinct_figures([g, f]);
            println!(
                "held-out poses ({}): starting model refitted {g} mm → extended model {f} mm",
                h["poses"]
            );
        }
        if h["noise_floor_capped"].as_bool() == Some(true) {
            println!(
                "  (the noise floor above is lowered to the RMS these poses reached: their errors are the noise plus the model's, so the noise is no larger)"
            );
        }
    }
    println!("{:.2} s", d.seconds);
}
