//! Measurement planning on the example cell (examples/cell: an ER20-C10-like arm, a laser
//! tracker about 3 m away, a car body and a wall as capsules, the floor):
//!
//! - every pose of every plan (random, d, o1, a, kpi; with and without collision avoidance)
//!   is feasible by an independent check written here from the definitions (own forward
//!   kinematics from 4×4 matrices, own segment distance by convex minimisation);
//! - the KPI design's predicted TCP covariance trace is ≤ 0.45× that of random feasible poses
//!   and ≤ 0.6× that of the D-optimal design (Jost et al. 2017 report 40–44 % and 10–19 %
//!   improvements), recomputed here with a dense SVD pseudo-inverse;
//! - the command line: negative `--work` values, the CSV and the JSON keys;
//! - the online stepper: its predicted precision falls as it measures its own proposals,
//!   matches the batch prediction, and it stops at the target.

use kinecal_cli::HostRobot;

use kinecal::model::param::ParamSet;
use kinecal::planning::information::{default_tolerance, scaled_rows, PoseRows};
use kinecal::planning::online_design::OnlineDesign;
use kinecal_cli::formats::cell_file::SceneFile;
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::plan::design::{self, CriterionArg, HostCandidate, PlanRequest, PCAP};
use nalgebra::{DMatrix, Matrix4, Vector3, Vector4};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::{Path, PathBuf};
use std::process::Command;

fn cell_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/cell")
}

fn load() -> (RobotFile, HostRobot<6>, SceneFile) {
    let file = RobotFile::load(&cell_dir().join("robot.toml")).unwrap();
    let robot = file.to_robot::<6>().unwrap();
    let scene = SceneFile::load(&cell_dir().join("scene.toml"), 6).unwrap();
    (file, robot, scene)
}

const WORK_DEG: [[f64; 6]; 2] = [
    [0.0, 30.0, 10.0, 0.0, -40.0, 0.0],
    [-20.0, 30.0, 30.0, 0.0, -60.0, 0.0],
];

fn work() -> Vec<[f64; 6]> {
    WORK_DEG.iter().map(|q| q.map(f64::to_radians)).collect()
}

// ---------------------------------------------------------------------------------------
// The independent feasibility check.

/// Joint frames 0..=N (0 = base = identity) from the MDH formula of docs/formats.md "Kinematic model":
/// T_i = Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta + q)·Tz(d), with plain 4×4 products.
fn frames(file: &RobotFile, q_deg: &[f64]) -> Vec<Matrix4<f64>> {
    let rx = |a: f64| {
        let (s, c) = a.sin_cos();
        Matrix4::new(
            1.0, 0.0, 0.0, 0.0, 0.0, c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0,
        )
    };
    let ry = |a: f64| {
        let (s, c) = a.sin_cos();
        Matrix4::new(
            c, 0.0, s, 0.0, 0.0, 1.0, 0.0, 0.0, -s, 0.0, c, 0.0, 0.0, 0.0, 0.0, 1.0,
        )
    };
    let rz = |a: f64| {
        let (s, c) = a.sin_cos();
        Matrix4::new(
            c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        )
    };
    let tr = |x: f64, y: f64, z: f64| {
        Matrix4::new(
            1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, y, 0.0, 0.0, 1.0, z, 0.0, 0.0, 0.0, 1.0,
        )
    };
    let mut t = Matrix4::identity();
    let mut out = vec![t];
    for (j, q) in file.joints.iter().zip(q_deg) {
        t = t
            * rx(j.alpha_deg.to_radians())
            * tr(j.a_mm, 0.0, 0.0)
            * ry(j.beta_deg.unwrap_or(0.0).to_radians())
            * rz((j.theta_deg + q).to_radians())
            * tr(0.0, 0.0, j.d_mm);
        out.push(t);
    }
    out
}

fn apply(t: &Matrix4<f64>, p: [f64; 3]) -> Vector3<f64> {
    let v = t * Vector4::new(p[0], p[1], p[2], 1.0);
    Vector3::new(v.x, v.y, v.z)
}

