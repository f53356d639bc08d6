//! Base frames from sweeps of a coupled robot, in the library and on the command line.

use super::*;
use kinecal_cli::HostRobot;

#[test]
fn frames_from_sweeps_of_a_coupled_robot() {
    let f = parse(&fanuc_text());
    let robot: HostRobot<6> = f.to_robot().unwrap();
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
