//! The planning study of Jost et al. 2017 (their §3.3, Table 8, Figure 8): the example arm and
//! cell with varied segment lengths, one arm's KPI, random and D-optimal designs, and the Monte
//! Carlo check of the predicted tool-point covariance.

use crate::calibration::fit_lm;
use crate::formats::cell_file::{HostScene, SceneFile};
use crate::plan::design::{
    self, optimise, CriterionArg, HostCandidate, Neighbourhood, PoseRowsHost, Refinement,
};
use crate::simulation::{self, GeomErrors};
use anyhow::{anyhow, bail};
use kinecal::identify::lm::LmConfig;
use kinecal::planning::capsule::Capsule;
use kinecal::planning::cell::{Scene, Tracker};
use kinecal::planning::selection::Criterion;
use kinecal::{ForwardKinematics, Frame, Joint, Measurement, Robot};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Instant;

/// What every arm of the study is planned and judged with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StudySettings {
    /// Measurement poses per design.
    pub poses: usize,
    /// Feasible candidate poses per arm and setting.
    pub pool: usize,
    /// Random designs averaged per arm and setting.
    pub random_designs: usize,
    /// Most Fedorov exchange passes per design.
    pub passes: u32,
    /// Measurement noise, standard deviation per axis (mm).
    pub noise_mm: f64,
    /// Polish the D and KPI designs by local refinement.
    pub refine: bool,
}

/// The example arm with upper arm `upper` and forearm `forearm` (mm).
pub fn arm(upper: f64, forearm: f64) -> anyhow::Result<Robot<f64, 6, kinecal::Inline<0>>> {
    let lim = |j: Joint<f64>, lo: f64, hi: f64| Joint {
        lower: lo.to_radians(),
        upper: hi.to_radians(),
        ..j
    };
    let rows = [
        lim(Joint::mdh_deg(0.0, 0.0, 0.0, 504.0), -170.0, 170.0),
        lim(Joint::mdh_deg(-90.0, 170.0, -90.0, 0.0), -90.0, 150.0),
        lim(Joint::mdh_deg(0.0, upper, 0.0, 0.0), -80.0, 160.0),
        lim(Joint::mdh_deg(-90.0, 140.0, 0.0, forearm), -180.0, 180.0),
        lim(Joint::mdh_deg(90.0, 0.0, 0.0, 0.0), -135.0, 135.0),
        lim(Joint::mdh_deg(-90.0, 0.0, 0.0, 125.0), -360.0, 360.0),
    ];
    Robot::new(Frame::identity(), rows, Vector3::new(0.0, 0.0, 100.0))
        .map_err(|e| anyhow!("arm: {e:?}"))
}

/// Horizontal reach of an arm of this family (mm): shoulder offset, upper arm, forearm with
/// its offset, flange and tool.
pub fn reach(upper: f64, forearm: f64) -> f64 {
    170.0 + upper + (140.0f64 * 140.0 + forearm * forearm).sqrt() + 225.0
}

/// The example cell (examples/cell/scene.toml) adapted to an arm of this family.
pub fn cell(upper: f64, forearm: f64) -> anyhow::Result<HostScene> {
    let v = Vector3::new;
    let c = |a: Vector3<f64>, b: Vector3<f64>, r: f64| Capsule::new(a, b, r);
    let tracker = Tracker {
        position: v(1000.0, -2700.0, 300.0),
        max_incidence: 30f64.to_radians(),
        beam_radius: 5.0,
    };
    let mut s: HostScene = Scene::new(tracker, Some(-450.0)).map_err(|e| anyhow!("{e:?}"))?;
    let links = [
        (0, c(v(0.0, 0.0, 0.0), v(0.0, 0.0, 150.0), 200.0)),
        (1, c(v(0.0, 0.0, -250.0), v(170.0, 0.0, 0.0), 170.0)),
        (2, c(v(0.0, 0.0, 0.0), v(upper, 0.0, 0.0), 130.0)),
        (
            3,
            c(v(70.0, -100.0, 0.0), v(140.0, forearm - 140.0, 0.0), 110.0),
        ),
        (5, c(v(0.0, -60.0, 0.0), v(0.0, 70.0, 0.0), 85.0)),
        (6, c(v(0.0, 0.0, 0.0), v(0.0, 0.0, 40.0), 45.0)),
    ];
    for (f, cap) in links {
        s.add_link_capsule(f, cap).map_err(|e| anyhow!("{e:?}"))?;
    }
    // The example cell's car side is at x = 1100, 56.5 % of the example arm's reach.
    let shift = 1100.0 / reach(780.0, 760.0) * (reach(upper, forearm) - reach(780.0, 760.0));
    for cap in [
        c(
            v(1900.0 + shift, -2000.0, 100.0),
            v(1900.0 + shift, 2000.0, 100.0),
            800.0,
        ),
        c(
            v(2000.0 + shift, -900.0, 800.0),
            v(2000.0 + shift, 900.0, 800.0),
            600.0,
        ),
        c(v(-1700.0, -3500.0, 500.0), v(-1700.0, 3500.0, 500.0), 800.0),
    ] {
        s.add_obstacle(cap).map_err(|e| anyhow!("{e:?}"))?;
    }
    Ok(s)
}

