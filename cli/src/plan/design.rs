//! Measurement designs on the desktop (optimum experimental design, Jost et al. 2017): the pool
//! of feasible candidate poses, the selection by a criterion with local refinement, the
//! prediction of what a design will identify, and the plan `kinecal plan` writes.
//!
//! Plans are made in the robot base frame with the base at identity; see the `plan` command
//! for the steps and the report.

use crate::formats::cell_file::HostScene;
use anyhow::{anyhow, bail};
use kinecal::model::param::{Param, ParamSet};
use kinecal::planning::cell::Tracker;
use kinecal::planning::information::{
    default_tolerance, scaled_rows, Covariance, Information, PoseRows,
};
use kinecal::planning::observability::{criteria, indices};
use kinecal::planning::pose_pool::{self, Sampling};
use kinecal::planning::selection::{self, Basis, Candidate, Criterion, DesignState};
use kinecal::{ForwardKinematics, Frame, Robot};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::fmt::Write as _;

/// Parameter capacity of host plans (full set of a 7-joint arm: 6 + 28 + 3 = 37).
pub const PCAP: usize = 40;
/// Capacity of working configurations.
pub const WCAP: usize = 16;
/// Clearance (mm) and incidence (rad) margins kept by every planned pose.
pub const CLEARANCE_MARGIN_MM: f64 = 0.1;
pub const INCIDENCE_MARGIN_RAD: f64 = 0.001 * std::f64::consts::PI / 180.0;

/// Jacobian rows of host plans.
pub type PoseRowsHost = PoseRows<f64, PCAP>;

/// A pool candidate of a host plan.
pub type HostCandidate<const N: usize> = Candidate<f64, N, PCAP>;

/// The design criteria of the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CriterionArg {
    Random,
    D,
    O1,
    A,
    Kpi,
}

impl CriterionArg {
    pub fn name(self) -> &'static str {
        match self {
            CriterionArg::Random => "random",
            CriterionArg::D => "d",
            CriterionArg::O1 => "o1",
            CriterionArg::A => "a",
            CriterionArg::Kpi => "kpi",
        }
    }
    /// The optimiser's criterion (`None` for random).
    pub fn criterion(self) -> Option<Criterion> {
        match self {
            CriterionArg::Random => None,
            CriterionArg::D | CriterionArg::O1 => Some(Criterion::D),
            CriterionArg::A => Some(Criterion::A),
            CriterionArg::Kpi => Some(Criterion::Kpi),
        }
    }
}

/// The warning for a working configuration `q` (radians, as [`parse_configuration`] gives it)
/// given as `text` on the command line when it looks given in radians: every joint within
/// ±2π degrees (with 0.01 to spare for a rounded 6.2832), at least two of them half a degree
/// or more from zero, and a value with decimals (`0,-1.57,1.57,0,1.57,0`) or all of them
/// whole numbers within ±3 (`0,-1,1,0,1,0`: whole radians). A pose near zero in whole degrees
/// beyond that (`0,5,2,0,-4,0`) is a working configuration, not a unit slip.
pub fn radians_warning(q: &[f64], text: &str) -> Option<String> {
    let given: Vec<f64> = q.iter().map(|v| v.to_degrees()).collect();
    let most = given.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let moved = given.iter().filter(|v| v.abs() >= 0.5).count();
    let decimals = given.iter().any(|v| (v - v.round()).abs() > 1e-9);
    let whole_radians = !decimals && most <= 3.0 + 1e-9;
    let small = most <= std::f64::consts::TAU + 0.01;
    (small && moved >= 2 && (decimals || whole_radians)).then(|| {
        // The degrees meant, if the text's numbers are radians ("-0" written as 0).
        let meant: Vec<String> = given
            .iter()
            .map(|v| {
                let d = v.to_degrees().round();
                format!("{}", if d == 0.0 { 0.0 } else { d })
            })
            .collect();
        format!(
            "warning: --work {text}: every joint within ±{most:.1}°: if these are radians, give \
             degrees (--work={})",
            meant.join(",")
        )
    })
}

