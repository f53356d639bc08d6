//! The report of `kinecal simulate`.

use super::plain_report;
use crate::formats::robot_file::THERMAL;
use crate::simulation::request::{Request, Simulated};
use serde::Serialize;
use std::fmt;

/// `kinecal simulate`: what was written, from which true robot.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimulateReport {
    pub poses: usize,
    pub seed: u64,
    /// The measurement file written.
    pub out: String,
    /// The true model's robot file, when written.
    pub truth: Option<String>,
    pub joints: usize,
    pub noise_mm: f64,
    pub geom_errors: bool,
    pub effects: Vec<SimulatedEffect>,
    /// Where the base comes from: `file`, or `identity (robot file has no [base])`.
    pub base: String,
}

/// One `--effect` of the true robot.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimulatedEffect {
    pub effect: String,
    /// 1-based.
    pub joint: usize,
    pub values: Vec<f64>,
    pub order: u16,
}

impl SimulateReport {
    /// The report of the simulation `s` of `req` for a robot file with or without `[base]`
    /// (`base_known`): `poses` rows written to `out`, the true model to `truth`.
    pub fn of<const N: usize>(
        s: &Simulated<N>,
        req: &Request,
        base_known: bool,
        poses: usize,
        (out, truth): (&str, Option<&str>),
    ) -> Self {
        Self {
            poses,
            seed: req.seed,
            out: out.to_string(),
            truth: truth.map(str::to_string),
            joints: N,
            noise_mm: req.noise_mm,
            geom_errors: req.geom_errors,
            effects: s
                .effects
                .iter()
                .map(|e| SimulatedEffect {
                    effect: e.kind.clone(),
                    joint: if e.kind == THERMAL || e.kind == kinecal::EffectKind::Drift.id() {
                        0
                    } else {
                        e.joint + 1
                    },
                    values: e.values.clone(),
                    order: e.order,
                })
                .collect(),
            base: if base_known {
                "file"
            } else {
                "identity (robot file has no [base])"
            }
            .to_string(),
        }
    }
}

plain_report!(SimulateReport);

impl fmt::Display for SimulateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "wrote {} poses of a {}-joint robot to {} (seed {}, noise {} mm{}{})",
            self.poses,
            self.joints,
            self.out,
            self.seed,
            self.noise_mm,
            if self.geom_errors {
                ", geometric errors"
            } else {
                ""
            },
            if self.effects.is_empty() {
                String::new()
            } else {
                format!(", {} effect(s)", self.effects.len())
            }
        )?;
        if let Some(t) = &self.truth {
            writeln!(f, "true model written to {t}")?;
        }
        Ok(())
    }
}
