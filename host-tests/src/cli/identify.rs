//! `kinecal identify`: fits the model to measurements and reports residuals before and after.

use crate::data;
use crate::identify::{
    add_effect, fit_lm, named_values, split_holdout, EffectRequest, Fit, Residuals,
};
use crate::robot_file::{load_robot, RobotFile};
use crate::{with_joints, VCAP};
use anyhow::Context;
use kinecal::lm::LmConfig;
use kinecal::param::ParamSet;
use kinecal::{Measurement, Robot};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Identification method.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Levenberg–Marquardt from the nominal model.
    Lm,
    /// Particle swarm over the 24 MDH deltas (Gao et al. 2018 §3.1).
    Pso,
    /// PSO seeded by a BP network trained on a previous PSO run of the same robot (§3.2).
    #[value(name = "bpnn-pso")]
    BpnnPso,
    /// Global PSO search, then an LM polish of the full parameter set.
    #[value(name = "pso+lm")]
    PsoLm,
}

impl Method {
    pub fn id(self) -> &'static str {
        match self {
            Method::Lm => "lm",
            Method::Pso => "pso",
            Method::BpnnPso => "bpnn-pso",
            Method::PsoLm => "pso+lm",
        }
    }
}

/// Arguments of `kinecal identify` (see interfaces.md §4).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot description (TOML); without `[base]` the base pose is estimated too.
    #[arg(long)]
    pub robot: PathBuf,
    /// Measurements (CSV: q1…qN, x, y, z).
    #[arg(long)]
    pub data: PathBuf,
    #[arg(long, value_enum, default_value = "lm")]
    pub method: Method,
    /// Hold out the last poses for validation: a fraction (< 1) or a count (≥ 1).
    #[arg(long, conflicts_with = "validate")]
    pub holdout: Option<f64>,
    /// Validate on a separate measurement file.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Add a joint correction to the model: KIND:JOINT[:ARG] (ARG: cyclic order, or table knot
    /// spacing in degrees, default 3.6). Repeatable.
    #[arg(long = "effect")]
    pub effects: Vec<EffectRequest>,
    /// Seed of the stochastic methods.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the identified model (robot TOML).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: &Args, json: bool) -> anyhow::Result<serde_json::Value> {
    let n = RobotFile::load(&args.robot)?.joint_count();
    with_joints!(n, N => run_n::<N>(args, json))
}

fn run_n<const N: usize>(args: &Args, json: bool) -> anyhow::Result<serde_json::Value> {
    let (file, mut nominal) = load_robot::<N>(&args.robot)?;
    let all = data::load::<N>(&args.data)?.measurements::<f64>();
    let (ident, valid) = match (&args.validate, args.holdout) {
        (Some(v), _) => (all, data::load::<N>(v)?.measurements::<f64>()),
        (None, Some(h)) => split_holdout(&all, h)?,
        (None, None) => (all, Vec::new()),
    };
    anyhow::ensure!(
        !ident.is_empty(),
        "{}: no measurements",
        args.data.display()
    );
    let base_unknown = !file.base_known();
    if base_unknown {
        let base =
            crate::registration::fit_base(&nominal, &ident).context("estimating the base pose")?;
        nominal
            .set_base(base)
            .map_err(|e| anyhow::anyhow!("estimated base pose is invalid: {e:?}"))?;
    }
    // Effects requested on the command line join the model with zero values.
    let mut extra = Vec::new();
    for t in file.tilt_joints() {
        extra.push(kinecal::Param::Beta(t as u8));
    }
    for req in &args.effects {
        let range = joint_range(&ident, req.joint);
        extra.extend(add_effect(&mut nominal, req, range)?);
    }
    let before = Residuals::of(&nominal, &ident, &valid);
    let t0 = Instant::now();
    let fit = match args.method {
        Method::Lm => {
            let mut params: Vec<kinecal::Param> = ParamSet::<64>::full(N, base_unknown)
                .map_err(|e| anyhow::anyhow!("{e:?}"))?
                .as_slice()
                .to_vec();
            params.extend(existing_effect_params(&nominal, &params));
            params.extend(extra.iter().copied());
            params.dedup();
            fit_lm(&nominal, &params, &ident, LmConfig::default())?
        }
        m => crate::global::identify(m, &nominal, base_unknown, &extra, &ident, args.seed)?,
    };
    let seconds = t0.elapsed().as_secs_f64();
    let after = Residuals::of(&fit.robot, &ident, &valid);
    if let Some(out) = &args.out {
        let f = RobotFile::from_robot(
            &format!("{} (identified)", file.name),
            &fit.robot,
            true,
            &file.tilt_joints(),
        );
        f.save(out)?;
    }
    let report = report(
        args.method,
        &file,
        &fit,
        &ident,
        &valid,
        before,
        after,
        seconds,
    );
    if !json {
        print_human(&report);
    }
    Ok(report)
}

