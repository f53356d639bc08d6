//! One case: data with its hidden effects scaled to the noise floor, the diagnosis, what it named.

use super::*;
use kinecal::Param;
use kinecal_cli::diagnose::candidates::{Candidate, CandidateKind};
use kinecal_cli::diagnose::plausibility::{implausible, Limits};

pub fn sim<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    noise: f64,
    seed: u64,
    effects: Vec<EffectArg>,
) -> Vec<Measurement<f64, N>> {
    let s = Simulation {
        poses,
        noise_mm: noise,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects,
    };
    simulate(&l.sim_nominal, &s).unwrap().1.measurements()
}

/// RMS (mm) a geometric refit leaves of noiseless data with `effects`.
pub fn unexplained<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    seed: u64,
    effects: Vec<EffectArg>,
) -> f64 {
    let data = sim(l, poses, 0.0, seed, effects);
    let (fitted, _) = fit_geometry(&l.nominal, l.base_known, &[], &data).unwrap();
    kinecal::identify::lm::rms_error(&fitted, &data)
}

/// The data of a case: each hidden effect scaled so that what the geometry cannot absorb has an
/// RMS of `amplitude` noise floors; and which of the hidden effects (indices into `c.hidden`)
/// are then beyond the sizes the search accepts ([`Limits`]): a wrist joint that needs 1.3° of
/// deflection per metre, or a table of 5.3° peak to peak, to move the tool by ten noise floors.
pub fn make_data<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    c: &Case,
) -> (Vec<Measurement<f64, N>>, Vec<usize>, Vec<EffectArg>) {
    let effects = match &c.raw {
        Some(raw) => raw.clone(),
        None => {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(c.seed ^ 0xeff);
            let floor = 3f64.sqrt() * c.noise_mm;
            let mut effects = Vec::new();
            for h in &c.hidden {
                let j = l.nominal.joints()[h.joint - 1];
                let mut e = h.unit(&mut rng, j.lower, j.upper);
                let u = unexplained(l, poses, c.seed, vec![e.clone()]);
                let k = c.amplitude * floor / u.max(1e-9);
                e.values.iter_mut().for_each(|v| *v *= k);
                effects.push(e);
            }
            effects
        }
    };
    let beyond = effects
        .iter()
        .enumerate()
        .filter(|(_, e)| beyond_limits(e))
        .map(|(i, _)| i)
        .collect();
    (
        sim(l, poses, c.noise_mm, c.seed, effects.clone()),
        beyond,
        effects,
    )
}

/// Poses of a fresh session of the same robot and effects as a case's data: the next poses of
/// the same streams (configurations and noise are drawn pose by pose, so the first `poses` of
/// a longer simulation are the case's own).
pub const FRESH_POSES: usize = 2000;

/// `FRESH_POSES` poses of the case's robot and effects that the search never saw.
fn fresh_poses<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    c: &Case,
    effects: &[EffectArg],
) -> Vec<Measurement<f64, N>> {
    let mut all = sim(l, poses + FRESH_POSES, c.noise_mm, c.seed, effects.to_vec());
    all.split_off(poses)
}

/// The RMS error (mm) of a model on fresh poses.
fn fresh_rms<const N: usize>(
    fresh: &[Measurement<f64, N>],
    model: &kinecal_cli::HostRobot<N>,
) -> f64 {
    kinecal::identify::lm::rms_error(model, fresh)
}

/// The true effects on their true grids, fitted with the search's geometry parameters (and the
/// nominal model's own effects): their cross-validated held-out RMS (mm) on the search's folds,
/// a reference for what the right structure reaches on these folds, and the fitted model
/// (`None` when a hidden effect is not a grid table, a compliance or a scale).
fn oracle<const N: usize>(
    d: &Diagnosis<N>,
    data: &[Measurement<f64, N>],
    effects: &[EffectArg],
) -> Option<(f64, kinecal_cli::HostRobot<N>)> {
    use kinecal_cli::diagnose::cross_validation::{refit_errors, rms, Folds};
    use kinecal_cli::diagnose::linear::Problem;
    let cfg = Config::default();
    let mut robot = d.geometric.clone();
    // The search's geometry parameters and the nominal model's effects (the named effects'
    // values come after those).
    let own = d.geometric.effects().values().len();
    let mut params: Vec<Param> = d
        .params
        .iter()
        .copied()
        .filter(|p| !matches!(p, Param::Effect(k) if *k as usize >= own))
        .collect();
    for e in effects {
        let kind = match (e.kind.as_str(), e.grid) {
            ("joint-table", Some((start, step))) => CandidateKind::Table {
                start,
                step,
                knots: e.values.len(),
            },
            ("joint-compliance", _) => CandidateKind::Compliance,
            ("joint-scale", _) => CandidateKind::Scale,
            _ => return None,
        };
        let c = Candidate {
            kind,
            joint: e.joint,
        };
        params.extend(c.add_to(&mut robot).ok()?);
    }
    let problem = Problem::new(&robot, &params, cfg.penalty).ok()?;
    let fitted = kinecal_cli::diagnose::refit::fit(&robot, &problem, data, cfg.refit_iterations)
        .ok()?
        .robot;
    let folds = Folds::new(data, cfg.folds, cfg.seed);
    let errors = refit_errors(&fitted, &problem, data, &folds, cfg.refit_iterations).ok()?;
    Some((rms(&errors), fitted))
}