/// KPI traces (mm²) of the three designs of one arm in one setting.
#[derive(Clone, Debug, Default)]
pub struct Cell {
    pub random: f64,
    pub d: f64,
    pub kpi: f64,
    /// Share of the D and KPI designs' poses that collide (settings without avoidance).
    pub colliding: f64,
}

#[derive(Clone, Debug)]
pub struct ArmResult {
    pub upper: f64,
    pub forearm: f64,
    /// [with collision avoidance, without].
    pub settings: [Cell; 2],
}

pub fn colliding_share<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    scene: &HostScene,
    poses: &[[f64; N]],
) -> f64 {
    let mut fk = ForwardKinematics::new();
    let bad = poses
        .iter()
        .filter(|q| {
            fk.compute(robot, q);
            !scene.check(robot, &fk, true).feasible()
        })
        .count();
    bad as f64 / poses.len().max(1) as f64
}

pub fn study_arm(
    args: &StudySettings,
    upper: f64,
    forearm: f64,
    work: &[[f64; 6]],
    seed: u64,
) -> anyhow::Result<ArmResult> {
    let robot = arm(upper, forearm)?;
    let scene = cell(upper, forearm)?;
    let params = design::plan_params(6)?;
    let params = params.as_slice();
    let mut settings: [Cell; 2] = Default::default();
    for (k, collisions) in [true, false].into_iter().enumerate() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ ((k as u64) << 40));
        let max_draws = 4_000_000;
        let mut random = 0.0;
        for _ in 0..args.random_designs.max(1) {
            let (poses, _) = design::random_design(
                &robot, &scene, params, args.poses, collisions, &mut rng, max_draws,
            )?;
            let qs: Vec<[f64; 6]> = poses.iter().map(|c| c.q).collect();
            random += design::evaluate(&robot, params, &qs, work, args.noise_mm)?.kpi_trace_mm2;
        }
        random /= args.random_designs.max(1) as f64;
        let pool = design::build_pool(
            &robot,
            &scene,
            params,
            args.pool.max(args.poses),
            collisions,
            &mut rng,
            max_draws,
        );
        if pool.candidates.len() < args.poses {
            bail!(
                "arm {upper}/{forearm} mm: only {} feasible poses in {} draws",
                pool.candidates.len(),
                pool.draws
            );
        }
        let mut cands: Vec<HostCandidate<6>> = pool.candidates;
        let basis = design::pool_basis(&cands, params.len())?;
        basis.reduce_pool(&mut cands);
        let wr: Vec<PoseRowsHost> = design::work_rows(&robot, params, work)?
            .iter()
            .map(|g| basis.reduce(g))
            .collect();
        let mut traces = [0.0; 2];
        let mut colliding = 0.0;
        let hood = Neighbourhood {
            robot: &robot,
            scene: &scene,
            params,
            collisions,
        };
        let refinement = Refinement::default();
        for (t, criterion) in traces.iter_mut().zip([Criterion::D, Criterion::Kpi]) {
            // Each design starts from the same pool and refines with its own neighbours.
            let mut own = cands.clone();
            let refine = args.refine.then_some((&hood, &refinement, &mut rng));
            let (design, _) = optimise(
                &mut own,
                &basis,
                &wr,
                criterion,
                args.poses,
                args.passes,
                refine,
            )?;
            let qs: Vec<[f64; 6]> = design.iter().map(|i| own[*i].q).collect();
            *t = design::evaluate(&robot, params, &qs, work, args.noise_mm)?.kpi_trace_mm2;
            if !collisions {
                colliding += 0.5 * colliding_share(&robot, &scene, &qs);
            }
        }
        settings[k] = Cell {
            random,
            d: traces[0],
            kpi: traces[1],
            colliding,
        };
    }
    Ok(ArmResult {
        upper,
        forearm,
        settings,
    })
}

/// Monte Carlo of simulate + identify against the plan's prediction.
pub struct MonteCarlo {
    pub runs: usize,
    pub predicted_trace_mm2: f64,
    /// Σ_s trace of the sample covariance of the identified tool points.
    pub empirical_trace_mm2: f64,
    /// Σ_s mean squared error of the identified tool points against the truth.
    pub empirical_mse_mm2: f64,
    pub seconds: f64,
}

impl MonteCarlo {
    pub fn ratio(&self) -> f64 {
        self.empirical_trace_mm2 / self.predicted_trace_mm2
    }
}