/// Parameters of effects the model file already carries (identified along with the geometry).
fn existing_effect_params<const N: usize>(
    robot: &Robot<f64, N, VCAP>,
    have: &[kinecal::Param],
) -> Vec<kinecal::Param> {
    (0..robot.effects().values().len())
        .map(|k| kinecal::Param::Effect(k as u16))
        .filter(|p| !have.contains(p))
        .collect()
}

/// (min, max) of joint `j` over the data, rad.
pub fn joint_range<const N: usize>(data: &[Measurement<f64, N>], j: usize) -> (f64, f64) {
    data.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
            (lo.min(m.q[j]), hi.max(m.q[j]))
        })
}

#[allow(clippy::too_many_arguments)]
fn report<const N: usize>(
    method: Method,
    file: &RobotFile,
    fit: &Fit<N, VCAP>,
    ident: &[Measurement<f64, N>],
    valid: &[Measurement<f64, N>],
    before: Residuals,
    after: Residuals,
    seconds: f64,
) -> serde_json::Value {
    let mut params: Vec<kinecal::Param> = ParamSet::<64>::full(N, true)
        .map(|s| s.as_slice().to_vec())
        .unwrap_or_default();
    params.extend(
        (0..N as u8)
            .map(kinecal::Param::Beta)
            .filter(|p| file.tilt_joints().contains(&(p.joint().unwrap_or(99)))),
    );
    params
        .extend((0..fit.robot.effects().values().len()).map(|k| kinecal::Param::Effect(k as u16)));
    json!({
        "method": method.id(),
        "n_identification": ident.len(),
        "n_validation": valid.len(),
        "before": before,
        "after": after,
        "iterations": fit.iterations,
        "evaluations": fit.evaluations,
        "seconds": seconds,
        "parameters": named_values(&fit.robot, &params),
        "unidentifiable": fit.unidentifiable,
        "fitness_history": fit.history,
    })
}

fn print_human(r: &serde_json::Value) {
    let f = |v: &serde_json::Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.4}"));
    println!(
        "method {}: {} identification poses, {} validation poses",
        r["method"].as_str().unwrap_or(""),
        r["n_identification"],
        r["n_validation"]
    );
    println!(
        "{:>8} {:>16} {:>16} {:>16} {:>16}",
        "", "ident RMS mm", "valid RMS mm", "valid mean mm", "valid max mm"
    );
    for k in ["before", "after"] {
        let o = &r[k];
        println!(
            "{:>8} {:>16} {:>16} {:>16} {:>16}",
            k,
            f(&o["identification_rms_mm"]),
            f(&o["validation_rms_mm"]),
            f(&o["validation_mean_mm"]),
            f(&o["validation_max_mm"])
        );
    }
    println!(
        "{} iterations, {} evaluations, {:.3} s",
        r["iterations"],
        r["evaluations"],
        r["seconds"].as_f64().unwrap_or(0.0)
    );
    if let Some(u) = r["unidentifiable"].as_array() {
        if !u.is_empty() {
            let names: Vec<&str> = u.iter().filter_map(|v| v.as_str()).collect();
            println!(
                "held at nominal (not identifiable from these data): {}",
                names.join(", ")
            );
        }
    }
}
