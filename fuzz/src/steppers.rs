//! The LM, PSO and BPNN steppers on degenerate data: few, duplicate or collinear poses,
//! NaN-free but extreme values, odd budgets, bad calls in between.
//!
//! Invariants:
//! - `no-panic`;
//! - `stays-finite`: the LM's robot, the swarm and the net stay finite after every call,
//!   whatever it returned (fitness may be +∞, never NaN);
//! - `recovers-after-error`: after a refused call (changed data, too few poses) the stepper
//!   still steps on valid data;
//! - `terminates`: an LM run with at most 10 iterations stops within a bounded number of calls;
//! - `pso-monotone`: the swarm's best fitness never rises; its best position stays in the box;
//! - `bpnn-diverged-restores`: a `Diverged` epoch leaves the net as it was.

use super::{finite_f64, invariant, near, robot_finite, VecWriter};
use arbitrary::Unstructured;
use kinecal::identify::bpnn::{Bpnn, BpnnConfig, BpnnError};
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::lm::{FixedLevenberg, LmConfig};
use kinecal::identify::pso::{Pso, PsoConfig};
use kinecal::io::snapshot::Snapshot;
use kinecal::model::param::{Param, ParamSet};
use kinecal::Measurement;
use nalgebra::Vector3;

const N: usize = 3;

fn degenerate(u: &mut Unstructured) -> Vec<Measurement<f64, N>> {
    let truth = super::perturbed(&super::arm3::<kinecal::Inline<4>>());
    let n = u.int_in_range(1..=10usize).unwrap_or(1);
    let mode = u.int_in_range(0..=3u8).unwrap_or(0);
    let mut out = Vec::new();
    for k in 0..n {
        let q: [f64; N] = match mode {
            0 => [0.1, 0.2, 0.3],               // duplicates
            1 => [near(u, 0.0, 3.0), 0.2, 0.3], // one joint moves: points on a circle
            2 => std::array::from_fn(|_| near(u, 0.0, 3.0)),
            _ => std::array::from_fn(|_| finite_f64(u, 0.0, 3.0)), // extreme readings
        };
        let mut p = kinecal::forward::point(&truth, &q);
        if u.ratio(1u8, 4).unwrap_or(false) {
            p = Vector3::new(
                finite_f64(u, p.x, 10.0),
                finite_f64(u, p.y, 10.0),
                finite_f64(u, p.z, 10.0),
            );
        }
        if !p.iter().all(|x| x.is_finite()) {
            p = Vector3::new(k as f64, 0.0, 0.0);
        }
        out.push(Measurement::new(q, p));
    }
    out
}