/// Plans a design (`criterion`) of `poses` poses for `robot` in `scene`, then identifies `runs`
/// noisy data sets of a true robot with geometric errors and compares the spread of the
/// identified tool points at `work` with the prediction.
#[allow(clippy::too_many_arguments)]
pub fn monte_carlo<V: kinecal::ValueStorage>(
    robot: &Robot<f64, 6, V>,
    scene: &HostScene,
    criterion: CriterionArg,
    work: &[[f64; 6]],
    poses: usize,
    pool: usize,
    sigma: f64,
    runs: usize,
    seed: u64,
) -> anyhow::Result<MonteCarlo> {
    if runs < 2 {
        bail!("the Monte Carlo check needs at least 2 runs, got {runs}");
    }
    let start = Instant::now();
    let nominal = design::in_base_frame(robot);
    let req = design::PlanRequest {
        scene,
        criterion,
        poses,
        work,
        sigma,
        pool,
        collisions: true,
        passes: 30,
        seed,
        refine: true,
        estimate: &[],
    };
    let p = design::plan(&nominal, &req)?;
    let qs: Vec<[f64; 6]> = p.poses.iter().map(|c| c.q).collect();
    let params = design::plan_params(6)?;
    let mut streams = simulation::Streams::new(seed);
    let truth = simulation::perturb_geometry(&nominal, &GeomErrors::default(), &mut streams.errors);
    let mut fk = ForwardKinematics::new();
    let true_tcp: Vec<Vector3<f64>> = work.iter().map(|q| fk.compute(&truth, q)).collect();
    let mut sum = vec![Vector3::zeros(); work.len()];
    let mut sum2 = vec![Matrix3::zeros(); work.len()];
    let mut mse = 0.0;
    let cfg = LmConfig::default();
    for _ in 0..runs {
        let points = simulation::measure(&truth, &qs, sigma, &mut streams.noise);
        let data: Vec<Measurement<f64, 6>> = qs
            .iter()
            .zip(&points)
            .map(|(q, p)| Measurement::new(*q, *p))
            .collect();
        let fit = fit_lm(&nominal, params.as_slice(), &data, cfg)?;
        for (s, q) in work.iter().enumerate() {
            let e = fk.compute(&fit.robot, q) - true_tcp[s];
            sum[s] += e;
            sum2[s] += e * e.transpose();
            mse += e.norm_squared();
        }
    }
    let r = runs as f64;
    let mut empirical = 0.0;
    for (s1, s2) in sum.iter().zip(&sum2) {
        let mean = s1 / r;
        let cov = (s2 - mean * mean.transpose() * r) / (r - 1.0);
        empirical += cov.trace();
    }
    Ok(MonteCarlo {
        runs,
        predicted_trace_mm2: p.evaluation.kpi_trace_mm2,
        empirical_trace_mm2: empirical,
        empirical_mse_mm2: mse / r,
        seconds: start.elapsed().as_secs_f64(),
    })
}

pub fn stats(v: &[f64]) -> (f64, f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let max = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    (mean, min, max)
}

/// The example cell as a scene file (what examples/cell/scene.toml holds).
pub fn example_scene_file() -> anyhow::Result<SceneFile> {
    let s = cell(780.0, 760.0)?;
    let v3 = |v: &Vector3<f64>| [v.x, v.y, v.z];
    Ok(SceneFile {
        tracker: crate::formats::cell_file::TrackerSpec {
            xyz_mm: v3(&s.tracker().position),
            max_incidence_deg: (s.tracker().max_incidence.to_degrees() * 1e9).round() / 1e9,
            beam_radius_mm: s.tracker().beam_radius,
        },
        floor: s
            .floor_z()
            .map(|z| crate::formats::cell_file::FloorSpec { z_mm: z }),
        link_capsules: s
            .link_capsules()
            .iter()
            .map(|l| crate::formats::cell_file::LinkCapsuleSpec {
                frame: l.frame as usize,
                a_mm: v3(&l.capsule.a),
                b_mm: v3(&l.capsule.b),
                radius_mm: l.capsule.radius,
            })
            .collect(),
        obstacles: s
            .obstacles()
            .iter()
            .map(|o| crate::formats::cell_file::ObstacleSpec {
                a_mm: v3(&o.a),
                b_mm: v3(&o.b),
                radius_mm: o.radius,
            })
            .collect(),
    })
}

/// The lengths `MIN:MAX:STEP` (mm) of `text` (the option `what`): at most 1000 values, within
/// (0, the longest length a robot file takes].
pub fn length_range(text: &str, what: &str) -> anyhow::Result<Vec<f64>> {
    let p: Vec<f64> = text
        .split(':')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow!("{what} `{text}`: expected MIN:MAX:STEP in mm"))?;
    let [lo, hi, step] = p[..] else {
        bail!("{what} `{text}`: expected MIN:MAX:STEP in mm")
    };
    if !(lo.is_finite()
        && hi.is_finite()
        && step.is_finite()
        && step > 0.0
        && lo <= hi
        && lo > 0.0
        && hi <= crate::MAX_LENGTH_MM)
    {
        crate::refuse!(
            "{what} `{text}`: need 0 < MIN ≤ MAX ≤ {} and a finite STEP > 0",
            crate::MAX_LENGTH_MM
        );
    }
    // Counted in f64 first: a tiny step must not wrap the count.
    let n_f = ((hi - lo) / step + 1e-9).floor() + 1.0;
    if n_f.is_nan() || n_f > 1000.0 {
        crate::refuse!("{what} `{text}`: more than 1000 values: use a larger STEP");
    }
    let n = n_f as usize;
    Ok((0..n).map(|i| lo + step * i as f64).collect())
}
