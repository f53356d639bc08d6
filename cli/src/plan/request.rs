//! What `kinecal plan` asks for, checked against the command line's limits, and the plan it
//! makes in memory for a robot model in a cell: the chosen poses with their signed clearance
//! in the full cell, and what the report says of them. The command line writes the poses;
//! the Python package returns them.
//!
//! Plans are made in the robot base frame with the base at identity: the scene is given there,
//! and the identified base pose (the tracker's placement) only rotates the tool-point
//! covariance, whose trace is what the criteria use. The identified set is the default full
//! set (base pose, alpha/a/theta/d of every joint, tool point), or with `--estimate` the named
//! subset with every other parameter held at its value (a quick re-calibration: the
//! information about the subset is then its own Jacobian columns,
//! [`crate::calibration::selection`]); structural redundancies are dropped by
//! [`Basis`](kinecal::planning::selection::Basis). Without `--scene` the joint limits are the
//! only constraint ([`super::design::limits_only_scene`]).
//!
//! 1. Pool: `--pool` feasible configurations, 80 % drawn with the wrist aimed at the tracker
//!    and 20 % uniformly within the limits ([`kinecal::planning::pose_pool::draw`]); all
//!    uniformly without a scene. Poses closer than 0.1 mm to a collision or within 0.001° of the incidence limit are
//!    dropped, so the rounding of the written joint values cannot make a planned pose
//!    infeasible.
//! 2. Design: `random` draws uniformly within the limits and keeps feasible poses (the
//!    experimenter's heuristic); `d`, `o1` (the same optimum: O1 is monotone in det JᵀJ for a
//!    fixed number of poses), `a` and `kpi` select from the pool by greedy construction and
//!    Fedorov exchange ([`kinecal::planning::selection::select`]).
//! 3. Report: predicted by linear error propagation, σ = `--noise-mm` per coordinate (or the
//!    RMS of a tracker file's stated σ, `--noise-from`):
//!    `kpi_trace_mm2` = trace of the summed tool-point covariance at the `--work`
//!    configurations, the A/D/E criteria, the observability indices O1–O5.

use super::design::{
    in_base_frame, parse_configuration, plan, CriterionArg, HostCandidate, Plan, PlanRequest,
};
use crate::formats::cell_file::HostScene;
use crate::HostRobot;
use crate::Tell;
use kinecal::ForwardKinematics;
use std::time::Instant;

/// The options of a plan (`kinecal plan`'s flags, but the files).
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// Design for these parameters only (names or groups); empty: the full set.
    pub estimate: Vec<String>,
    pub poses: usize,
    pub criterion: CriterionArg,
    /// Working configurations `q1,…,qN` in degrees, as the command line gives them.
    pub work: Vec<String>,
    pub seed: u64,
    /// Measurement noise per axis (mm), unless the caller states another ([`plan_request`]).
    pub noise_mm: f64,
    pub pool: usize,
    /// Avoid collisions, floor and beam (`false`: `--no-collisions`).
    pub collisions: bool,
    pub passes: u32,
    /// Local refinement (`false`: `--no-refine`).
    pub refine: bool,
}

/// The defaults of a [`Request`] (the command line's too).
pub const DEFAULT_SEED: u64 = 1;
pub const DEFAULT_NOISE_MM: f64 = 0.01;
pub const DEFAULT_POOL: usize = 3000;
pub const DEFAULT_PASSES: u32 = 30;

impl Request {
    /// `poses` poses by `criterion` around the working configurations `work`, everything else
    /// at its default (all parameters, with collisions and refinement).
    pub fn new(poses: usize, criterion: CriterionArg, work: Vec<String>) -> Self {
        Self {
            estimate: Vec::new(),
            poses,
            criterion,
            work,
            seed: DEFAULT_SEED,
            noise_mm: DEFAULT_NOISE_MM,
            pool: DEFAULT_POOL,
            collisions: true,
            passes: DEFAULT_PASSES,
            refine: true,
        }
    }

    /// Refuses (exit 2) sizes outside the command line's limits: the work grows with poses ×
    /// pool × passes, so all three are bounded before it starts.
    pub fn check(&self) -> anyhow::Result<()> {
        crate::check_count("--poses", self.poses, 1, crate::MAX_PLAN_POSES)?;
        crate::check_count("--pool", self.pool, 1, crate::MAX_POOL)?;
        crate::check_count(
            "--passes",
            self.passes as usize,
            0,
            crate::MAX_PASSES as usize,
        )?;
        crate::check_positive("--noise-mm", self.noise_mm, crate::MAX_NOISE_MM)
    }
}

/// A plan made: the design and what the report says of it.
pub struct Planned<const N: usize> {
    pub plan: Plan<N>,
    /// The chosen poses with their signed clearance in the full cell, also for plans made
    /// without collision avoidance (negative: the pose collides): what `--out` writes.
    pub poses: Vec<HostCandidate<N>>,
    /// The smallest clearance (mm); `None` when the cell has nothing to collide with.
    pub min_clearance_mm: Option<f64>,
    pub colliding_poses: usize,
    pub max_incidence_deg: f64,
    /// The noise the predictions are for (mm).
    pub noise_mm: f64,
    /// The names of the parameters the design is for (empty: the full set).
    pub estimate: Vec<String>,
    pub seconds: f64,
}