/// Parses `q1,…,qN` (degrees) into radians.
pub fn parse_configuration<const N: usize>(text: &str) -> anyhow::Result<[f64; N]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != N {
        crate::refuse!(
            "--work `{text}`: expected {N} comma-separated joint values (degrees), got {}",
            parts.len()
        );
    }
    let mut q = [0.0; N];
    for (i, (qi, p)) in q.iter_mut().zip(&parts).enumerate() {
        let v: f64 = p.parse().map_err(|_| {
            crate::refused(format!(
                "--work `{text}`: value {} (`{p}`) is not a number",
                i + 1
            ))
        })?;
        // Beyond the library's angle bound a reading is no joint angle (a unit or typing error).
        if v.is_nan() || v.to_radians().abs() > kinecal::model::bounds::MAX_ANGLE {
            crate::refuse!(
                "--work `{text}`: value {} ({p}°) is no joint angle in degrees: give q1,…,q{N} \
                 in degrees",
                i + 1
            );
        }
        *qi = v.to_radians();
    }
    Ok(q)
}

/// The parameters a plan is made for: the default full set with the base pose unknown.
pub fn plan_params(n: usize) -> anyhow::Result<ParamSet<PCAP>> {
    ParamSet::<PCAP>::full(n, true).map_err(|e| anyhow!("parameter set: {e:?}"))
}

/// The cell of a plan made without a scene file: the robot's joint limits are the only
/// constraint. Its tracker sees every orientation (incidence limit 180°; it stands at the base
/// origin, so `incidence_deg` is measured against that point and means nothing), and there is
/// no floor, no capsule and no obstacle (clearance ∞).
pub fn limits_only_scene() -> anyhow::Result<HostScene> {
    HostScene::new(
        Tracker {
            position: nalgebra::Vector3::zeros(),
            max_incidence: std::f64::consts::PI,
            beam_radius: 0.0,
        },
        None,
    )
    .map_err(|e| anyhow!("the joint-limits-only cell: {e:?}"))
}

/// True when the scene's tracker constrains the orientation (not [`limits_only_scene`]): only
/// then are poses aimed at it.
fn aims(scene: &HostScene) -> bool {
    scene.tracker().max_incidence < std::f64::consts::PI
}

/// The robot in its own base frame (base at identity), as plans use it.
pub fn in_base_frame<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
) -> Robot<f64, N, V> {
    let mut r = robot.clone();
    // Identity is always finite.
    let _ = r.set_base(Frame::identity());
    r
}

fn keeps_margins<const N: usize>(
    c: &HostCandidate<N>,
    scene: &HostScene,
    collisions: bool,
) -> bool {
    c.incidence <= scene.tracker().max_incidence - INCIDENCE_MARGIN_RAD
        && (!collisions || c.clearance >= CLEARANCE_MARGIN_MM)
}

/// A pool of feasible candidates and how many draws it took.
pub struct Pool<const N: usize> {
    pub candidates: Vec<HostCandidate<N>>,
    pub draws: u64,
}

/// Draws until `size` feasible candidates (with margins) are found or `max_draws` is reached.
pub fn build_pool<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    scene: &HostScene,
    params: &[Param],
    size: usize,
    collisions: bool,
    rng: &mut Xoshiro256PlusPlus,
    max_draws: u64,
) -> Pool<N> {
    let sampling = Sampling {
        aimed_fraction: if aims(scene) { 0.8 } else { 0.0 },
        cone_fraction: 0.97,
        collisions,
    };
    let mut fk = ForwardKinematics::new();
    let mut candidates = Vec::with_capacity(size);
    let mut draws = 0;
    while candidates.len() < size && draws < max_draws {
        draws += 1;
        if let Some(c) = pose_pool::draw::<f64, N, V, PCAP, _, _, _>(
            rng, robot, scene, params, &sampling, &mut fk,
        ) {
            if keeps_margins(&c, scene, collisions) {
                candidates.push(c);
            }
        }
    }
    Pool { candidates, draws }
}

