//! Couplings validated, kept by cast and clone, round-tripped by the robot file, refused in place.

use super::*;
use kinecal_cli::HostRobot;

#[test]
fn couplings_are_validated_and_kept_by_cast_capacity_and_clone() {
    let f = parse(&fanuc_text());
    let mut r: HostRobot<6> = f.to_robot().unwrap();
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
    let r32: Robot<f32, 6, HostValues> = r.cast().unwrap();
    assert_eq!(r32.couplings().get(2), Some((1, 1.0f32)));
    let r64: Robot<f64, 6, kinecal::Inline<64>> = r.with_capacity::<kinecal::Inline<64>>().unwrap();
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
    let mut r7: HostRobot<7> = parse(ARM7).to_robot().unwrap();
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
    let robot: HostRobot<7> = f.to_robot().unwrap();
    assert_eq!(robot.couplings().get(3), Some((1, -1.3)));
    assert_eq!(robot.couplings().get(6), Some((5, 0.25)));
    let back = RobotFile::from_robot(&f.name, &robot, true, &[]);
    assert_eq!(back.couplings, f.couplings);
    let text = back.to_toml().unwrap();
    assert!(text.contains("[[couplings]]"), "{text}");
    let again = parse(&text);
    assert_eq!(again.couplings, f.couplings);
    let r2: HostRobot<7> = again.to_robot().unwrap();
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