/// Plans `req` for `robot` in `scene`. `noise` gives the noise per axis (mm) once the
/// working configurations are read (`req.noise_mm`, or a tracker file's stated σ); working
/// configurations outside the joint limits are told to `tell` as warnings, the design's stage
/// as a stage.
pub fn plan_request<const N: usize>(
    robot: &HostRobot<N>,
    scene: &HostScene,
    req: &Request,
    noise: impl FnOnce(&HostRobot<N>) -> anyhow::Result<f64>,
    tell: &mut dyn Tell,
) -> anyhow::Result<Planned<N>> {
    let estimate = if req.estimate.is_empty() {
        Vec::new()
    } else {
        crate::calibration::selection::named("--estimate", &req.estimate, robot)?
    };
    let work = req
        .work
        .iter()
        .map(|w| parse_configuration::<N>(w))
        .collect::<anyhow::Result<Vec<_>>>()?;
    for (k, q) in work.iter().enumerate() {
        if let Some(w) = super::design::radians_warning(q, &req.work[k]) {
            tell.line(&format!("kinecal plan: {w}"));
        }
        if !robot.within_limits(q) {
            tell.line(&format!(
                "kinecal plan: warning: working configuration {} is outside the joint limits",
                k + 1
            ));
        }
    }
    let sigma = noise(robot)?;
    let start = Instant::now();
    let preq = PlanRequest {
        scene,
        criterion: req.criterion,
        poses: req.poses,
        work: &work,
        sigma,
        pool: req.pool,
        collisions: req.collisions,
        passes: req.passes,
        seed: req.seed,
        refine: req.refine,
        estimate: &estimate,
    };
    tell.stage(&format!(
        "choosing {} poses from a pool of {}",
        req.poses, req.pool
    ));
    let p = plan(robot, &preq)?;
    let seconds = start.elapsed().as_secs_f64();
    // Signed clearance in the full cell, also for plans made without collision avoidance
    // (negative: the pose collides).
    let base_robot = in_base_frame(robot);
    let mut fk = ForwardKinematics::new();
    let clearances: Vec<f64> = p
        .poses
        .iter()
        .map(|c| {
            fk.compute(&base_robot, &c.q);
            scene.clearance(&fk)
        })
        .collect();
    // A cell with nothing to collide with (no `--scene`) reports the largest float: no
    // clearance to report (JSON null).
    let min_clearance = clearances.iter().cloned().fold(f64::INFINITY, f64::min);
    let min_clearance = (min_clearance < 1e300).then_some(min_clearance);
    let colliding = clearances.iter().filter(|c| **c <= 0.0).count();
    let mut poses = p.poses.clone();
    for (c, cl) in poses.iter_mut().zip(&clearances) {
        c.clearance = *cl;
    }
    let max_incidence = p
        .poses
        .iter()
        .map(|c| c.incidence.to_degrees())
        .fold(0.0, f64::max);
    Ok(Planned {
        estimate: estimate.iter().map(|e| e.name(robot).to_string()).collect(),
        plan: p,
        poses,
        min_clearance_mm: min_clearance,
        colliding_poses: colliding,
        max_incidence_deg: max_incidence,
        noise_mm: sigma,
        seconds,
    })
}

/// The RMS of the stated 1-σ (`sx_mm`, `sy_mm`, `sz_mm`) of every row of the measurement file
/// `path` (mm): the tracker's noise as it reports it, for the predicted covariances.
/// Read as every measurement file is (`--map`, units, the stated base).
pub fn stated_noise_mm<const N: usize>(
    path: &std::path::Path,
    units: &crate::formats::units::UnitArgs,
    robot: &HostRobot<N>,
    base_known: bool,
) -> anyhow::Result<f64> {
    let ds = crate::formats::loading::load_measurements(path, units, robot, base_known)?;
    let cols: Vec<Vec<f64>> = ["sx_mm", "sy_mm", "sz_mm"]
        .iter()
        .filter_map(|c| ds.extra(c))
        .collect();
    if cols.len() != 3 || ds.is_empty() {
        crate::refuse!(
            "--noise-from {}: needs the columns sx_mm, sy_mm, sz_mm (the tracker's 1-σ per \
             coordinate): give --noise-mm instead",
            path.display()
        );
    }
    let values: Vec<f64> = cols.concat();
    if let Some(bad) = values.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        crate::refuse!(
            "--noise-from {}: a stated σ of {bad} mm: every σ must be a positive number",
            path.display()
        );
    }
    let rms = crate::calibration::stats::rms(&values);
    crate::check_positive("--noise-from (the RMS of its σ)", rms, crate::MAX_NOISE_MM)?;
    Ok(rms)
}