/// Uniformly random feasible configurations (rejection sampling within the limits): the
/// experimenter's heuristic. Returns the configurations and the number of draws.
pub fn random_design<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    scene: &HostScene,
    params: &[Param],
    n: usize,
    collisions: bool,
    rng: &mut Xoshiro256PlusPlus,
    max_draws: u64,
) -> anyhow::Result<(Vec<HostCandidate<N>>, u64)> {
    let mut fk = ForwardKinematics::new();
    let mut out = Vec::with_capacity(n);
    let mut draws = 0;
    while out.len() < n {
        if draws >= max_draws {
            bail!(
                "only {} of {n} random poses were feasible after {draws} draws: check the scene",
                out.len()
            );
        }
        draws += 1;
        let q = pose_pool::uniform_configuration(rng, robot);
        if let Some(c) = pose_pool::candidate::<f64, N, V, PCAP, _, _>(
            robot, scene, params, &q, collisions, &mut fk,
        ) {
            if keeps_margins(&c, scene, collisions) {
                out.push(c);
            }
        }
    }
    Ok((out, draws))
}

/// Scaled Jacobian rows of the tool point at each working configuration.
pub fn work_rows<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    params: &[Param],
    work: &[[f64; N]],
) -> anyhow::Result<Vec<PoseRows<f64, PCAP>>> {
    let mut fk = ForwardKinematics::new();
    work.iter()
        .map(|q| {
            fk.compute(robot, q);
            let mut g = [[0.0; PCAP]; 3];
            scaled_rows(robot, &fk, params, &mut g).map_err(|e| anyhow!("Jacobian: {e:?}"))?;
            Ok(g)
        })
        .collect()
}

/// The identifiable basis of a pool (from its full-parameter rows).
pub fn pool_basis<const N: usize>(
    pool: &[HostCandidate<N>],
    n_params: usize,
) -> anyhow::Result<Basis<f64, PCAP>> {
    let mut info = Information::<f64, PCAP>::new(n_params).map_err(|e| anyhow!("{e:?}"))?;
    for c in pool {
        info.add_pose(&c.rows)
            .map_err(|e| anyhow!("pool information: {e:?}"))?;
    }
    Basis::new(&info, default_tolerance()).map_err(|e| anyhow!("identifiable subspace: {e:?}"))
}

/// Local refinement of a selected design (the discrete counterpart of the paper's continuous
/// SQP polish): poses near the selected ones join the pool, then more exchange passes; the
/// neighbourhood shrinks each round.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refinement {
    pub rounds: u32,
    /// New candidates tried around each selected pose per round.
    pub neighbours: usize,
    /// Half-width of the joint perturbation in the first round (rad).
    pub step: f64,
}

impl Default for Refinement {
    fn default() -> Self {
        Self {
            rounds: 3,
            neighbours: 6,
            step: 6f64.to_radians(),
        }
    }
}

/// What is needed to make new feasible candidates near a pose.
pub struct Neighbourhood<'a, const N: usize, V: kinecal::ValueStorage> {
    pub robot: &'a Robot<f64, N, V>,
    pub scene: &'a HostScene,
    pub params: &'a [Param],
    pub collisions: bool,
}

