//! `compensate` returns commands in the controller's readings.

use super::*;
use kinecal_cli::HostRobot;

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
    let robot: HostRobot<6> = f.to_robot().unwrap();
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
