//! Global identification methods on the desktop: PSO, BPNN-PSO and PSO followed by an LM
//! polish, over the paper's MDH set (alpha, a, theta, d of every joint; base and tool fixed).

use crate::calibration::method::Method;
use crate::calibration::{fit_lm, Fit};
use kinecal::identify::bpnn::BpnnConfig;
use kinecal::identify::bpnn_pso::{self, MdhSeedNet};
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::lm::LmConfig;
use kinecal::identify::pso::{Pso, PsoConfig};
use kinecal::model::param::{apply_delta, Param, ParamSet};
use kinecal::{Measurement, Robot};

/// Swarm size of the paper (§3.1).
pub const SWARM: usize = 200;

/// The outcome of a PSO run: the fit plus the swarm's start and final personal bests, which
/// train the BPNN for the next identification of the same robot.
pub struct SwarmRun<const N: usize, V: kinecal::ValueStorage> {
    pub fit: Fit<N, V>,
    pub initial: Vec<Vec<f64>>,
    pub personal_bests: Vec<Vec<f64>>,
    pub best: Vec<f64>,
}

/// Runs PSO over the MDH deltas of `start` (geometry only; effects are not searched).
/// `init` optionally replaces the initial particle positions (BPNN-PSO's predictions).
pub fn pso_mdh<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    seed: u64,
    max_iterations: u32,
    init: Option<&[Vec<f64>]>,
) -> anyhow::Result<SwarmRun<N, V>> {
    macro_rules! go {
        ($d:literal) => {
            pso_with::<N, V, $d>(start, data, seed, max_iterations, init)
        };
    }
    match 4 * N {
        8 => go!(8),
        12 => go!(12),
        16 => go!(16),
        20 => go!(20),
        24 => go!(24),
        28 => go!(28),
        32 => go!(32),
        _ => anyhow::bail!("PSO supports 2 to 8 joints"),
    }
}