/// Whether `e` at its true size is beyond the plausibility limits (the search judges its fitted
/// size, which may come in on the other side of a limit).
fn beyond_limits(e: &EffectArg) -> bool {
    let kind = match e.kind.as_str() {
        "joint-table" => CandidateKind::Table {
            start: 0.0,
            step: 1.0,
            knots: e.values.len(),
        },
        "joint-cyclic" => CandidateKind::Cyclic(e.order),
        "joint-scale" => CandidateKind::Scale,
        "joint-compliance" => CandidateKind::Compliance,
        _ => return false,
    };
    let c = Candidate {
        kind,
        joint: e.joint,
    };
    implausible(&c, &e.values, &Limits::default()).is_some()
}

pub struct Outcome {
    pub named: Vec<String>,
    /// The plausible hidden effects named exactly, nothing else, and the others refused.
    pub exact: bool,
    /// The hidden effects beyond the plausibility limits.
    pub beyond: Vec<String>,
    pub final_rms: f64,
    pub baseline_rms: f64,
    pub floor_est: f64,
    pub floor_true: f64,
    pub seconds: f64,
    /// The smallest relative drop of the held-out RMS that an added effect gave (1 when none
    /// was added).
    pub least_gain: f64,
    /// Why the search stopped, when a significant candidate was too small to be added.
    pub too_small: Option<String>,
    /// The final model's RMS (mm) on fresh poses of the same robot (never seen by the search).
    pub fresh_rms: Option<f64>,
    /// The true effects on their true grids (when they are grid tables, compliances or
    /// scales), fitted with the search's geometry: their cross-validated held-out RMS (mm) on
    /// the search's folds, and their RMS on the fresh poses.
    pub oracle: Option<(f64, f64)>,
}

pub fn named<const N: usize>(d: &Diagnosis<N>) -> Vec<Hidden> {
    d.found
        .iter()
        .map(|f| {
            use kinecal_cli::diagnose::candidates::CandidateKind;
            let (arg, grid) = match f.candidate.kind {
                CandidateKind::Cyclic(n) => (n as usize, None),
                CandidateKind::Table { start, step, knots } => {
                    let (start, step) = (start.to_degrees(), step.to_degrees());
                    let phase = start.rem_euclid(step);
                    let phase = if step - phase < 1e-6 { 0.0 } else { phase };
                    (knots, Some((step, phase)))
                }
                _ => (0, None),
            };
            Hidden {
                kind: f.candidate.id().to_string(),
                joint: f.candidate.joint + 1,
                arg,
                grid,
            }
        })
        .collect()
}

/// Named exactly: the same kinds on the same joints (cyclic: the same order), nothing else.
/// A table on a fixed grid is a `joint-table` like any other (its grid is not compared).
pub fn exact(hidden: &[Hidden], found: &[Hidden]) -> bool {
    let key = |h: &Hidden| {
        (
            h.kind.clone(),
            h.joint,
            if h.kind == "joint-cyclic" { h.arg } else { 0 },
        )
    };
    let mut a: Vec<_> = hidden.iter().map(key).collect();
    let mut b: Vec<_> = found.iter().map(key).collect();
    a.sort();
    b.sort();
    a == b
}

