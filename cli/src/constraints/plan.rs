//! Planning a session without a tracker (`plan --constraints socket:4x10,plane:2x12,distance:20`):
//! which orientations to touch each socket with, where to touch each plane, which pairs a ball
//! bar should join, chosen by the criteria of tracker plans (D, A, KPI: docs/formats.md) on the
//! information the constraints give.
//!
//! The sockets and planes are placed as `simulate --constraints` places them (seeded), in the
//! nominal robot's frame; each group gets a pool of `pool` candidate rows per row it needs
//! (reached by the library's `compensate` from random poses), the distances and tracker points
//! a pool of candidate pairs and poses. With every row's scaled model columns `c_i` at the
//! nominal model (the parameters `identify` would estimate, less what the whole pool cannot
//! determine), a group's information is that of [`crate::constraints::system`] with its shape
//! projected out (kinecal's `identify::lm::constraint` documents the same algebra): a socket
//! `Σ c_iᵀc_i − (Σc_i)ᵀ(Σc_i)/K`; a plane (normal `n`, in-plane axes `t`) the same of
//! `a_i = n·c_i`, less `b_t b_tᵀ/λ_t` for its tilts; a distance `aᵀa`, `a = u·(c_a − c_b)`; a
//! point `Σ c_iᵀc_i`; all over `σ²`. The session's information `M` is their sum. Selection
//! starts from the pool's first rows (a random design) and exchanges one row for another of
//! the same group while the criterion improves (Fedorov exchange, as the tracker planner).
//!
//! The predicted accuracy is the tool point's standard deviation over 300 random poses,
//! `σ_tool = √(mean trace(L M⁻¹ Lᵀ))` (`L`: the scaled tool columns there): what a
//! calibration from this session leaves at random poses, noise only, after the rigid motion
//! constraints cannot see.

use super::fit::{candidates, unidentifiable};
use super::read::{Group, Kind, Row};
use super::shapes::tangents;
use super::simulate::{reach, SessionPlan};
use crate::formats::measurements::quantize_deg;
use crate::formats::robot_file::RobotFile;
use crate::plan::design::CriterionArg;
use crate::simulation::{random_configurations, Streams};
use crate::HostRobot;
use kinecal::{ForwardKinematics, Param};
use nalgebra::{DMatrix, RowDVector, Vector3};
use rand::RngExt;
use rand_distr::StandardNormal;
use std::fmt::Write as _;

/// Most exchange passes.
pub const PASSES: usize = 20;
/// Random poses the predicted accuracy is averaged over.
pub const ACCURACY_POSES: usize = 300;

/// One candidate row: joint readings, the nominal tool point, and its scaled model columns
/// (3 × estimated parameters).
#[derive(Clone, Debug)]
struct Candidate<const N: usize> {
    q: [f64; N],
    p: Vector3<f64>,
    c: DMatrix<f64>,
}

/// A group being planned: its kind and name, the candidates, which are chosen (indices into
/// `pool`; a distance's chosen pairs are `pool[2i], pool[2i+1]`), and a plane's normal.
#[derive(Clone, Debug)]
struct Planned<const N: usize> {
    kind: Kind,
    name: String,
    pool: Vec<Candidate<N>>,
    chosen: Vec<usize>,
    normal: Option<Vector3<f64>>,
}

/// A planned session.
#[derive(Clone, Debug)]
pub struct SessionDesign<const N: usize> {
    groups: Vec<Planned<N>>,
    /// The parameters the design is for, and those the whole pool cannot determine (held).
    pub estimated: Vec<Param>,
    pub held: Vec<Param>,
    /// Predicted tool-point σ (mm) of the pool's first rows (a random design) and of the plan.
    pub random_tool_mm: f64,
    pub planned_tool_mm: f64,
    /// Criterion values (lower is better: `−ln det M`, `trace M⁻¹`, `trace L M⁻¹ Lᵀ`).
    pub random_criterion: f64,
    pub planned_criterion: f64,
    /// Exchanges made, passes run.
    pub exchanges: usize,
    pub passes: usize,
    /// Candidate rows in the pools.
    pub pool_rows: usize,
}

/// What to plan.
pub struct Request<'a, const N: usize> {
    pub session: SessionPlan,
    pub criterion: CriterionArg,
    /// Candidates per row needed (≥ 1; 1: the random design).
    pub pool: usize,
    pub seed: u64,
    pub sigma_mm: f64,
    /// Working configurations (rad) for KPI.
    pub work: &'a [[f64; N]],
}