impl<const N: usize, V: kinecal::ValueStorage> Neighbourhood<'_, N, V> {
    /// A feasible candidate (full rows) near `q`: every joint moved by up to ±`step`, and
    /// half of the time the wrist re-aimed at the tracker (within the incidence cone).
    pub fn near(
        &self,
        q: &[f64; N],
        step: f64,
        rng: &mut Xoshiro256PlusPlus,
        fk: &mut ForwardKinematics<f64, N>,
    ) -> Option<HostCandidate<N>> {
        let mut x = *q;
        for (xi, j) in x.iter_mut().zip(self.robot.joints()) {
            let u: f64 = pose_pool::uniform(rng);
            *xi = (*xi + step * (2.0 * u - 1.0)).clamp(j.lower, j.upper);
        }
        if aims(self.scene) && pose_pool::uniform::<f64, _>(rng) < 0.5 {
            fk.compute(self.robot, &x);
            let tracker = fk.base.point(&self.scene.tracker().position);
            let target = pose_pool::aim_target(
                rng,
                &tracker,
                &fk.point,
                self.scene.tracker().max_incidence * 0.97,
            );
            if !pose_pool::aim_wrist(self.robot, fk, &mut x, &target, 1e-4) {
                return None;
            }
        }
        let c = pose_pool::candidate::<f64, N, V, PCAP, _, _>(
            self.robot,
            self.scene,
            self.params,
            &x,
            self.collisions,
            fk,
        )?;
        keeps_margins(&c, self.scene, self.collisions).then_some(c)
    }
}

/// How a host design went.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Optimised {
    pub outcome: selection::Outcome<f64>,
    /// Candidates added near the design by refinement, and the swaps they brought.
    pub added: usize,
    pub refine_swaps: u32,
}

/// Selects `n` poses from `pool` (rows already reduced by `basis`) for `criterion`, then,
/// with `refine`, grows the pool near the design and exchanges again. Returns the pool
/// indices (the pool may have grown).
#[allow(clippy::too_many_arguments)]
pub fn optimise<const N: usize, V: kinecal::ValueStorage>(
    pool: &mut Vec<HostCandidate<N>>,
    basis: &Basis<f64, PCAP>,
    work_reduced: &[PoseRows<f64, PCAP>],
    criterion: Criterion,
    n: usize,
    passes: u32,
    refine: Option<(&Neighbourhood<N, V>, &Refinement, &mut Xoshiro256PlusPlus)>,
) -> anyhow::Result<(Vec<usize>, Optimised)> {
    let ridge = basis.per_pose() * 1e-8;
    let mut state = Box::new(
        DesignState::<f64, PCAP, WCAP>::new(basis.rank(), work_reduced, ridge)
            .map_err(|e| anyhow!("design: {e:?}"))?,
    );
    let mut design = vec![0usize; n];
    let too_small =
        |len: usize| anyhow!("the pool has {len} feasible poses, fewer than the {n} requested");
    let outcome = selection::select(&mut state, criterion, pool, &mut design, passes).map_err(
        |e| match e {
            selection::PlanError::PoolTooSmall => too_small(pool.len()),
            e => anyhow!("design: {e:?}"),
        },
    )?;
    let mut added = 0;
    let mut refine_swaps = 0;
    if let Some((hood, r, rng)) = refine {
        let mut fk = ForwardKinematics::new();
        let mut step = r.step;
        for _ in 0..r.rounds {
            let around: Vec<[f64; N]> = design.iter().map(|i| pool[*i].q).collect();
            for q in &around {
                for _ in 0..r.neighbours {
                    if let Some(mut c) = hood.near(q, step, rng, &mut fk) {
                        c.rows = basis.reduce(&c.rows);
                        pool.push(c);
                        added += 1;
                    }
                }
            }
            let (_, swaps) = selection::exchange(&mut state, criterion, pool, &mut design, passes)
                .map_err(|e| anyhow!("design: {e:?}"))?;
            refine_swaps += swaps;
            step *= 0.5;
        }
    }
    let outcome = selection::Outcome {
        objective: state.objective(criterion),
        ..outcome
    };
    Ok((
        design,
        Optimised {
            outcome,
            added,
            refine_swaps,
        },
    ))
}

/// What linear error propagation predicts for a design.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// σ²·trace Σ_s C_s (mm²).
    pub kpi_trace_mm2: f64,
    /// √trace C_s per working configuration (mm).
    pub tool_std_mm: Vec<f64>,
    pub a: f64,
    pub d: f64,
    pub e: f64,
    pub o: [f64; 5],
    /// Identifiable directions the design determines.
    pub rank: usize,
}