pub fn run_case<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    c: &Case,
    against_truth: bool,
) -> Outcome {
    let (data, beyond, effects) = make_data(l, poses, c);
    let fresh = if against_truth {
        fresh_poses(l, poses, c, &effects)
    } else {
        Vec::new()
    };
    let t = Instant::now();
    let d = diagnose(&l.nominal, l.base_known, &[], &data, &Config::default()).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    if std::env::var("KINECAL_MATRIX_VERBOSE").is_ok() {
        let r = kinecal_cli::reports::diagnose::DiagnoseReport::of(&d).to_value();
        eprintln!("{}", serde_json::to_string_pretty(&r).unwrap());
    }
    let found = named(&d);
    let refused: Vec<Candidate> = d
        .rounds
        .iter()
        .filter(|r| r.refused.is_some())
        .filter_map(|r| Some(r.tested.get(r.chosen?)?.candidate))
        .collect();
    // An effect beyond the limits must be refused (its family, kind and joint), and the others
    // named exactly.
    let plausible: Vec<Hidden> = (0..c.hidden.len())
        .filter(|i| !beyond.contains(i))
        .map(|i| c.hidden[i].clone())
        .collect();
    let all_refused = beyond.iter().all(|&i| {
        let h = &c.hidden[i];
        refused
            .iter()
            .any(|r| r.id() == h.kind && r.joint + 1 == h.joint)
    });
    Outcome {
        named: found.iter().map(|h| h.label()).collect(),
        exact: exact(&plausible, &found) && all_refused,
        beyond: beyond.iter().map(|&i| c.hidden[i].label()).collect(),
        final_rms: d.final_validation_rms_mm,
        baseline_rms: d.baseline_validation_rms_mm,
        floor_est: d.noise_floor_mm,
        floor_true: 3f64.sqrt() * c.noise_mm,
        seconds,
        least_gain: d
            .found
            .iter()
            .map(|f| 1.0 - f.validation_rms_mm / f.before_rms_mm)
            .fold(1.0, f64::min),
        too_small: d.below_margin.map(|_| d.stop_reason.clone()),
        fresh_rms: against_truth.then(|| fresh_rms(&fresh, &d.model)),
        oracle: against_truth
            .then(|| oracle(&d, &data, &effects))
            .flatten()
            .map(|(cv, fitted)| (cv, fresh_rms(&fresh, &fitted))),
    }
}

pub fn all_cases(m: &Matrix) -> Vec<Case> {
    let mut cases = Vec::new();
    let mut seed = m.seed_base;
    for (ri, rc) in m.robots.iter().enumerate() {
        let mut sets: Vec<Vec<Hidden>> =
            rc.effects.iter().map(|e| vec![Hidden::parse(e)]).collect();
        sets.extend(
            rc.pairs
                .iter()
                .map(|p| p.iter().map(|e| Hidden::parse(e)).collect()),
        );
        for hidden in sets {
            for &noise in &m.noise_mm {
                for &amp in &m.amplitudes {
                    seed += 1;
                    cases.push(Case {
                        robot: ri,
                        hidden: hidden.clone(),
                        noise_mm: noise,
                        amplitude: amp,
                        seed,
                        raw: None,
                    });
                }
            }
        }
        for &noise in &m.noise_mm {
            for _ in 0..m.nothing_seeds {
                seed += 1;
                cases.push(Case {
                    robot: ri,
                    hidden: Vec::new(),
                    noise_mm: noise,
                    amplitude: 0.0,
                    seed,
                    raw: None,
                });
            }
        }
    }
    for rc in &m.raw {
        let ri = m
            .robots
            .iter()
            .position(|r| r.name == rc.robot)
            .unwrap_or_else(|| panic!("raw case: no robot {}", rc.robot));
        let effects: Vec<EffectArg> = rc.effects.iter().map(|e| e.parse().unwrap()).collect();
        let hidden = effects
            .iter()
            .map(|e| Hidden {
                kind: e.kind.clone(),
                joint: e.joint + 1,
                arg: if e.kind == "joint-cyclic" {
                    e.order as usize
                } else {
                    e.values.len()
                },
                grid: None,
            })
            .collect::<Vec<_>>();
        for _ in 0..rc.seeds {
            seed += 1;
            cases.push(Case {
                robot: ri,
                hidden: hidden.clone(),
                noise_mm: rc.noise_mm,
                amplitude: f64::NAN,
                seed,
                raw: Some(effects.clone()),
            });
        }
    }
    cases
}

pub fn describe(m: &Matrix, c: &Case) -> String {
    let h: Vec<String> = match &c.raw {
        Some(raw) => raw
            .iter()
            .map(|e| format!("{}:{}:{:?}", e.kind, e.joint + 1, e.values))
            .collect(),
        None => c.hidden.iter().map(|h| h.label()).collect(),
    };
    format!(
        "{:6} seed {:5} noise {:.3} amp {:>4}  hidden [{}]",
        m.robots[c.robot].name,
        c.seed,
        c.noise_mm,
        if c.amplitude.is_nan() {
            "raw".to_string()
        } else {
            format!("{:.0}", c.amplitude)
        },
        if h.is_empty() {
            "nothing".into()
        } else {
            h.join(" + ")
        }
    )
}