fn pso_with<const N: usize, V: kinecal::ValueStorage, const D: usize>(
    start: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    seed: u64,
    max_iterations: u32,
    init: Option<&[Vec<f64>]>,
) -> anyhow::Result<SwarmRun<N, V>> {
    let params = ParamSet::<D>::mdh(N).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    // The swarm evaluates geometry only: a copy without effect storage is cheaper to clone.
    let geometric: Robot<f64, N, kinecal::Inline<0>> = if start.effects().is_empty() {
        start
            .with_capacity::<kinecal::Inline<0>>()
            .map_err(|e| anyhow::anyhow!("{e:?}"))?
    } else {
        anyhow::bail!(
            "PSO searches geometry only; the model has effects (joint corrections, thermal \
             expansion or a drift): use lm"
        )
    };
    let mut cfg = PsoConfig::<f64, D>::calibration(params.as_slice())
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    cfg.max_iterations = max_iterations;
    let mut pso =
        Box::new(Pso::<f64, SWARM, D>::new(cfg, seed).map_err(|e| anyhow::anyhow!("{e:?}"))?);
    if let Some(init) = init {
        for (i, x) in init.iter().enumerate().take(SWARM) {
            let x: [f64; D] = x
                .as_slice()
                .try_into()
                .map_err(|_| anyhow::anyhow!("BPNN prediction has the wrong dimension"))?;
            let v = [0.0; D];
            pso.set_start(i, &x, &v)
                .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        }
    }
    // Joint sines and cosines once per pose, not once per particle: 3.7x faster iterations.
    let mut cache = vec![[(0.0, 0.0); N]; data.len()];
    let mut objective = PositionFitness::with_cache(&geometric, &params, data, &mut cache)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let bar = indicatif::ProgressBar::new(max_iterations as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("PSO {bar:40} {pos}/{len} iterations, best {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let p = loop {
        let p = pso
            .step(&mut objective, SWARM)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        bar.set_position(p.iteration as u64);
        bar.set_message(format!("{:.4e} mm²", p.best_fitness));
        if p.stopped.is_some() {
            break p;
        }
    };
    bar.finish_and_clear();
    let mut robot = start.clone();
    apply_delta(&mut robot, &params, pso.best_position()).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    Ok(SwarmRun {
        fit: Fit::plain(robot, p.iteration, p.evaluations, pso.history().to_vec()),
        initial: pso.initial_positions().iter().map(|x| x.to_vec()).collect(),
        personal_bests: pso.personal_bests().iter().map(|x| x.to_vec()).collect(),
        best: pso.best_position().to_vec(),
    })
}

/// `identify` with a global method. `lm_params` is what LM would estimate (the full set with
/// base, tool and effects, after `--fix`/`--free`).
///
/// PSO and BPNN-PSO search the paper's 24 MDH parameters only. Base and tool are not part of
/// that search, so when `lm_params` holds any of them (an unknown base, a tool to find) they
/// are fitted first by LM with the nominal geometry, and the swarm searches from there; a
/// note on stderr says so. Without that step an unknown base leaves the swarm metres from
/// anything it can reach (UR10: 4.24 mm where LM reaches 0.49).
pub fn identify<const N: usize, V: kinecal::ValueStorage>(
    method: Method,
    start: &Robot<f64, N, V>,
    lm_params: &[Param],
    data: &[Measurement<f64, N>],
    seed: u64,
) -> anyhow::Result<Fit<N, V>> {
    let frame_params: Vec<Param> = lm_params
        .iter()
        .copied()
        .filter(|p| p.is_base() || p.is_tool())
        .collect();
    let framed = |what: &str| -> anyhow::Result<Robot<f64, N, V>> {
        if frame_params.is_empty() || method == Method::PsoLm {
            return Ok(start.clone());
        }
        let names: Vec<String> = frame_params
            .iter()
            .map(|p| p.name(start).to_string())
            .collect();
        eprintln!(
            "note: {what} searches the 24 MDH parameters only; {} were fitted first by LM with \
             the nominal geometry and stay fixed during the search (use --method pso+lm or lm \
             to estimate everything together)",
            names.join(", ")
        );
        Ok(fit_lm(start, &frame_params, data, LmConfig::default())?.robot)
    };
    match method {
        Method::Pso => Ok(pso_mdh(&framed("pso")?, data, seed, 1000, None)?.fit),
        Method::PsoLm => {
            let run = pso_mdh(start, data, seed, 1000, None)?;
            let mut polished = fit_lm(&run.fit.robot, lm_params, data, LmConfig::default())?;
            polished.iterations += run.fit.iterations;
            polished.evaluations += run.fit.evaluations;
            let mut history = run.fit.history.clone();
            history.extend(polished.history.iter().copied());
            polished.history = history;
            Ok(polished)
        }
        Method::BpnnPso => {
            // On the command line there is no earlier identification to learn from: a first
            // ("factory") PSO run on the same data trains the network, as in the paper's
            // procedure; `kinecal demo` shows the follow-up case where that pays off.
            let start = framed("bpnn-pso")?;
            let factory = pso_mdh(&start, data, seed ^ 0xfac7, 1000, None)?;
            let net = train_bpnn(&factory, seed)?;
            Ok(bpnn_pso_mdh(&net, &start, data, seed, 1000)?.fit)
        }
        Method::Lm => fit_lm(start, lm_params, data, LmConfig::default()),
    }
}

/// Trains the paper's 24 → 12 → 24 network on a finished 6-joint PSO run (each particle's
/// initial position → its final personal best; see `kinecal::identify::bpnn_pso`).
pub fn train_bpnn<const N: usize, V: kinecal::ValueStorage>(
    run: &SwarmRun<N, V>,
    seed: u64,
) -> anyhow::Result<Box<MdhSeedNet<f64>>> {
    anyhow::ensure!(
        N == 6 && run.initial.len() == SWARM,
        "BPNN-PSO is built for the 24 MDH parameters of a 6-joint arm"
    );
    let mut net = Box::new(
        MdhSeedNet::<f64>::new(BpnnConfig::default(), seed)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?,
    );
    let to24 = |v: &Vec<f64>| -> anyhow::Result<[f64; 24]> {
        v.as_slice()
            .try_into()
            .map_err(|_| anyhow::anyhow!("dimension"))
    };
    let inputs: Vec<[f64; 24]> = run
        .initial
        .iter()
        .map(to24)
        .collect::<anyhow::Result<_>>()?;
    let targets: Vec<[f64; 24]> = run
        .personal_bests
        .iter()
        .map(to24)
        .collect::<anyhow::Result<_>>()?;
    net.fit_ranges(&inputs, &targets)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    for _ in 0..bpnn_pso::DEFAULT_EPOCHS {
        net.train_epoch(&inputs, &targets)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    }
    Ok(net)
}

/// BPNN-PSO: a fresh swarm (same draws as plain PSO with this seed) whose particles start at
/// the network's predictions, then the unchanged PSO.
pub fn bpnn_pso_mdh<const N: usize, V: kinecal::ValueStorage>(
    net: &MdhSeedNet<f64>,
    start: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    seed: u64,
    max_iterations: u32,
) -> anyhow::Result<SwarmRun<N, V>> {
    anyhow::ensure!(
        N == 6,
        "BPNN-PSO is built for the 24 MDH parameters of a 6-joint arm"
    );
    let params = ParamSet::<24>::mdh(N).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let mut cfg = PsoConfig::<f64, 24>::calibration(params.as_slice())
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    cfg.max_iterations = max_iterations;
    let mut swarm =
        Box::new(Pso::<f64, SWARM, 24>::new(cfg, seed).map_err(|e| anyhow::anyhow!("{e:?}"))?);
    bpnn_pso::seed(&mut swarm, net).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let init: Vec<Vec<f64>> = swarm.positions().iter().map(|x| x.to_vec()).collect();
    pso_mdh(start, data, seed, max_iterations, Some(&init))
}