/// Distance from point `x` to segment `[a, b]` (projection, clamped).
fn point_segment(x: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let l2 = d.norm_squared();
    let t = if l2 > 0.0 {
        ((x - a).dot(&d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + d * t - x).norm()
}

/// Segment–segment distance by ternary search over the first segment's parameter: the
/// distance from a point moving along a segment to a convex set is convex.
fn seg_seg(p0: &Vector3<f64>, p1: &Vector3<f64>, q0: &Vector3<f64>, q1: &Vector3<f64>) -> f64 {
    let f = |s: f64| point_segment(&(p0 + (p1 - p0) * s), q0, q1);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..200 {
        let m1 = lo + (hi - lo) / 3.0;
        let m2 = hi - (hi - lo) / 3.0;
        if f(m1) <= f(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    f(0.5 * (lo + hi)).min(f(0.0)).min(f(1.0))
}

/// Why a pose is infeasible, or None. Written from the scene file's definitions.
fn independent_violation(
    file: &RobotFile,
    scene: &SceneFile,
    q_deg: &[f64],
    collisions: bool,
) -> Option<String> {
    let n = file.joints.len();
    for (i, (j, q)) in file.joints.iter().zip(q_deg).enumerate() {
        let [lo, hi] = j.limits_deg.unwrap_or([-180.0, 180.0]);
        if !(*q >= lo && *q <= hi) {
            return Some(format!("joint {} at {q}° outside [{lo}, {hi}]", i + 1));
        }
    }
    let f = frames(file, q_deg);
    let point = apply(&f[n], file.tool.xyz_mm);
    let z = Vector3::new(f[n][(0, 2)], f[n][(1, 2)], f[n][(2, 2)]);
    let tracker = Vector3::from(scene.tracker.xyz_mm);
    let beam_dir = (tracker - point).normalize();
    let incidence = z.dot(&beam_dir).clamp(-1.0, 1.0).acos().to_degrees();
    if incidence > scene.tracker.max_incidence_deg {
        return Some(format!("incidence {incidence}°"));
    }
    if !collisions {
        return None;
    }
    let links: Vec<(usize, Vector3<f64>, Vector3<f64>, f64)> = scene
        .link_capsules
        .iter()
        .map(|c| {
            (
                c.frame,
                apply(&f[c.frame], c.a_mm),
                apply(&f[c.frame], c.b_mm),
                c.radius_mm,
            )
        })
        .collect();
    if let Some(fl) = &scene.floor {
        for (k, l) in links.iter().enumerate() {
            if l.1.z.min(l.2.z) - l.3 <= fl.z_mm {
                return Some(format!("link capsule {k} below the floor"));
            }
        }
    }
    let mut bodies: Vec<usize> = links.iter().map(|l| l.0).collect();
    bodies.sort_unstable();
    bodies.dedup();
    let rank = |frame: usize| bodies.iter().position(|b| *b == frame).unwrap() as i64;
    for i in 0..links.len() {
        for j in i + 1..links.len() {
            if (rank(links[i].0) - rank(links[j].0)).abs() < 2 {
                continue;
            }
            let d = seg_seg(&links[i].1, &links[i].2, &links[j].1, &links[j].2)
                - links[i].3
                - links[j].3;
            if d <= 0.0 {
                return Some(format!("link capsules {i} and {j} collide ({d} mm)"));
            }
        }
    }
    let obstacles: Vec<(Vector3<f64>, Vector3<f64>, f64)> = scene
        .obstacles
        .iter()
        .map(|o| (Vector3::from(o.a_mm), Vector3::from(o.b_mm), o.radius_mm))
        .collect();
    for (i, l) in links.iter().enumerate() {
        for (j, o) in obstacles.iter().enumerate() {
            if seg_seg(&l.1, &l.2, &o.0, &o.1) - l.3 - o.2 <= 0.0 {
                return Some(format!("link capsule {i} hits obstacle {j}"));
            }
        }
    }
    let rb = scene.tracker.beam_radius_mm;
    for (j, o) in obstacles.iter().enumerate() {
        if seg_seg(&tracker, &point, &o.0, &o.1) - rb - o.2 <= 0.0 {
            return Some(format!("obstacle {j} cuts the beam"));
        }
    }
    for (i, l) in links.iter().enumerate() {
        // The reflector's own body (the last frame) is exempt from the beam test.
        if l.0 == n {
            continue;
        }
        if seg_seg(&tracker, &point, &l.1, &l.2) - rb - l.3 <= 0.0 {
            return Some(format!("link capsule {i} cuts the beam"));
        }
    }
    None
}

// ---------------------------------------------------------------------------------------
// Independent KPI: dense Jacobian, SVD pseudo-inverse.

fn dense_kpi(robot: &HostRobot<6>, poses: &[[f64; 6]], work: &[[f64; 6]], sigma: f64) -> f64 {
    let robot = design::in_base_frame(robot);
    let params = ParamSet::<PCAP>::full(6, true).unwrap();
    let n = params.len();
    let rows = |q: &[f64; 6]| -> PoseRows<f64, PCAP> {
        let mut fk = kinecal::ForwardKinematics::new();
        fk.compute(&robot, q);
        let mut g = [[0.0; PCAP]; 3];
        scaled_rows(&robot, &fk, params.as_slice(), &mut g).unwrap();
        g
    };
    let all: Vec<_> = poses.iter().map(rows).collect();
    let j = DMatrix::from_fn(3 * all.len(), n, |i, k| all[i / 3][i % 3][k]);
    let svd = j.svd(true, true);
    let smax = svd.singular_values.max();
    let vt = svd.v_t.unwrap();
    // C = σ² V S⁻² Vᵀ over the singular values above the threshold.
    let mut c = DMatrix::zeros(n, n);
    for (k, s) in svd.singular_values.iter().enumerate() {
        if *s > 1e-6 * smax {
            let v = vt.row(k).transpose();
            c += &v * v.transpose() * (sigma * sigma / (s * s));
        }
    }
    work.iter()
        .map(|q| {
            let g = rows(q);
            let js = DMatrix::from_fn(3, n, |i, k| g[i][k]);
            (&js * &c * js.transpose()).trace()
        })
        .sum()
}

fn plan_with(criterion: CriterionArg, collisions: bool, seed: u64) -> (Vec<[f64; 6]>, f64) {
    let (_, robot, scene_file) = load();
    let scene = scene_file.to_scene().unwrap();
    let w = work();
    let req = PlanRequest {
        scene: &scene,
        criterion,
        poses: 60,
        work: &w,
        sigma: 0.01,
        pool: 2000,
        collisions,
        passes: 30,
        seed,
        refine: true,
        estimate: &[],
    };
    let p = design::plan(&robot, &req).unwrap();
    (
        p.poses.iter().map(|c| c.q).collect(),
        p.evaluation.kpi_trace_mm2,
    )
}

#[test]
fn every_planned_pose_is_feasible_and_kpi_beats_random_and_d() {
    let (file, robot, scene) = load();
    let w = work();
    let mut kpi = std::collections::BTreeMap::new();
    let mut jobs = Vec::new();
    for collisions in [true, false] {
        for (criterion, seeds) in [
            (CriterionArg::Random, &[1u64, 2, 3, 4, 5][..]),
            (CriterionArg::D, &[1][..]),
            (CriterionArg::O1, &[2][..]),
            (CriterionArg::A, &[1][..]),
            (CriterionArg::Kpi, &[1, 2][..]),
        ] {
            jobs.extend(seeds.iter().map(|&seed| (collisions, criterion, seed)));
        }
    }
    // The 20 designs are independent (the planner runs on one core): planned side by side,
    // checked in order.
    let plans: Vec<_> = std::thread::scope(|s| {
        let running: Vec<_> = jobs
            .iter()
            .map(|&(collisions, criterion, seed)| {
                s.spawn(move || plan_with(criterion, collisions, seed))
            })
            .collect();
        running.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for (&(collisions, criterion, seed), (poses, predicted)) in jobs.iter().zip(plans) {
        assert_eq!(poses.len(), 60);
        let mut distinct = poses.clone();
        distinct.sort_by(|a, b| a.partial_cmp(b).unwrap());
        distinct.dedup();
        assert_eq!(distinct.len(), 60, "{criterion:?}: a pose repeated");
        for q in &poses {
            let q_deg: Vec<f64> = q.iter().map(|v| v.to_degrees()).collect();
            if let Some(why) = independent_violation(&file, &scene, &q_deg, collisions) {
                panic!("{criterion:?} (collisions {collisions}, seed {seed}) planned an infeasible pose {q_deg:?}: {why}");
            }
        }
        let dense = dense_kpi(&robot, &poses, &w, 0.01);
        assert!(
            (dense - predicted).abs() <= 1e-6 * dense,
            "{criterion:?}: predicted {predicted} vs dense {dense}"
        );
        kpi.entry((collisions, criterion.name()))
            .or_insert_with(Vec::new)
            .push(dense);
    }
    let mean = |v: &Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
    for collisions in [true, false] {
        let random = mean(&kpi[&(collisions, "random")]);
        let d = mean(&kpi[&(collisions, "d")]);
        let o1 = mean(&kpi[&(collisions, "o1")]);
        let a = mean(&kpi[&(collisions, "a")]);
        let k = &kpi[&(collisions, "kpi")];
        eprintln!("collisions {collisions}: random {random:.3e}, d {d:.3e}, o1 {o1:.3e}, a {a:.3e}, kpi {k:?} mm²");
        for v in k {
            assert!(
                *v <= 0.45 * random,
                "KPI design {v:.3e} vs random {random:.3e}"
            );
            assert!(*v <= 0.6 * d, "KPI design {v:.3e} vs D-optimal {d:.3e}");
            assert!(*v <= 0.6 * o1, "KPI design {v:.3e} vs O1-optimal {o1:.3e}");
            assert!(*v < a, "KPI design {v:.3e} vs A-optimal {a:.3e}");
        }
        // Different seeds (different pools and starts) agree closely.
        assert!(
            (k[0] - k[1]).abs() <= 0.05 * k[0],
            "KPI designs of two seeds: {k:?}"
        );
    }
    // Designs without collision avoidance are at least as good (more freedom) but collide.
    assert!(mean(&kpi[&(false, "kpi")]) <= 1.02 * mean(&kpi[&(true, "kpi")]));
}

#[test]
fn plan_command_accepts_negative_work_values_and_writes_csv_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.csv");
    let cell = cell_dir();
    let output = Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
        .args(["plan", "--robot"])
        .arg(cell.join("robot.toml"))
        .arg("--scene")
        .arg(cell.join("scene.toml"))
        .args([
            "--poses",
            "25",
            "--criterion",
            "kpi",
            "--work=-20,30,30,0,-60,0",
            "--work",
            "0,30,10,0,-40,0",
            "--seed",
            "7",
        ])
        .args(["--noise-mm", "0.02", "--pool", "800", "--json", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(v["criterion"], "kpi");
    assert_eq!(v["poses"], 25);
    assert!(v["kpi_trace_mm2"].as_f64().unwrap() > 0.0);
    assert!(v["min_clearance_mm"].as_f64().unwrap() > 0.0);
    let inc = v["max_incidence_deg"].as_f64().unwrap();
    assert!(inc > 0.0 && inc <= 30.0);
    let (file, _, scene) = load();
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&header[..6], &["q1", "q2", "q3", "q4", "q5", "q6"]);
    let mut rows = 0;
    for l in lines {
        let q: Vec<f64> = l.split(',').take(6).map(|x| x.parse().unwrap()).collect();
        assert_eq!(independent_violation(&file, &scene, &q, true), None, "{l}");
        rows += 1;
    }
    assert_eq!(rows, 25);
    assert!(!String::from_utf8_lossy(&output.stderr).contains("radians"));
    // A configuration in radians was taken as degrees without a word: now warned, with the
    // degrees meant; a pose near zero in whole degrees beyond ±3 is a working configuration.
    let plan_at = |work: &str| {
        let run = Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
            .args(["plan", "--robot"])
            .arg(cell.join("robot.toml"))
            .args(["--poses", "10", "--criterion", "kpi", "--pool", "200"])
            .arg(format!("--work={work}"))
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        String::from_utf8_lossy(&run.stderr).to_string()
    };
    let err = plan_at("0,-1.57,1.57,0,1.57,0");
    assert!(
        err.contains("if these are radians") && err.contains("--work=0,-90,90,0,90,0"),
        "{err}"
    );
    assert!(!plan_at("0,5,2,0,-4,0").contains("radians"));
    // Whole radians too: within ±3, every value whole.
    let err = plan_at("0,-1,1,0,1,0");
    assert!(err.contains("--work=0,-57,57,0,57,0"), "{err}");
    let err = plan_at("3,-1,1,0,1,0");
    assert!(err.contains("--work=172,-57,57,0,57,0"), "{err}");
    // A malformed work configuration is a one-line error.
    let bad = Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
        .args(["plan", "--robot"])
        .arg(cell.join("robot.toml"))
        .arg("--scene")
        .arg(cell.join("scene.toml"))
        .args([
            "--poses",
            "10",
            "--criterion",
            "d",
            "--work=-20,30,x,0,-60,0",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("--work") && err.trim().lines().count() == 1,
        "{err}"
    );
}

#[test]
fn online_stepper_reaches_the_target_precision_with_its_own_proposals() {
    let (_, robot, scene_file) = load();
    let scene = scene_file.to_scene().unwrap();
    let robot = design::in_base_frame(&robot);
    let params = design::plan_params(6).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    let mut pool = design::build_pool(
        &robot,
        &scene,
        params.as_slice(),
        1500,
        true,
        &mut rng,
        1_000_000,
    )
    .candidates;
    let basis = design::pool_basis(&pool, params.len()).unwrap();
    basis.reduce_pool(&mut pool);
    let w = work();
    let sigma = 0.01;
    // Target: what a 40-pose KPI design reaches, plus 10 %.
    let (_, k40) = {
        let mut p2: Vec<HostCandidate<6>> = pool.clone();
        let wr: Vec<_> = design::work_rows(&robot, params.as_slice(), &w)
            .unwrap()
            .iter()
            .map(|g| basis.reduce(g))
            .collect();
        let (d, _) = design::optimise::<6, kinecal_cli::HostValues>(
            &mut p2,
            &basis,
            &wr,
            kinecal::planning::selection::Criterion::Kpi,
            40,
            30,
            None,
        )
        .unwrap();
        let qs: Vec<[f64; 6]> = d.iter().map(|i| p2[*i].q).collect();
        (
            qs.clone(),
            design::evaluate(&robot, params.as_slice(), &qs, &w, sigma).unwrap(),
        )
    };
    let worst40 = k40.tool_std_mm.iter().cloned().fold(0.0, f64::max);
    let target = worst40 * 1.1;
    let mut online = OnlineDesign::<f64, 6, kinecal_cli::HostValues, PCAP, 4>::new(
        robot.clone(),
        params.clone(),
        basis.clone(),
        &w,
        sigma,
        target,
    )
    .unwrap();
    let mut measured: Vec<[f64; 6]> = Vec::new();
    let mut last = f64::INFINITY;
    let mut first_known = None;
    loop {
        let i = online.propose(&pool).expect("a proposal");
        assert!(!pool[i].selected);
        let status = online.add_candidate(&mut pool, i).unwrap();
        measured.push(pool[i].q);
        assert_eq!(status.measurements, measured.len());
        if let Some(std) = status.tool_std {
            first_known.get_or_insert(measured.len());
            assert!(
                status.worst_std <= last * (1.0 + 1e-9),
                "precision got worse: {} after {last}",
                status.worst_std
            );
            last = status.worst_std;
            // Agrees with the batch prediction from scratch.
            let ev = design::evaluate(&robot, params.as_slice(), &measured, &w, sigma).unwrap();
            for (a, b) in std.iter().zip(&ev.tool_std_mm) {
                assert!((a - b).abs() <= 1e-4 * b, "online {a} vs batch {b}");
            }
        } else {
            assert!(!status.reached);
        }
        if status.reached {
            assert!(status.worst_std <= target);
            break;
        }
        assert!(
            measured.len() < 120,
            "target {target} not reached after 120 poses (now {last})"
        );
    }
    let first_known = first_known.unwrap();
    // Every identifiable direction needs ≥ rank/3 poses; greedy gets there quickly, and
    // reaches a 40-pose exchange design's precision (+10 %) with about as many poses.
    assert!(
        first_known <= basis.rank(),
        "first full-rank prediction after {first_known} poses"
    );
    assert!(
        measured.len() <= 60,
        "{} poses to reach {target}",
        measured.len()
    );
    eprintln!(
        "online: determined after {first_known} poses, target {target:.5} mm reached after {}",
        measured.len()
    );
    let _ = default_tolerance::<f64>();
}

#[test]
fn example_scene_file_is_the_studys_cell_and_round_trips() {
    let (_, _, scene) = load();
    let built = kinecal_cli::plan::study::example_scene_file().unwrap();
    assert_eq!(
        scene, built,
        "examples/cell/scene.toml differs from study::cell(780, 760)"
    );
    let text = scene.to_toml().unwrap();
    assert_eq!(SceneFile::parse(&text, "round-trip", 6).unwrap(), scene);
    // Errors name the file, line and column.
    let bad = text.replacen("frame = 2", "frame = 9", 1);
    let e = SceneFile::parse(&bad, "cell.toml", 6)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("cell.toml:") && e.contains("frame 9"), "{e}");
    let line: usize = e.split(':').nth(1).unwrap().parse().unwrap();
    assert!(
        bad.lines()
            .nth(line - 1)
            .unwrap()
            .contains("[[link_capsules]]")
            || bad.lines().nth(line - 1).unwrap().contains("frame = 9"),
        "{e}"
    );
    let e = SceneFile::parse("[tracker]\nxyz_mm = [1, 2]\n", "s.toml", 6)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("s.toml:2:"), "{e}");
}

#[test]
fn plans_without_collision_avoidance_report_their_collisions() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.csv");
    let cell = cell_dir();
    let output = Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
        .args(["plan", "--robot"])
        .arg(cell.join("robot.toml"))
        .arg("--scene")
        .arg(cell.join("scene.toml"))
        .args([
            "--poses",
            "40",
            "--criterion",
            "d",
            "--work=0,30,10,0,-40,0",
            "--no-collisions",
            "--no-refine",
            "--pool",
            "800",
            "--json",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let (file, _, scene) = load();
    let text = std::fs::read_to_string(&out).unwrap();
    let colliding = text
        .lines()
        .skip(1)
        .filter(|l| {
            let q: Vec<f64> = l.split(',').take(6).map(|x| x.parse().unwrap()).collect();
            // Limits and incidence always hold; collisions are what was not avoided.
            assert_eq!(independent_violation(&file, &scene, &q, false), None);
            independent_violation(&file, &scene, &q, true).is_some()
        })
        .count();
    assert_eq!(v["colliding_poses"].as_u64().unwrap() as usize, colliding);
    assert!(
        colliding > 0,
        "a D design ignoring collisions is expected to collide somewhere"
    );
    assert!(v["min_clearance_mm"].as_f64().unwrap() <= 0.0);
}

/// `plan --noise-from D.csv` takes the noise from a tracker file's stated σ: the RMS of its
/// `sx_mm, sy_mm, sz_mm`. The KPI design does not depend on σ (it scales every covariance),
/// so the plan equals `--noise-mm` at that RMS, and the predicted trace grows with σ²; a file
/// without σ columns is refused.
#[test]
fn plan_takes_the_noise_from_the_trackers_stated_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let cell = cell_dir();
    let plan = |noise: &[&str]| {
        let out = dir.path().join("p.csv");
        let o = Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
            .args(["plan", "--robot"])
            .arg(cell.join("robot.toml"))
            .arg("--scene")
            .arg(cell.join("scene.toml"))
            .args([
                "--poses",
                "12",
                "--criterion",
                "kpi",
                "--work=-20,30,30,0,-60,0",
            ])
            .args(["--pool", "300", "--passes", "3", "--no-refine", "--json"])
            .args(noise)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let v: Option<serde_json::Value> = serde_json::from_slice(&o.stdout).ok();
        (
            o.status.code(),
            v,
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    // σ of 0.01, 0.02 and 0.03 mm on alternate rows: RMS √((0.01² + 0.02² + 0.03²)/3).
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,x,y,z,sx_mm,sy_mm,sz_mm\n");
    for k in 0..30 {
        csv += &format!("{k},0,0,0,0,0,1000,0,500,0.01,0.02,0.03\n");
    }
    let sigma_file = dir.path().join("sigma.csv");
    std::fs::write(&sigma_file, &csv).unwrap();
    let rms = ((0.01f64.powi(2) + 0.02f64.powi(2) + 0.03f64.powi(2)) / 3.0).sqrt();
    let (code, from_file, err) = plan(&["--noise-from", sigma_file.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    let from_file = from_file.unwrap();
    let (_, given, _) = plan(&["--noise-mm", &format!("{rms}")]);
    let given = given.unwrap();
    let (_, tenfold, _) = plan(&["--noise-mm", &format!("{}", 10.0 * rms)]);
    let tenfold = tenfold.unwrap();
    let trace = |v: &serde_json::Value| v["kpi_trace_mm2"].as_f64().unwrap();
    assert!((from_file["noise_mm"].as_f64().unwrap() - rms).abs() < 1e-12);
    assert!((trace(&from_file) - trace(&given)).abs() <= 1e-9 * trace(&given));
    let ratio = trace(&tenfold) / trace(&given);
    assert!((ratio - 100.0).abs() < 1e-6, "{ratio}");
    // No σ columns: refused (exit 2) with what to do.
    let plain = dir.path().join("plain.csv");
    std::fs::write(&plain, "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n").unwrap();
    let (code, _, err) = plan(&["--noise-from", plain.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("sx_mm") && err.contains("--noise-mm"), "{err}");
}

/// A design with fewer equations than the directions it is to determine: one pose predicted a
/// tool σ of 0.0097 mm where ten predicted 0.0158 mm (the prediction covers only the
/// directions a design determines), and `identify` refuses such a session. Refused now (exit
/// 2) with how many poses are needed, for every criterion; at that number it plans, and its
/// prediction covers every direction of the pool.
#[test]
fn a_design_with_fewer_equations_than_directions_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.csv");
    let cell = cell_dir();
    let run = |poses: &str, criterion: &str| {
        Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
            .args(["plan", "--robot"])
            .arg(cell.join("robot.toml"))
            .args(["--poses", poses, "--criterion", criterion])
            .args(["--work=0,-60,90,0,30,0", "--pool", "300", "--json", "--out"])
            .arg(&out)
            .output()
            .unwrap()
    };
    let mut need = 0;
    for (poses, criterion) in [("1", "d"), ("3", "kpi"), ("2", "random")] {
        let o = run(poses, criterion);
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert_eq!(o.status.code(), Some(2), "{criterion}: {err}");
        assert!(err.contains("plan at least"), "{err}");
        assert!(!out.exists());
        if criterion == "d" {
            let at = err.find("plan at least ").unwrap() + "plan at least ".len();
            need = err[at..]
                .split(' ')
                .next()
                .unwrap()
                .parse::<usize>()
                .unwrap();
        }
    }
    let o = run(&need.to_string(), "d");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["identifiable_directions"].as_u64().unwrap() as usize > 3 * (need - 1));
}