fn candidate<const N: usize>(
    nominal: &HostRobot<N>,
    params: &[Param],
    q: [f64; N],
) -> Candidate<N> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    let p = fk.compute(nominal, &q);
    let reach = nominal.reach();
    let mut c = DMatrix::zeros(3, params.len());
    for (k, &param) in params.iter().enumerate() {
        let col = fk
            .column(nominal, param)
            .unwrap_or_else(|_| Vector3::zeros())
            / param.scale(reach);
        c.set_column(k, &col);
    }
    Candidate { q, p, c }
}

/// A group's candidate readings: its kind, name, the readings (a distance's in pairs) and a
/// plane's normal.
type Pool<const N: usize> = (Kind, String, Vec<[f64; N]>, Option<Vector3<f64>>);

/// The candidate pools of `session` on `nominal` (readings only; columns come later).
fn pools<const N: usize>(
    nominal: &HostRobot<N>,
    req: &Request<'_, N>,
) -> anyhow::Result<Vec<Pool<N>>> {
    let s = &req.session;
    let mut streams = Streams::new(req.seed);
    let mut out = Vec::new();
    let draws = 30;
    for (kind, (groups, rows)) in [(Kind::Socket, s.sockets), (Kind::Plane, s.planes)] {
        for g in 0..groups {
            let want = rows * req.pool;
            let mut found = None;
            for _ in 0..draws {
                let q0 = random_configurations(nominal, 1, &mut streams.configs)[0];
                let p0 = ForwardKinematics::<f64, N>::new().compute(nominal, &q0);
                let normal = (kind == Kind::Plane).then(|| {
                    Vector3::from_fn(|_, _| streams.errors.sample::<f64, _>(StandardNormal))
                        .normalize()
                });
                let mut qs = Vec::new();
                for _ in 0..want {
                    let target = match normal {
                        None => p0,
                        Some(n) => {
                            let (t1, t2) = tangents(&n);
                            let u: f64 = streams.configs.random_range(-150.0..150.0);
                            let v: f64 = streams.configs.random_range(-150.0..150.0);
                            p0 + t1 * u + t2 * v
                        }
                    };
                    let spread = if normal.is_some() { 30.0 } else { 45.0 };
                    match reach(nominal, &target, &q0, spread, None, &mut streams.configs) {
                        Some(q) => qs.push(q),
                        None => break,
                    }
                }
                if qs.len() == want {
                    found = Some((qs, normal));
                    break;
                }
            }
            let Some((qs, normal)) = found else {
                crate::refuse!(
                    "plan --constraints: no {} with {want} reachable candidate rows in {draws} \
                     draws: try another --seed, fewer rows or a smaller --pool",
                    kind.id()
                );
            };
            let prefix = if kind == Kind::Socket { "s" } else { "p" };
            out.push((kind, format!("{prefix}{}", g + 1), qs, normal));
        }
    }
    for (kind, count, per) in [(Kind::Distance, s.distances, 2), (Kind::Point, s.points, 1)] {
        if count > 0 {
            let qs = random_configurations(nominal, count * req.pool * per, &mut streams.configs);
            out.push((kind, kind.id().into(), qs, None));
        }
    }
    Ok(out)
}

/// The pools as groups of rows (every candidate), for the identifiability analysis.
fn as_groups<const N: usize>(
    nominal: &HostRobot<N>,
    pools: &[Pool<N>],
    sigma_mm: f64,
) -> Vec<Group<N>> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    let row = |q: &[f64; N], xyz: Option<[f64; 3]>| Row {
        q: *q,
        tool: 0,
        sigma_mm,
        xyz,
        temp_c: None,
        line: 0,
    };
    let mut out = Vec::new();
    for (kind, name, qs, _) in pools {
        match kind {
            Kind::Socket | Kind::Plane => out.push(Group {
                kind: *kind,
                name: name.clone(),
                rows: qs.iter().map(|q| row(q, None)).collect(),
                length_mm: None,
            }),
            Kind::Distance => {
                for (i, pair) in qs.chunks(2).enumerate() {
                    let length =
                        (fk.compute(nominal, &pair[0]) - fk.compute(nominal, &pair[1])).norm();
                    out.push(Group {
                        kind: Kind::Distance,
                        name: format!("d{}", i + 1),
                        rows: pair.iter().map(|q| row(q, None)).collect(),
                        length_mm: Some(length),
                    });
                }
            }
            Kind::Point => {
                for (i, q) in qs.iter().enumerate() {
                    let p = fk.compute(nominal, q);
                    out.push(Group {
                        kind: Kind::Point,
                        name: format!("x{}", i + 1),
                        rows: vec![row(q, Some([p.x, p.y, p.z]))],
                        length_mm: None,
                    });
                }
            }
        }
    }
    out
}