/// Predicted covariances of a design, computed from scratch (full parameter set, eigen
/// pseudo-inverse) rather than from the optimiser's reduced coordinates.
pub fn evaluate<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    params: &[Param],
    poses: &[[f64; N]],
    work: &[[f64; N]],
    sigma: f64,
) -> anyhow::Result<Evaluation> {
    let mut info =
        Box::new(Information::<f64, PCAP>::new(params.len()).map_err(|e| anyhow!("{e:?}"))?);
    let mut fk = ForwardKinematics::new();
    for q in poses {
        fk.compute(robot, q);
        let mut g = [[0.0; PCAP]; 3];
        scaled_rows(robot, &fk, params, &mut g).map_err(|e| anyhow!("Jacobian: {e:?}"))?;
        info.add_pose(&g)
            .map_err(|e| anyhow!("information: {e:?}"))?;
    }
    let cov = Box::new(
        Covariance::new(&info, sigma, default_tolerance())
            .map_err(|e| anyhow!("covariance: {e:?}"))?,
    );
    let w = work_rows(robot, params, work)?;
    let c = criteria(&cov, &w);
    let ix = indices(&cov, poses.len());
    Ok(Evaluation {
        kpi_trace_mm2: c.kpi,
        tool_std_mm: w
            .iter()
            .map(|g| cov.tool_variance(g).max(0.0).sqrt())
            .collect(),
        a: c.a,
        d: c.d,
        e: c.e,
        o: [ix.o1, ix.o2, ix.o3, ix.o4, ix.o5],
        rank: cov.rank(),
    })
}

/// A finished plan.
pub struct Plan<const N: usize> {
    pub poses: Vec<HostCandidate<N>>,
    pub evaluation: Evaluation,
    pub pool_size: usize,
    pub draws: u64,
    pub passes: u32,
    pub exchanges: u32,
    pub basis_rank: usize,
}

/// Everything a plan needs besides the robot.
pub struct PlanRequest<'a, const N: usize> {
    pub scene: &'a HostScene,
    pub criterion: CriterionArg,
    pub poses: usize,
    pub work: &'a [[f64; N]],
    pub sigma: f64,
    pub pool: usize,
    pub collisions: bool,
    pub passes: u32,
    pub seed: u64,
    /// Polish the design by local refinement ([`Refinement`]).
    pub refine: bool,
    /// The parameters the design is for (`--estimate`, [`crate::calibration::selection::named`]), the others
    /// held at their values; empty: the default full set ([`plan_params`]).
    pub estimate: &'a [Param],
}

