//! Joint couplings (`[[couplings]]`, docs/formats.md) honoured everywhere: forward kinematics
//! against the uncoupled model at converted angles and against the independent reference,
//! effect and joint Jacobians against central differences, the PSO fitness, the LM and its
//! snapshot, planning, frames from sweeps, the robot file, and the command line (`identify`
//! on coupled vs pre-converted data, `compensate` in readings, refused couplings, the `check`
//! hint).

use kinecal::compensate::{compensate, Config, Target};
use kinecal::forward::ForwardKinematics;
use kinecal::frames::circle_point::{base_from_sweeps, FramesError};
use kinecal::identify::fitness::{JointTrig, Objective, PositionFitness};
use kinecal::identify::lm::{FixedLevenberg, Levenberg, LmConfig};
use kinecal::model::coupling::{CouplingError, Couplings};
use kinecal::model::param::{Param, ParamSet};
use kinecal::planning::cell::{Scene, Tracker};
use kinecal::planning::information::{scaled_rows, PoseRows};
use kinecal::{Measurement, Robot, RobotError};
use kinecal_cli::formats::measurements::{self, Dataset};
use kinecal_cli::formats::robot_file::{deg_exact, RobotFile};
use kinecal_cli::simulation::sweeps::{sweep_data, SweepSet};
use kinecal_cli::VCAP;
use kinecal_host::reference::RefRobot;
use nalgebra::{Matrix3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::{Path, PathBuf};

use crate::common::{f64s, json_of, kinecal, location, run_on, s, simulate, ur10_dir, write};

/// A FANUC-like 6R arm whose J3 is read from the horizontal: q3 = J3 + J2.
const FANUC: &str = include_str!("../data/fanuc_j3_horizontal.toml");

const FANUC_COUPLING: &str = "[[couplings]]\njoint = 3\nfrom = 2\nratio = 1.0\n";

/// A 7R arm with two couplings of other ratios and pairs: q4 = r4 − 1.3·r2, q7 = r7 + 0.25·r6.
const ARM7: &str = include_str!("../data/arm7_coupled.toml");

fn fanuc_text() -> String {
    format!("{FANUC}{FANUC_COUPLING}")
}

fn parse(text: &str) -> RobotFile {
    RobotFile::parse(text, "test.toml").unwrap()
}

/// The same file without its couplings.
fn uncoupled(f: &RobotFile) -> RobotFile {
    let mut u = f.clone();
    u.couplings.clear();
    u
}

/// Model angles of readings, written independently of the library: q_j += ratio · r_from.
fn to_model(f: &RobotFile, r: &[f64]) -> Vec<f64> {
    let mut q = r.to_vec();
    for c in &f.couplings {
        q[c.joint - 1] += c.ratio * r[c.from - 1];
    }
    q
}

/// Random readings (rad) within the file's limits.
fn readings(f: &RobotFile, rng: &mut Xoshiro256PlusPlus) -> Vec<f64> {
    (0..f.joint_count())
        .map(|j| {
            let [lo, hi] = f.limits_deg(j);
            rng.random_range(lo..hi).to_radians()
        })
        .collect()
}

fn arr<const N: usize>(q: &[f64]) -> [f64; N] {
    std::array::from_fn(|i| q[i])
}

fn rotation(f: &kinecal::Frame<f64>) -> Matrix3<f64> {
    f.rotation()
}

// ---------------------------------------------------------------------------------------------
// Library: forward kinematics, Jacobians, fitness, LM, planning.

fn fk_checks<const N: usize>(text: &str, seed: u64) {
    let f = parse(text);
    assert!(!f.couplings.is_empty());
    let coupled: Robot<f64, N, VCAP> = f.to_robot().unwrap();
    let plain: Robot<f64, N, VCAP> = uncoupled(&f).to_robot().unwrap();
    assert_eq!(coupled.couplings().len(), f.couplings.len());
    assert!(plain.couplings().is_empty());
    let reference = RefRobot::from_file(&f);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let (mut a, mut b) = (ForwardKinematics::new(), ForwardKinematics::new());
    let mut moved = 0f64;
    for _ in 0..300 {
        let r = readings(&f, &mut rng);
        let q = to_model(&f, &r);
        let pc = a.compute(&coupled, &arr::<N>(&r));
        let pu = b.compute(&plain, &arr::<N>(&q));
        assert!(
            (pc - pu).norm() <= 1e-9,
            "coupled {pc} vs uncoupled at model angles {pu}"
        );
        assert!((rotation(&a.flange_pose()) - rotation(&b.flange_pose())).norm() <= 1e-12);
        let pr = reference.point(&r);
        assert!((pc - pr).norm() <= 1e-9, "library {pc} vs reference {pr}");
        assert!((rotation(&a.flange_pose()) - reference.tool_rotation(&r)).norm() <= 1e-12);
        assert_eq!(a.q, arr::<N>(&r), "fk.q stays the readings");
        // The couplings matter here: the uncoupled model at the readings is elsewhere.
        moved = moved.max((b.compute(&plain, &arr::<N>(&r)) - pc).norm());
        // Readings → model angles → readings.
        let c = coupled.couplings();
        let back = c.to_readings(&c.to_model(&arr::<N>(&r)));
        for (x, y) in back.iter().zip(&r) {
            assert!((x - y).abs() <= 1e-15 * (1.0 + y.abs()));
        }
    }
    assert!(
        moved > 10.0,
        "the couplings must change the point: {moved} mm"
    );
}

#[test]
fn fk_of_coupled_robot_is_fk_at_model_angles_and_the_reference() {
    fk_checks::<6>(&fanuc_text(), 1);
    fk_checks::<7>(ARM7, 2);
}

/// Effects on the `from` joint and on the coupled joint: every effect column and the joint
/// Jacobian (∂/∂readings, through the couplings) against central differences of the reference.
fn jacobian_checks<const N: usize>(text: &str, effects: &str, seed: u64) {
    let f = parse(&format!("{text}{effects}"));
    let robot: Robot<f64, N, VCAP> = f.to_robot().unwrap();
    assert!(!robot.effects().is_empty() && !robot.couplings().is_empty());
    let reference = RefRobot::from_robot(&robot);
    let independent = RefRobot::from_file(&f);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut fk = ForwardKinematics::<f64, N>::new();
    let close = |a: &Vector3<f64>, b: &Vector3<f64>| (a - b).norm() <= 1e-6 * b.norm() + 1e-7;
    let mut params: Vec<Param> = (0..robot.effects().values().len())
        .map(|k| Param::Effect(k as u16))
        .collect();
    params.extend([
        Param::Theta(1),
        Param::Theta(2),
        Param::Alpha(2),
        Param::D(3),
    ]);
    for _ in 0..40 {
        let r = readings(&f, &mut rng);
        let p = fk.compute(&robot, &arr::<N>(&r));
        assert!((p - independent.point(&r)).norm() <= 1e-9);
        for prm in &params {
            let c = fk.column(&robot, *prm).unwrap();
            let want = reference.dp_dparam(&r, *prm);
            assert!(close(&c, &want), "{}: {c} vs {want}", prm.name(&robot));
        }
        let (lin, ang) = fk.joint_jacobian(&robot);
        for j in 0..N {
            let want = reference.dp_dq(&r, j);
            assert!(
                close(&lin[j], &want),
                "dp/dr{}: {} vs {want}",
                j + 1,
                lin[j]
            );
            let want = reference.dr_dq(&r, j);
            assert!((ang[j] - want).norm() <= 1e-8, "dR/dr{}", j + 1);
        }
    }
}

#[test]
fn effect_and_joint_jacobian_columns_follow_the_chain_rule() {
    let fanuc_effects = r#"[[effects]]
kind = "joint-cyclic"
joint = 2
values = [0.002, -0.001]
[[effects]]
kind = "joint-scale"
joint = 2
values = [0.0015]
[[effects]]
kind = "joint-cyclic"
joint = 3
order = 2
values = [-0.0007, 0.0012]
"#;
    jacobian_checks::<6>(&fanuc_text(), fanuc_effects, 3);
    let arm7_effects = r#"[[effects]]
kind = "joint-cyclic"
joint = 2
values = [0.001, 0.002]
[[effects]]
kind = "joint-scale"
joint = 6
values = [-0.002]
[[effects]]
kind = "joint-scale"
joint = 4
values = [0.001]
"#;
    jacobian_checks::<7>(ARM7, arm7_effects, 4);
}

#[test]
fn compliance_and_table_with_couplings_match_the_reference() {
    let effects = r#"[[effects]]
kind = "joint-compliance"
joint = 3
values = [0.0004]
[[effects]]
kind = "joint-compliance"
joint = 2
values = [0.0003]
[[effects]]
kind = "joint-table"
joint = 2
step_deg = 20.0
values = [0.001, -0.002, 0.0005, 0.0, 0.001, 0.002, -0.001, 0.0, 0.0005, 0.001, -0.0015, 0.0, 0.001]
"#;
    let f = parse(&format!("{}{effects}", fanuc_text()));
    let robot: Robot<f64, 6, VCAP> = f.to_robot().unwrap();
    let reference = RefRobot::from_file(&f);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    for _ in 0..200 {
        let r = readings(&f, &mut rng);
        let p = fk.compute(&robot, &arr::<6>(&r));
        assert!((p - reference.point(&r)).norm() <= 1e-9);
        // The geometry sees C · (r + dq(r)).
        let qg = reference.corrected(&r);
        for (a, b) in fk.q_geometric.iter().zip(&qg) {
            assert!((a - b).abs() <= 1e-14);
        }
    }
}

#[test]
fn couplings_are_validated_and_kept_by_cast_capacity_and_clone() {
    let f = parse(&fanuc_text());
    let mut r: Robot<f64, 6, VCAP> = f.to_robot().unwrap();
    let before = r.clone();
    for (j, from, ratio, err) in [
        (2, 2, 1.0, CouplingError::SameJoint),
        (6, 1, 1.0, CouplingError::OutOfRange),
        (4, 9, 1.0, CouplingError::OutOfRange),
        (4, 3, f64::NAN, CouplingError::NotFinite),
        (4, 3, f64::INFINITY, CouplingError::NotFinite),
        (2, 0, 1.0, CouplingError::Twice),
        (4, 2, 1.0, CouplingError::Chain),
        (1, 0, 1.0, CouplingError::Chain),
    ] {
        assert_eq!(
            r.set_coupling(j, from, ratio),
            Err(RobotError::BadCoupling(err)),
            "joint {j} from {from}"
        );
        assert_eq!(r, before, "a refused coupling leaves the robot unchanged");
    }
    // A second, independent coupling is fine; removing restores the first state.
    r.set_coupling(4, 3, 0.5).unwrap();
    assert_eq!(r.couplings().get(4), Some((3, 0.5)));
    assert_eq!(
        r.couplings().dependents(1).collect::<Vec<_>>(),
        vec![(2, 1.0)]
    );
    r.remove_coupling(4);
    assert_eq!(r, before);
    let r32: Robot<f32, 6, VCAP> = r.cast().unwrap();
    assert_eq!(r32.couplings().get(2), Some((1, 1.0f32)));
    let r64: Robot<f64, 6, 64> = r.with_capacity::<64>().unwrap();
    assert_eq!(r64.couplings(), r.couplings());
    assert_eq!(r.clone().couplings(), r.couplings());
    // f32 FK of the cast robot agrees with f64 to f32 rounding.
    let q = [0.3, -0.4, 0.9, 0.2, 0.7, -0.1];
    let p64 = ForwardKinematics::<f64, 6>::new().compute(&r, &q);
    let p32 = ForwardKinematics::<f32, 6>::new().compute(&r32, &q.map(|x| x as f32));
    assert!((p64 - p32.map(|x| x as f64)).norm() < 2e-3);
    let mut c = Couplings::<f64, 3>::new();
    c.add(2, 0, 2.0).unwrap();
    assert_eq!(c.to_model(&[1.0, 5.0, 3.0]), [1.0, 5.0, 5.0]);
    assert_eq!(c.to_readings(&[1.0, 5.0, 5.0]), [1.0, 5.0, 3.0]);
    let mut cols = [1.0, 10.0, 100.0];
    c.reading_columns(&mut cols);
    assert_eq!(cols, [201.0, 10.0, 100.0]);
    r.clear_couplings();
    assert!(r.couplings().is_empty());
    // At most MAX_COUPLINGS, whatever the number of joints.
    let mut r7: Robot<f64, 7, VCAP> = parse(ARM7).to_robot().unwrap();
    r7.clear_couplings();
    for j in 1..=kinecal::model::coupling::MAX_COUPLINGS {
        r7.set_coupling(j, 0, 0.5).unwrap();
    }
    let full = r7.clone();
    assert_eq!(
        r7.set_coupling(6, 0, 0.5),
        Err(RobotError::BadCoupling(CouplingError::Capacity))
    );
    assert_eq!(r7, full);
    // Kept in joint order whatever the order they were added in.
    let mut a = Couplings::<f64, 7>::new();
    let mut b = Couplings::<f64, 7>::new();
    a.add(5, 0, 1.0).unwrap();
    a.add(2, 1, -1.0).unwrap();
    b.add(2, 1, -1.0).unwrap();
    b.add(5, 0, 1.0).unwrap();
    assert_eq!(a, b);
    assert_eq!(
        a.iter().collect::<Vec<_>>(),
        vec![(2, 1, -1.0), (5, 0, 1.0)]
    );
    a.remove(2);
    b.remove(2);
    assert_eq!(a, b);
    assert_eq!(a.get(5), Some((0, 1.0)));
    assert_eq!(a.get(2), None);
}

fn measure<const N: usize>(
    robot: &Robot<f64, N, VCAP>,
    f: &RobotFile,
    n: usize,
    rng: &mut Xoshiro256PlusPlus,
) -> Vec<Measurement<f64, N>> {
    let mut fk = ForwardKinematics::new();
    (0..n)
        .map(|_| {
            let q = arr::<N>(&readings(f, rng));
            Measurement {
                q,
                point: fk.compute(robot, &q),
                ..Default::default()
            }
        })
        .collect()
}

#[test]
fn pso_fitness_cache_and_lm_with_snapshots_honour_couplings() {
    let f = parse(&fanuc_text());
    let nominal: Robot<f64, 6, VCAP> = f.to_robot().unwrap();
    let mut truth = nominal.clone();
    let set = ParamSet::<64>::full(6, false).unwrap();
    let delta: Vec<f64> = (0..set.len())
        .map(|k| 1e-3 * ((k * 7 % 11) as f64 - 5.0))
        .collect();
    kinecal::model::param::apply_delta(&mut truth, &set, &delta).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
    let data = measure(&truth, &f, 60, &mut rng);
    // The same data in model angles, for the uncoupled model.
    let plain: Robot<f64, 6, VCAP> = uncoupled(&f).to_robot().unwrap();
    let converted: Vec<Measurement<f64, 6>> = data
        .iter()
        .map(|m| Measurement {
            q: arr::<6>(&to_model(&f, &m.q)),
            point: m.point,
            ..Default::default()
        })
        .collect();

    // Fitness: the trigonometry cache (model angles) = the general path = the uncoupled model.
    let mut cache: Vec<JointTrig<f64, 6>> = vec![[(0.0, 0.0); 6]; data.len()];
    let mut fast = PositionFitness::with_cache(&nominal, &set, &data, &mut cache).unwrap();
    let mut general = PositionFitness::new(&nominal, &set, &data).unwrap();
    let mut on_plain = PositionFitness::new(&plain, &set, &converted).unwrap();
    for x in [
        vec![0.0; set.len()],
        delta.iter().map(|d| d * 0.5).collect(),
        delta.clone(),
    ] {
        let (a, b, c) = (fast.fitness(&x), general.fitness(&x), on_plain.fitness(&x));
        assert!(
            (a - b).abs() <= 1e-9 * b.max(1.0),
            "cached {a} vs general {b}"
        );
        assert!(
            (b - c).abs() <= 1e-9 * c.max(1.0),
            "coupled {b} vs converted {c}"
        );
    }
    assert!(fast.fitness(&delta) < 1e-12, "the truth fits exactly");
    assert!(general.fitness(&vec![0.0; set.len()]) > 1.0);

    // LM: coupled model on readings = uncoupled model on model angles; a snapshot at every
    // step resumes bit-identically (the couplings survive the restore).
    use kinecal::io::snapshot::Snapshot;
    let mut a = FixedLevenberg::<f64, 6, VCAP, 64>::fixed(
        nominal.clone(),
        set.clone(),
        LmConfig::default(),
    )
    .unwrap();
    a.run(&data).unwrap();
    let mut b =
        FixedLevenberg::<f64, 6, VCAP, 64>::fixed(plain.clone(), set.clone(), LmConfig::default())
            .unwrap();
    b.run(&converted).unwrap();
    assert_eq!(a.robot().couplings(), nominal.couplings());
    for p in set.as_slice() {
        let (x, y) = (
            kinecal::model::param::value(a.robot(), *p).unwrap(),
            kinecal::model::param::value(b.robot(), *p).unwrap(),
        );
        assert!((x - y).abs() <= 1e-9, "{}: {x} vs {y}", p.name(a.robot()));
    }
    let rms = kinecal::identify::lm::rms_error(a.robot(), &data);
    assert!(rms < 1e-4, "rms {rms} {:?}", a.progress());
    let mut lm = FixedLevenberg::<f64, 6, VCAP, 64>::fixed(
        nominal.clone(),
        set.clone(),
        LmConfig::default(),
    )
    .unwrap();
    loop {
        let p = lm.step(&data, 9).unwrap();
        if p.stopped.is_some() {
            break;
        }
        let mut buf = Vec::new();
        lm.save(&mut buf).unwrap();
        let mut fresh =
            Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
        fresh.restore(&mut buf.as_slice()).unwrap();
        lm = fresh;
    }
    assert_eq!(lm.robot(), a.robot());
    // A snapshot of the coupled run does not restore into a solver of the uncoupled robot
    // (the couplings are part of the robot, stored in the snapshot), and the target is kept.
    let mut buf = Vec::new();
    lm.save(&mut buf).unwrap();
    let mut other =
        FixedLevenberg::<f64, 6, VCAP, 64>::fixed(plain.clone(), set.clone(), LmConfig::default())
            .unwrap();
    let kept = other.robot().clone();
    assert_eq!(
        other.restore(&mut buf.as_slice()),
        Err(kinecal::io::snapshot::SnapshotError::Shape)
    );
    assert_eq!(other.robot(), &kept);
}

#[test]
fn planning_candidates_of_a_coupled_robot() {
    let f = parse(&fanuc_text());
    let coupled: Robot<f64, 6, VCAP> = f.to_robot().unwrap();
    let plain: Robot<f64, 6, VCAP> = uncoupled(&f).to_robot().unwrap();
    let tracker = Tracker {
        position: Vector3::new(2500.0, 0.0, 800.0),
        max_incidence: 30f64.to_radians(),
        beam_radius: 5.0,
    };
    let scene = Scene::<f64, 4, 2>::new(tracker, None).unwrap();
    let params = ParamSet::<32>::full(6, false).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let mut fk = ForwardKinematics::new();
    let mut found = 0;
    for _ in 0..400 {
        let Some(c) = kinecal::planning::pose_pool::draw::<f64, 6, VCAP, 32, 4, 2, _>(
            &mut rng,
            &coupled,
            &scene,
            params.as_slice(),
            &kinecal::planning::pose_pool::Sampling::default(),
            &mut fk,
        ) else {
            continue;
        };
        found += 1;
        // Readings within the limits, the reflector facing the tracker on the coupled model.
        assert!(coupled.within_limits(&c.q));
        let mut check = ForwardKinematics::new();
        check.compute(&coupled, &c.q);
        assert!(scene.check(&coupled, &check, true).feasible());
        let beam = (coupled.base().point(&tracker.position) - check.point).normalize();
        assert!(check.flange_pose().z.dot(&beam) >= 30f64.to_radians().cos() - 1e-9);
        // Its Jacobian rows are the uncoupled model's at the model angles.
        let mut plain_fk = ForwardKinematics::new();
        plain_fk.compute(&plain, &arr::<6>(&to_model(&f, &c.q)));
        let mut rows: PoseRows<f64, 32> = [[0.0; 32]; 3];
        scaled_rows(&plain, &plain_fk, params.as_slice(), &mut rows).unwrap();
        for (a, b) in c.rows.iter().zip(rows.iter()) {
            for (x, y) in a.iter().zip(b) {
                assert!((x - y).abs() <= 1e-9 * (1.0 + y.abs()));
            }
        }
    }
    assert!(found >= 20, "only {found} feasible candidates");
}

// ---------------------------------------------------------------------------------------------
// Frames from sweeps.

#[test]
fn frames_from_sweeps_of_a_coupled_robot() {
    let f = parse(&fanuc_text());
    let robot: Robot<f64, 6, VCAP> = f.to_robot().unwrap();
    let rest = kinecal_cli::simulation::sweeps::default_rest(&robot);
    let ds = sweep_data(&robot, &rest, &[1, 2, 5, 6], 24, 360.0, 0.0, 1).unwrap();
    // During the J2 sweep J3's reading moves opposite, so q3 stays put.
    let sweeps = SweepSet::<6>::from_dataset(&ds).unwrap().unwrap();
    let j2 = &sweeps.q[1];
    let spread = |k: usize, model: bool| {
        let v: Vec<f64> = j2
            .iter()
            .map(|r| if model { to_model(&f, r)[k] } else { r[k] })
            .collect();
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    assert!(spread(2, false) > 1.0, "J3's reading follows the J2 sweep");
    assert!(spread(2, true) < 1e-6, "J3's model angle does not");
    let base = base_from_sweeps(&robot, &sweeps.get(0).unwrap(), &sweeps.get(1).unwrap()).unwrap();
    let want = robot.base();
    assert!(
        (base.base.o - want.o).norm() < 1e-6,
        "{:?} vs {:?}",
        base.base.o,
        want.o
    );
    assert!((base.base.rotation() - want.rotation()).norm() < 1e-9);

    // A J2 sweep with J3's reading held: q3 turns too, refused with a typed reason.
    let mut bad = ds.clone();
    let j3_rest = rest[2];
    for r in bad.records.iter_mut().filter(|r| r.extra[0] == 2.0) {
        r.q_deg[2] = j3_rest;
    }
    let bs = SweepSet::<6>::from_dataset(&bad).unwrap().unwrap();
    assert_eq!(
        base_from_sweeps(&robot, &bs.get(0).unwrap(), &bs.get(1).unwrap()).map(|b| b.base),
        Err(FramesError::CoupledJointMoved(2))
    );
}

#[test]
fn cli_frames_accepts_simulated_coupled_sweeps_and_refuses_dragged_ones() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "fanuc.toml", &fanuc_text());
    let sweeps = dir.path().join("sweeps.csv");
    simulate(
        &robot,
        None,
        Some(0.0),
        None,
        &["--sweeps", "1,2,5,6"],
        &sweeps,
    );
    let v = json_of(&run_on("frames", &robot, &sweeps, &["--json"]));
    let xyz = f64s(&v["base"]["xyz_mm"]);
    let want = [2200.0, -900.0, -350.0];
    for (a, b) in xyz.iter().zip(want) {
        assert!((a - b).abs() < 1e-3, "base {xyz:?} vs {want:?}");
    }
    // The same J2 sweep with J3's reading held fixed: refused, exit 2, one line saying why.
    let mut ds: Dataset<6> = measurements::load(&sweeps).unwrap();
    let rest3 = ds.records[0].q_deg[2];
    for r in ds.records.iter_mut().filter(|r| r.extra[0] == 2.0) {
        r.q_deg[2] = rest3;
    }
    let dragged = dir.path().join("dragged.csv");
    measurements::write(&dragged, &ds).unwrap();
    let out = kinecal(&["frames", "--robot", s(&robot), "--data", s(&dragged)]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("joint 3") && err.contains("coupled"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Robot file.

#[test]
fn robot_file_round_trip_of_couplings() {
    let f = parse(ARM7);
    assert_eq!(f.couplings.len(), 2);
    assert_eq!(
        (
            f.couplings[0].joint,
            f.couplings[0].from,
            f.couplings[0].ratio
        ),
        (4, 2, -1.3)
    );
    let robot: Robot<f64, 7, VCAP> = f.to_robot().unwrap();
    assert_eq!(robot.couplings().get(3), Some((1, -1.3)));
    assert_eq!(robot.couplings().get(6), Some((5, 0.25)));
    let back = RobotFile::from_robot(&f.name, &robot, true, &[]);
    assert_eq!(back.couplings, f.couplings);
    let text = back.to_toml().unwrap();
    assert!(text.contains("[[couplings]]"), "{text}");
    let again = parse(&text);
    assert_eq!(again.couplings, f.couplings);
    let r2: Robot<f64, 7, VCAP> = again.to_robot().unwrap();
    assert_eq!(r2.couplings(), robot.couplings());
    // No couplings: no table written.
    let plain = RobotFile::from_robot("p", &uncoupled(&f).to_robot::<7>().unwrap(), true, &[]);
    assert!(!plain.to_toml().unwrap().contains("couplings"));
}

#[test]
fn bad_couplings_are_refused_with_file_line_column_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d.csv");
    let good = write(dir.path(), "good.toml", &fanuc_text());
    simulate(&good, Some(20), None, None, &[], &data);
    let cases = [
        ("joint = 3\nfrom = 3\nratio = 1.0\n", "itself"),
        ("joint = 7\nfrom = 2\nratio = 1.0\n", "1 to 6"),
        ("joint = 3\nfrom = 0\nratio = 1.0\n", "1 to 6"),
        ("joint = 3\nfrom = 2\nratio = nan\n", "finite"),
        ("joint = 3\nfrom = 2\nratio = inf\n", "finite"),
        ("joint = 3\nfrom = 2\nratio = 1.0\n[[couplings]]\njoint = 3\nfrom = 1\nratio = 1.0\n", "twice"),
        ("joint = 3\nfrom = 2\nratio = 1.0\n[[couplings]]\njoint = 4\nfrom = 3\nratio = 1.0\n", "chained"),
        ("joint = 3\nfrom = 2\nratio = 1.0\n[[couplings]]\njoint = 2\nfrom = 1\nratio = 1.0\n", "chained"),
        ("joint = 3\nfrom = 2\nratio = 1.0\ngain = 2\n", "gain"),
        (
            "joint = 2\nfrom = 1\nratio = 1.0\n[[couplings]]\njoint = 3\nfrom = 1\nratio = 1.0\n[[couplings]]\njoint = 4\nfrom = 1\nratio = 1.0\n[[couplings]]\njoint = 5\nfrom = 1\nratio = 1.0\n[[couplings]]\njoint = 6\nfrom = 1\nratio = 1.0\n",
            "at most 4",
        ),
        ("joint = 3\nfrom = 2\n", "ratio"),
    ];
    let header_line = FANUC.lines().count() + 1;
    for (body, says) in cases {
        let text = format!("{FANUC}[[couplings]]\n{body}");
        let p = write(dir.path(), "bad.toml", &text);
        let err = RobotFile::load(&p).unwrap_err().to_string();
        assert!(err.starts_with(&format!("{}:", p.display())), "{err}");
        let (line, col, _) = location(&err, &p.display().to_string());
        assert!(line >= header_line && col >= 1, "{err}: line {line}");
        assert!(err.contains(says), "{err} should say {says}");
        let out = kinecal(&["check", "--robot", s(&p), "--data", s(&data)]);
        assert_eq!(out.status.code(), Some(2), "{err}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains(&format!("{}:{line}:{col}:", p.display())),
            "{stderr}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Command line: identify, compensate, check hint.

/// The model angles (rad) of a row's readings (deg), computed as the library's pipeline does
/// (degrees → radians, then the couplings), each as degrees that read back as those very
/// radians; `None` when some angle has no such degree value (a few per cent do not: the
/// degree → radian map skips some doubles).
fn exact_model_deg(f: &RobotFile, q_deg: &[f64]) -> Option<Vec<f64>> {
    let rad: Vec<f64> = q_deg.iter().map(|d| d.to_radians()).collect();
    to_model(f, &rad)
        .into_iter()
        .map(|x| {
            let d = deg_exact(x);
            (d.to_radians() == x).then_some(d)
        })
        .collect()
}

/// Writes `ds` with every row converted from readings to model angles. `exact = false`: as a
/// user would, in degrees (for ratio ±1 the decimal sum of the readings); `exact = true`: the
/// model angles in radians written as degrees that read back bit-exact (see
/// [`exact_model_deg`]; a ratio like −1.3 otherwise rounds differently in degrees and radians,
/// by an ulp, and the comparison would measure the LM's stopping tolerance rather than the
/// couplings).
fn preconvert<const N: usize>(f: &RobotFile, ds: &Dataset<N>, path: &Path, exact: bool) {
    let mut text: String = (1..=N).map(|i| format!("q{i},")).collect();
    text.push_str("x,y,z\n");
    for r in &ds.records {
        let q: Vec<f64> = if exact {
            exact_model_deg(f, &r.q_deg).expect("rows filtered to exact ones")
        } else {
            to_model(f, &r.q_deg)
        };
        for q in q {
            text.push_str(&format!("{q},"));
        }
        let [x, y, z] = r.xyz_mm;
        text.push_str(&format!("{x},{y},{z}\n"));
    }
    std::fs::write(path, text).unwrap();
}

fn identify_equivalence<const N: usize>(text: &str, tag: &str, exact: bool) {
    let dir = tempfile::tempdir().unwrap();
    let f = parse(text);
    let coupled = write(dir.path(), &format!("{tag}.toml"), text);
    let plain = write(
        dir.path(),
        &format!("{tag}-plain.toml"),
        &uncoupled(&f).to_toml().unwrap(),
    );
    let id = dir.path().join("id.csv");
    simulate(
        &coupled,
        Some(140),
        Some(0.01),
        Some(3),
        &["--geom-errors"],
        &id,
    );
    let mut ds = measurements::load::<N>(&id).unwrap();
    if exact {
        ds.records
            .retain(|r| exact_model_deg(&f, &r.q_deg).is_some());
        assert!(ds.len() >= 100, "{} exact rows", ds.len());
        measurements::write(&id, &ds).unwrap();
    }
    let id_m = dir.path().join("id_m.csv");
    preconvert(&f, &ds, &id_m, exact);
    let (m1, m2) = (dir.path().join("m1.toml"), dir.path().join("m2.toml"));
    let a = json_of(&run_on(
        "identify",
        &coupled,
        &id,
        &["--holdout", "0.3", "--json", "--out", s(&m1)],
    ));
    let b = json_of(&run_on(
        "identify",
        &plain,
        &id_m,
        &["--holdout", "0.3", "--json", "--out", s(&m2)],
    ));
    assert_eq!(a["n_validation"], b["n_validation"]);
    assert!(a["n_validation"].as_u64().unwrap() >= 30, "{a}");
    for k in [
        "identification_rms_mm",
        "validation_rms_mm",
        "validation_max_mm",
    ] {
        for phase in ["before", "after"] {
            let (x, y) = (a[phase][k].as_f64().unwrap(), b[phase][k].as_f64().unwrap());
            assert!((x - y).abs() <= 1e-9, "{tag} {phase}.{k}: {x} vs {y}");
        }
    }
    assert!(a["after"]["validation_rms_mm"].as_f64().unwrap() < 0.05);
    assert!(a["before"]["validation_rms_mm"].as_f64().unwrap() > 0.5);
    let (pa, pb) = (
        a["parameters"].as_object().unwrap(),
        b["parameters"].as_object().unwrap(),
    );
    assert_eq!(pa.len(), pb.len());
    for (name, x) in pa {
        let (x, y) = (x.as_f64().unwrap(), pb[name].as_f64().unwrap());
        assert!(
            (x - y).abs() <= 1e-9 * (1.0 + y.abs()),
            "{tag} {name}: {x} vs {y}"
        );
    }
    // The identified model keeps its couplings; the plain one has none.
    let m1f = RobotFile::load(&m1).unwrap();
    assert_eq!(m1f.couplings, f.couplings);
    assert!(RobotFile::load(&m2).unwrap().couplings.is_empty());
}

#[test]
fn identify_on_coupled_file_equals_identify_on_preconverted_data() {
    identify_equivalence::<6>(&fanuc_text(), "fanuc", false);
    identify_equivalence::<7>(ARM7, "arm7", true);
}

/// Roll, pitch, yaw (deg) of a rotation, `R = Rz(yaw)·Ry(pitch)·Rx(roll)`.
fn rpy_deg(r: &Matrix3<f64>) -> [f64; 3] {
    [
        r[(2, 1)].atan2(r[(2, 2)]).to_degrees(),
        (-r[(2, 0)]).asin().to_degrees(),
        r[(1, 0)].atan2(r[(0, 0)]).to_degrees(),
    ]
}

#[test]
fn compensate_returns_commands_in_the_controllers_readings() {
    let dir = tempfile::tempdir().unwrap();
    let f = parse(&fanuc_text());
    let model = write(dir.path(), "model.toml", &fanuc_text());
    let reference = RefRobot::from_file(&f);
    let robot: Robot<f64, 6, VCAP> = f.to_robot().unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(12);
    let mut text = String::from("q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n");
    let mut truths = Vec::new();
    while truths.len() < 12 {
        // Away from the limits and the wrist singularity.
        let r: Vec<f64> = (0..6)
            .map(|j| {
                let [lo, hi] = f.limits_deg(j);
                rng.random_range(lo + 10.0..hi - 10.0)
            })
            .collect();
        // The elbow is stretched where the model angle q3 = J3 + J2 lines a4/d4 up with a3
        // (q3 = -atan2(d4, a4) or 180° from it): a singular target, not a coupling test.
        let elbow = (r[2] + r[1] + 835f64.atan2(250.0).to_degrees()).rem_euclid(180.0);
        if r[4].abs() < 20.0 || !(25.0..=155.0).contains(&elbow) {
            continue;
        }
        let rad: Vec<f64> = r.iter().map(|d| d.to_radians()).collect();
        let p = reference.point(&rad);
        let o = rpy_deg(&reference.tool_rotation(&rad));
        // Only well-conditioned poses (no shoulder or wrist singularity): the library, seeded
        // at the answer, calls the pose regular.
        let mut fk = ForwardKinematics::<f64, 6>::new();
        fk.compute(&robot, &arr::<6>(&rad));
        let at = compensate(
            &robot,
            &Target::Pose(fk.flange_pose()),
            &arr::<6>(&rad),
            &Config::default(),
        );
        if at.is_err() {
            continue;
        }
        // Seeds: the true readings off by up to 0.5°.
        for v in &r {
            text.push_str(&format!("{:.6},", v + rng.random_range(-0.5..0.5)));
        }
        text.push_str(&format!(
            "{:.9},{:.9},{:.9},{:.12},{:.12},{:.12}\n",
            p.x, p.y, p.z, o[0], o[1], o[2]
        ));
        truths.push(r);
    }
    let targets = write(dir.path(), "targets.csv", &text);
    let out = dir.path().join("q.csv");
    let v = json_of(&kinecal(&[
        "compensate",
        "--model",
        s(&model),
        "--targets",
        s(&targets),
        "--out",
        s(&out),
        "--json",
    ]));
    assert!(v.is_object());
    let result = std::fs::read_to_string(&out).unwrap();
    let mut lines = result.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let status = header.iter().position(|h| *h == "status").unwrap();
    for (line, truth) in lines.zip(&truths) {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells[status], "ok", "{line}");
        let q: Vec<f64> = cells[..6].iter().map(|c| c.parse().unwrap()).collect();
        // The command is the controller's readings: the true readings (not the model angles,
        // which differ by J2 in J3), and the reference reaches the target from them.
        for (a, b) in q.iter().zip(truth) {
            assert!((a - b).abs() < 1e-5, "command {q:?} vs readings {truth:?}");
        }
        assert!(
            (truth[1]).abs() > 1e-3,
            "J2 non-zero, so readings and angles differ"
        );
        let rad: Vec<f64> = q.iter().map(|d| d.to_radians()).collect();
        let t: Vec<f64> = truth.iter().map(|d| d.to_radians()).collect();
        assert!((reference.point(&rad) - reference.point(&t)).norm() < 1e-3);
    }
}

/// The FANUC file with its coupling and without, written to `dir`, and `poses` poses simulated
/// from the coupled one (geometric errors, σ = 0.02 mm): (coupled, plain, data).
fn coupled_data(dir: &Path, poses: usize, seed: Option<u64>) -> (PathBuf, PathBuf, PathBuf) {
    let coupled = write(dir, "fanuc.toml", &fanuc_text());
    let plain = write(dir, "fanuc-plain.toml", FANUC);
    let d = dir.join("d.csv");
    simulate(
        &coupled,
        Some(poses),
        Some(0.02),
        seed,
        &["--geom-errors"],
        &d,
    );
    (coupled, plain, d)
}

/// Coupled data fitted with a file that lacks the coupling: neither `identify` nor `diagnose`
/// may turn the mistake into a number with exit 0 (they ended at 61.7 mm with exit 0 and at
/// "nothing significant is missing, noise floor 101.654 mm"): both exit 3 and say why.
#[test]
fn a_missing_coupling_is_neither_calibrated_nor_diagnosed() {
    let dir = tempfile::tempdir().unwrap();
    let (coupled, plain, d) = coupled_data(dir.path(), 60, Some(3));
    for cmd in ["identify", "diagnose"] {
        let out = kinecal(&[cmd, "--robot", s(&plain), "--data", s(&d), "--json"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{cmd}: {err}");
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON still written");
        assert_eq!(v["converged"], false, "{cmd}");
        assert!(err.contains("coupl"), "{cmd}: {err}");
        // With the coupling in the file, both succeed.
        let out = kinecal(&[cmd, "--robot", s(&coupled), "--data", s(&d), "--json"]);
        assert_eq!(json_of(&out)["converged"], true, "{cmd}");
    }
}

#[test]
fn check_hints_at_a_missing_coupling_and_not_on_ur10() {
    let dir = tempfile::tempdir().unwrap();
    let (coupled, plain, d) = coupled_data(dir.path(), 150, None);
    // The file without the coupling: the hint names it, in JSON and on stderr.
    let out = kinecal(&["check", "--robot", s(&plain), "--data", s(&d), "--json"]);
    let v = json_of(&out);
    let h = &v["coupling_hint"];
    assert_eq!(h["joint"], 3, "{v}");
    assert_eq!(h["from"], 2);
    assert_eq!(h["ratio"].as_f64(), Some(1.0));
    let (with, without) = (
        h["rms_mm"].as_f64().unwrap(),
        h["nominal_rms_mm"].as_f64().unwrap(),
    );
    assert!(with < 5.0 && without > 20.0 * with, "{h}");
    assert!((without - v["nominal_rms_mm"].as_f64().unwrap()).abs() < 1e-6);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.lines().any(
            |l| l.starts_with("hint: J3 looks measured from the horizontal")
                && l.contains("joint = 3, from = 2, ratio = 1.0")
        ),
        "{err}"
    );
    // Without [base] (registration) as well.
    let no_base = FANUC.replace(
        "[base]\nxyz_mm = [2200.0, -900.0, -350.0]\nrpy_deg = [0.4, -0.8, 130.0]\n",
        "",
    );
    assert!(!no_base.contains("[base]"));
    let p2 = write(dir.path(), "fanuc-nobase.toml", &no_base);
    let v = json_of(&run_on("check", &p2, &d, &["--json"]));
    assert_eq!(v["coupling_hint"]["joint"], 3, "{v}");
    // The right file: no hint.
    let v = json_of(&run_on("check", &coupled, &d, &["--json"]));
    assert!(v["coupling_hint"].is_null(), "{v}");
    // Real UR10 data with its own robot file: no hint.
    let ur10 = ur10_dir();
    for csv in ["ur10_random_poses.csv", "ur10_random_poses_6d.csv"] {
        let out = run_on(
            "check",
            &ur10.join("robot.toml"),
            &ur10.join(csv),
            &["--json"],
        );
        let v = json_of(&out);
        assert!(v["coupling_hint"].is_null(), "{csv}: {v}");
        assert!(!String::from_utf8_lossy(&out.stderr).contains("hint:"));
    }
}