/// The (unit-weight) information of group `g`'s chosen rows.
fn information<const N: usize>(g: &Planned<N>, k: usize) -> DMatrix<f64> {
    let rows: Vec<&Candidate<N>> = g.chosen.iter().map(|&i| &g.pool[i]).collect();
    let mut m = DMatrix::zeros(k, k);
    match g.kind {
        Kind::Point => {
            for r in &rows {
                m += r.c.transpose() * &r.c;
            }
        }
        Kind::Socket => {
            let mut s = DMatrix::zeros(3, k);
            for r in &rows {
                m += r.c.transpose() * &r.c;
                s += &r.c;
            }
            m -= s.transpose() * &s / rows.len() as f64;
        }
        Kind::Plane => {
            let n = g.normal.unwrap_or_else(Vector3::z);
            let (t1, t2) = tangents(&n);
            let centre = rows.iter().map(|r| r.p).sum::<Vector3<f64>>() / rows.len() as f64;
            let a: Vec<RowDVector<f64>> = rows.iter().map(|r| n.transpose() * &r.c).collect();
            let mut s = RowDVector::zeros(k);
            for ai in &a {
                m += ai.transpose() * ai;
                s += ai;
            }
            m -= s.transpose() * &s / rows.len() as f64;
            for t in [t1, t2] {
                let tau: Vec<f64> = rows.iter().map(|r| t.dot(&(r.p - centre))).collect();
                let lambda: f64 = tau.iter().map(|x| x * x).sum();
                if lambda > 1e-9 {
                    let mut b = RowDVector::zeros(k);
                    for (ai, ti) in a.iter().zip(&tau) {
                        b += ai * *ti;
                    }
                    m -= b.transpose() * &b / lambda;
                }
            }
        }
        Kind::Distance => {
            for pair in g.chosen.iter() {
                let (ca, cb) = (&g.pool[2 * pair], &g.pool[2 * pair + 1]);
                let u = (ca.p - cb.p).normalize();
                let a = u.transpose() * (&ca.c - &cb.c);
                m += a.transpose() * &a;
            }
        }
    }
    m
}

/// Candidates a group chooses among: rows, or a distance group's pairs.
fn choices<const N: usize>(g: &Planned<N>) -> usize {
    if g.kind == Kind::Distance {
        g.pool.len() / 2
    } else {
        g.pool.len()
    }
}

/// The criterion (lower is better) of information `m` (σ applied), `None` when singular.
fn criterion(kind: CriterionArg, m: &DMatrix<f64>, work: &[DMatrix<f64>]) -> Option<f64> {
    let k = m.nrows();
    let ridge = 1e-12 * (0..k).map(|i| m[(i, i)]).fold(0.0, f64::max);
    let mut reg = m.clone();
    for i in 0..k {
        reg[(i, i)] += ridge;
    }
    let ch = reg.cholesky()?;
    Some(match kind {
        CriterionArg::D | CriterionArg::O1 | CriterionArg::Random => {
            -2.0 * ch.l().diagonal().iter().map(|d| d.ln()).sum::<f64>()
        }
        CriterionArg::A => ch.inverse().trace(),
        CriterionArg::Kpi => {
            let inv = ch.inverse();
            work.iter()
                .map(|l| (l * &inv * l.transpose()).trace())
                .sum()
        }
    })
}