/// Plans `req.poses` poses for `robot` (any base: it is set to identity).
pub fn plan<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    req: &PlanRequest<N>,
) -> anyhow::Result<Plan<N>> {
    if req.poses == 0 {
        bail!("--poses must be at least 1");
    }
    if req.work.is_empty() || req.work.len() > WCAP {
        bail!(
            "give 1 to {WCAP} working configurations (--work), got {}",
            req.work.len()
        );
    }
    if !(req.sigma.is_finite() && req.sigma > 0.0) {
        bail!("--noise-mm must be a positive number, got {}", req.sigma);
    }
    let robot = in_base_frame(robot);
    let full = plan_params(N)?;
    let params = if req.estimate.is_empty() {
        full.as_slice()
    } else {
        req.estimate
    };
    if params.len() > PCAP {
        bail!(
            "{} parameters to plan for, more than the {PCAP} a plan holds",
            params.len()
        );
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(req.seed);
    let max_draws = 2_000_000 + 2_000 * req.pool.max(req.poses) as u64;
    let (poses, draws, pool_size, passes, exchanges, basis_rank) = match req.criterion.criterion() {
        None => {
            let (poses, draws) = random_design(
                &robot,
                req.scene,
                params,
                req.poses,
                req.collisions,
                &mut rng,
                max_draws,
            )?;
            (poses, draws, 0, 0, 0, 0)
        }
        Some(criterion) => {
            let size = req.pool.max(req.poses);
            let mut pool = build_pool(
                &robot,
                req.scene,
                params,
                size,
                req.collisions,
                &mut rng,
                max_draws,
            );
            if pool.candidates.len() < req.poses {
                bail!(
                    "only {} feasible poses found in {} draws, fewer than the {} requested: check the scene",
                    pool.candidates.len(),
                    pool.draws,
                    req.poses
                );
            }
            let basis = pool_basis(&pool.candidates, params.len())?;
            too_few_poses(
                req.poses,
                basis.rank(),
                "directions the cell's poses determine",
            )?;
            basis.reduce_pool(&mut pool.candidates);
            let work: Vec<PoseRows<f64, PCAP>> = work_rows(&robot, params, req.work)?
                .iter()
                .map(|g| basis.reduce(g))
                .collect();
            let hood = Neighbourhood {
                robot: &robot,
                scene: req.scene,
                params,
                collisions: req.collisions,
            };
            let refinement = Refinement::default();
            let refine = req.refine.then_some((&hood, &refinement, &mut rng));
            let (design, opt) = optimise(
                &mut pool.candidates,
                &basis,
                &work,
                criterion,
                req.poses,
                req.passes,
                refine,
            )?;
            let mut fk = ForwardKinematics::new();
            let mut chosen = Vec::with_capacity(design.len());
            for i in design {
                // Recompute full rows for the report (the pool holds reduced ones).
                let c = pose_pool::candidate::<f64, N, V, PCAP, _, _>(
                    &robot,
                    req.scene,
                    params,
                    &pool.candidates[i].q,
                    req.collisions,
                    &mut fk,
                )
                .ok_or_else(|| anyhow!("internal: a pool pose is no longer feasible"))?;
                chosen.push(c);
            }
            (
                chosen,
                pool.draws,
                pool.candidates.len(),
                opt.outcome.passes,
                opt.outcome.exchanges + opt.refine_swaps,
                basis.rank(),
            )
        }
    };
    let qs: Vec<[f64; N]> = poses.iter().map(|c| c.q).collect();
    let evaluation = evaluate(&robot, params, &qs, req.work, req.sigma)?;
    // A random design has no pool to tell the directions: one whose every equation went to a
    // direction of its own has none to spare, and more directions are left undetermined.
    if req.criterion.criterion().is_none() && evaluation.rank >= 3 * req.poses {
        too_few_poses(
            req.poses,
            evaluation.rank + 1,
            "directions or more a design determines",
        )?;
    }
    Ok(Plan {
        poses,
        evaluation,
        pool_size,
        draws,
        passes,
        exchanges,
        basis_rank,
    })
}

/// Refuses a design of `poses` poses whose equations (3 per pose) cannot determine `directions`
/// (`what` they are): its predicted accuracy would cover only the few directions it does
/// determine (one pose predicted a tool σ smaller than ten poses did).
fn too_few_poses(poses: usize, directions: usize, what: &str) -> anyhow::Result<()> {
    let need = directions.div_ceil(3);
    if poses < need {
        crate::refuse!(
            "--poses {poses}: {} equations (3 per pose) for the {directions} {what}: plan at \
             least {need} poses (fewer determine only some, and the predicted accuracy leaves \
             the others out), better three to five times as many",
            3 * poses
        );
    }
    Ok(())
}

/// The CSV text of planned poses: `q1…qN` (degrees, 9 decimals), incidence, clearance.
pub fn poses_csv<const N: usize>(poses: &[HostCandidate<N>]) -> String {
    let mut s = String::new();
    for i in 1..=N {
        let _ = write!(s, "q{i},");
    }
    s.push_str("incidence_deg,clearance_mm\n");
    for c in poses {
        for q in c.q {
            let _ = write!(s, "{:.9},", q.to_degrees());
        }
        let clearance = if c.clearance.is_finite() && c.clearance < 1e300 {
            format!("{:.3}", c.clearance)
        } else {
            "inf".into()
        };
        let _ = writeln!(s, "{:.6},{clearance}", c.incidence.to_degrees());
    }
    s
}