fn net_state(n: &Bpnn<f64, 3, 4, 3>) -> Vec<u8> {
    let mut w = VecWriter::default();
    n.save(&mut w).unwrap();
    w.0
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let meas = degenerate(&mut u);
    match u.int_in_range(0..=2u8).unwrap_or(0) {
        0 => {
            // Fields in this order: each draws from the input in turn.
            let cfg = LmConfig::<f64> {
                max_iterations: u.int_in_range(0..=10u32).unwrap_or(5),
                max_analyses: u.int_in_range(0..=3u8).unwrap_or(1),
                keep_curvature: u.ratio(1u8, 2).unwrap_or(false),
                complete_passes: u.ratio(1u8, 2).unwrap_or(false),
                ..Default::default()
            };
            let base_unknown = u.ratio(1u8, 3).unwrap_or(false);
            let params = ParamSet::<24>::full(N, base_unknown).unwrap();
            let Ok(mut lm) = FixedLevenberg::<f64, N, kinecal::Inline<4>, 24>::fixed(
                super::arm3::<kinecal::Inline<4>>(),
                params,
                cfg,
            ) else {
                return;
            };
            let mut calls = 0usize;
            let mut refused = false;
            loop {
                calls += 1;
                let budget = u.int_in_range(1..=13usize).unwrap_or(usize::MAX);
                let r = if u.ratio(1u8, 16).unwrap_or(false) {
                    lm.step(&meas[..meas.len() - 1], budget)
                } else {
                    lm.step(&meas, budget)
                };
                invariant!(
                    "stays-finite",
                    robot_finite(lm.robot()) && !lm.progress().cost.is_nan(),
                    "{r:?} {:?}",
                    lm.robot()
                );
                match r {
                    Err(_) => {
                        refused = true;
                        if calls > 200 {
                            break;
                        }
                    }
                    Ok(p) if p.stopped.is_some() => break,
                    Ok(_) => {
                        if refused {
                            refused = false;
                        }
                    }
                }
                // (10 iterations + 1) × (3 analyses + 2) passes of ≤ 10 poses, one solve each.
                invariant!(
                    "terminates",
                    calls <= 11 * 5 * 2 * (meas.len() + 1) + 200,
                    "{calls} calls, {:?}",
                    lm.progress()
                );
            }
        }
        1 => {
            let robot = super::arm3::<kinecal::Inline<4>>();
            let mut set = ParamSet::<3>::new();
            for p in [Param::Theta(0), Param::A(1), Param::D(0)] {
                set.push(p).unwrap();
            }
            let Ok(mut f) = PositionFitness::new(&robot, &set, &meas) else {
                return;
            };
            let w = finite_f64(&mut u, 1.0, 1.0).abs().min(1e6) + 1e-9;
            let mut cfg =
                PsoConfig::new([-w, -10.0 * w, -10.0 * w], [w, 10.0 * w, 10.0 * w]).unwrap();
            cfg.max_iterations = 6;
            let Ok(mut p) =
                Pso::<f64, 5, 3, 16>::new(cfg, u64::from(u.arbitrary::<u16>().unwrap_or(0)))
            else {
                return;
            };
            if u.ratio(1u8, 2).unwrap_or(false) {
                let x = [finite_f64(&mut u, 0.0, w), 0.0, 0.0];
                let before = format!("{p:?}");
                if p.set_start(u.int_in_range(0..=6usize).unwrap_or(0), &x, &[0.0; 3])
                    .is_err()
                {
                    invariant!(
                        "recovers-after-error",
                        format!("{p:?}") == before,
                        "set_start refused but changed the swarm"
                    );
                }
            }
            let mut best = f64::INFINITY;
            for _ in 0..40 {
                let r = p.step(&mut f, u.int_in_range(1..=7usize).unwrap_or(7));
                invariant!(
                    "stays-finite",
                    r.is_ok() && !p.best_fitness().is_nan(),
                    "{r:?}"
                );
                invariant!(
                    "pso-monotone",
                    p.best_fitness() <= best,
                    "best rose from {best} to {}",
                    p.best_fitness()
                );
                best = p.best_fitness();
                let b = p.best_position();
                invariant!(
                    "pso-monotone",
                    (0..3)
                        .all(|d| b[d] >= cfg.lower[d] && b[d] <= cfg.upper[d]
                            || best == f64::INFINITY),
                    "{b:?}"
                );
                if p.is_finished() {
                    break;
                }
            }
        }
        _ => {
            let xs: Vec<[f64; 3]> = meas.iter().map(|m| m.q).collect();
            let ys: Vec<[f64; 3]> = meas
                .iter()
                .map(|m| [m.point.x, m.point.y, m.point.z])
                .collect();
            let cfg = BpnnConfig {
                learning_rate: finite_f64(&mut u, 0.01, 0.01).abs().max(1e-12),
                ..BpnnConfig::default()
            };
            let Ok(mut net) = Bpnn::<f64, 3, 4, 3>::new(cfg, 9) else {
                return;
            };
            let _ = net.fit_ranges(&xs, &ys);
            for _ in 0..u.int_in_range(1..=6u8).unwrap_or(1) {
                let before = net_state(&net);
                let r = if u.ratio(1u8, 8).unwrap_or(false) {
                    net.train_epoch(&xs[..0], &ys[..0])
                } else {
                    net.train_epoch(&xs, &ys)
                };
                if matches!(r, Err(BpnnError::Diverged)) {
                    invariant!("bpnn-diverged-restores", net_state(&net) == before);
                }
                let y = net.forward(&xs[0]);
                invariant!(
                    "stays-finite",
                    y.iter().all(|v| v.is_finite()),
                    "{y:?} after {r:?}"
                );
            }
        }
    }
}
