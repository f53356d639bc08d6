//! The report of `kinecal plan`.

use super::plain_report;
use crate::plan::request::{Planned, Request};
use serde::Serialize;
use std::fmt;

/// `kinecal plan`: the planned poses' predicted accuracy, clearance and incidence.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlanReport {
    /// `random`, `d`, `o1`, `a` or `kpi`.
    pub criterion: String,
    pub poses: usize,
    /// σ²·trace of the summed tool-point covariance at the working configurations (mm²).
    pub kpi_trace_mm2: f64,
    /// √trace of the tool-point covariance per working configuration (mm).
    pub tool_std_mm: Vec<f64>,
    /// Signed clearance in the full cell (mm; ≤ 0: a pose collides); `None` (JSON `null`)
    /// when the cell has nothing to collide with (no `--scene`).
    pub min_clearance_mm: Option<f64>,
    pub colliding_poses: usize,
    pub max_incidence_deg: f64,
    pub noise_mm: f64,
    pub criteria: Criteria,
    pub observability: Observability,
    pub identifiable_directions: usize,
    /// The parameters the design is for (`--estimate`, others held); empty: the full set.
    pub estimate: Vec<String>,
    pub collision_avoidance: bool,
    /// Feasible candidate poses, and the draws it took.
    pub pool: usize,
    pub draws: u64,
    pub exchange_passes: u32,
    pub exchanges: u32,
    pub seconds: f64,
    /// The pose file written.
    pub out: String,
}

/// The A, D and E criteria (mm², scaled parameters).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Criteria {
    pub a: f64,
    pub d: f64,
    pub e: f64,
}

/// The observability indices O1–O5.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Observability {
    pub o1: f64,
    pub o2: f64,
    pub o3: f64,
    pub o4: f64,
    pub o5: f64,
}

impl From<[f64; 5]> for Observability {
    fn from(o: [f64; 5]) -> Self {
        let [o1, o2, o3, o4, o5] = o;
        Self { o1, o2, o3, o4, o5 }
    }
}

impl PlanReport {
    /// The report of the plan `p` made for `req`, its poses written to `out`.
    pub fn of<const N: usize>(p: &Planned<N>, req: &Request, out: &str) -> Self {
        let ev = &p.plan.evaluation;
        Self {
            criterion: req.criterion.name().to_string(),
            poses: p.poses.len(),
            kpi_trace_mm2: ev.kpi_trace_mm2,
            tool_std_mm: ev.tool_std_mm.clone(),
            min_clearance_mm: p.min_clearance_mm,
            colliding_poses: p.colliding_poses,
            max_incidence_deg: p.max_incidence_deg,
            noise_mm: p.noise_mm,
            criteria: Criteria {
                a: ev.a,
                d: ev.d,
                e: ev.e,
            },
            observability: ev.o.into(),
            identifiable_directions: ev.rank,
            estimate: p.estimate.clone(),
            collision_avoidance: req.collisions,
            pool: p.plan.pool_size,
            draws: p.plan.draws,
            exchange_passes: p.plan.passes,
            exchanges: p.plan.exchanges,
            seconds: p.seconds,
            out: out.to_string(),
        }
    }
}

plain_report!(PlanReport);

impl fmt::Display for PlanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} poses ({} design) written to {}",
            self.poses, self.criterion, self.out
        )?;
        writeln!(
            f,
            "predicted TCP covariance trace {:.4e} mm² (σ = {} mm); TCP std per working configuration: {}",
            self.kpi_trace_mm2,
            self.noise_mm,
            self.tool_std_mm
                .iter()
                .map(|s| format!("{s:.4} mm"))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
        let c = &self.criteria;
        writeln!(
            f,
            "A {:.4e}  D {:.4e}  E {:.4e} (mm², scaled parameters); identifiable directions {}",
            c.a, c.d, c.e, self.identifiable_directions
        )?;
        let o = &self.observability;
        writeln!(
            f,
            "O1 {:.4}  O2 {:.4}  O3 {:.4}  O4 {:.4}  O5 {:.4}",
            o.o1, o.o2, o.o3, o.o4, o.o5
        )?;
        let clearance = match self.min_clearance_mm {
            None => "∞ (nothing to collide with: no floor, link capsules or obstacles)".to_string(),
            Some(c) if self.collision_avoidance => format!("{c:.1} mm"),
            Some(c) => format!(
                "{c:.1} mm ({} colliding poses: collisions not avoided)",
                self.colliding_poses
            ),
        };
        writeln!(
            f,
            "min clearance {clearance}, max incidence {:.2}°; pool {} feasible of {} draws; {} exchange passes, {} swaps; {:.2} s",
            self.max_incidence_deg,
            self.pool,
            self.draws,
            self.exchange_passes,
            self.exchanges,
            self.seconds
        )
    }
}