/// Plans `req` for `nominal` (robot file `file`): the pools, the identifiable parameters, the
/// exchange, the predicted accuracy.
pub fn plan<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    req: &Request<'_, N>,
) -> anyhow::Result<SessionDesign<N>> {
    let pools = pools(nominal, req)?;
    let all = as_groups(nominal, &pools, req.sigma_mm);
    let base_unknown = !(file.base_known() && req.session.points > 0);
    let params = candidates(nominal, file, base_unknown, &[])?;
    let held = unidentifiable(nominal, &all, &params)?;
    let estimated: Vec<Param> = params
        .iter()
        .copied()
        .filter(|p| !held.contains(p))
        .collect();
    let k = estimated.len();
    let s = &req.session;
    let mut groups: Vec<Planned<N>> = pools
        .into_iter()
        .map(|(kind, name, qs, normal)| {
            let need = match kind {
                Kind::Socket => s.sockets.1,
                Kind::Plane => s.planes.1,
                Kind::Distance => s.distances,
                Kind::Point => s.points,
            };
            Planned {
                kind,
                name,
                pool: qs
                    .into_iter()
                    .map(|q| candidate(nominal, &estimated, q))
                    .collect(),
                chosen: (0..need).collect(),
                normal,
            }
        })
        .collect();
    let w = 1.0 / (req.sigma_mm * req.sigma_mm);
    let tool_columns = |qs: &[[f64; N]]| -> Vec<DMatrix<f64>> {
        qs.iter()
            .map(|q| candidate(nominal, &estimated, *q).c)
            .collect()
    };
    let work = tool_columns(req.work);
    let mut rng = Streams::new(req.seed ^ 0x5eed).configs;
    let accuracy_poses = tool_columns(&random_configurations(nominal, ACCURACY_POSES, &mut rng));
    let mut infos: Vec<DMatrix<f64>> = groups.iter().map(|g| information(g, k) * w).collect();
    let total = |infos: &[DMatrix<f64>]| infos.iter().fold(DMatrix::zeros(k, k), |a, b| a + b);
    let score = |m: &DMatrix<f64>| criterion(req.criterion, m, &work).unwrap_or(f64::INFINITY);
    let tool_mm = |m: &DMatrix<f64>| -> f64 {
        let Some(ch) = m.clone().cholesky() else {
            return f64::INFINITY;
        };
        let inv = ch.inverse();
        let v: f64 = accuracy_poses
            .iter()
            .map(|l| (l * &inv * l.transpose()).trace())
            .sum::<f64>()
            / accuracy_poses.len() as f64;
        v.max(0.0).sqrt()
    };
    let mut m = total(&infos);
    let (random_criterion, random_tool_mm) = (score(&m), tool_mm(&m));
    let mut current = random_criterion;
    let (mut exchanges, mut passes) = (0, 0);
    if req.criterion != CriterionArg::Random {
        while passes < PASSES {
            passes += 1;
            let mut changed = false;
            for gi in 0..groups.len() {
                for slot in 0..groups[gi].chosen.len() {
                    let mut best: Option<(usize, f64, DMatrix<f64>)> = None;
                    for c in 0..choices(&groups[gi]) {
                        if groups[gi].chosen.contains(&c) {
                            continue;
                        }
                        let old = groups[gi].chosen[slot];
                        groups[gi].chosen[slot] = c;
                        let info = information(&groups[gi], k) * w;
                        groups[gi].chosen[slot] = old;
                        let trial = &m - &infos[gi] + &info;
                        let v = score(&trial);
                        if v < best.as_ref().map_or(current, |b| b.1) - 1e-9 * current.abs() {
                            best = Some((c, v, info));
                        }
                    }
                    if let Some((c, v, info)) = best {
                        groups[gi].chosen[slot] = c;
                        m = &m - &infos[gi] + &info;
                        infos[gi] = info;
                        current = v;
                        exchanges += 1;
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
    }
    let pool_rows = groups.iter().map(|g| g.pool.len()).sum();
    Ok(SessionDesign {
        planned_tool_mm: tool_mm(&m),
        planned_criterion: current,
        random_tool_mm,
        random_criterion,
        groups,
        estimated,
        held,
        exchanges,
        passes,
        pool_rows,
    })
}

impl<const N: usize> SessionDesign<N> {
    /// The planned session as a constraint file (docs/formats.md) to measure: the chosen rows
    /// of each group, `sigma_mm` as planned, the lengths and tracker coordinates left empty
    /// (what the measurement gives).
    pub fn csv(&self, sigma_mm: f64) -> String {
        let mut out = String::from("kind,group");
        for j in 1..=N {
            let _ = write!(out, ",q{j}");
        }
        out.push_str(",length_mm,sigma_mm,x,y,z\n");
        let mut row = |kind: &str, group: &str, q: &[f64; N]| {
            let _ = write!(out, "{kind},{group}");
            for v in q {
                let _ = write!(out, ",{}", quantize_deg(v.to_degrees()));
            }
            let _ = writeln!(out, ",,{sigma_mm},,,");
        };
        for g in &self.groups {
            match g.kind {
                Kind::Socket | Kind::Plane => {
                    for &i in &g.chosen {
                        row(g.kind.id(), &g.name, &g.pool[i].q);
                    }
                }
                Kind::Distance => {
                    for (n, &i) in g.chosen.iter().enumerate() {
                        for c in [&g.pool[2 * i], &g.pool[2 * i + 1]] {
                            row("distance", &format!("d{}", n + 1), &c.q);
                        }
                    }
                }
                Kind::Point => {
                    for (n, &i) in g.chosen.iter().enumerate() {
                        row("point", &format!("x{}", n + 1), &g.pool[i].q);
                    }
                }
            }
        }
        out
    }

    /// Rows the session needs.
    pub fn rows(&self) -> usize {
        self.groups
            .iter()
            .map(|g| g.chosen.len() * if g.kind == Kind::Distance { 2 } else { 1 })
            .sum()
    }
}
