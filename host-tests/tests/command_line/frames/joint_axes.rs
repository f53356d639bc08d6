//! Common normals of lines, joint axes by the right-hand rule, a joint that moved out of turn.

use super::*;

#[test]
fn common_normal_of_skew_intersecting_and_parallel_lines() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    for _ in 0..20 {
        // A random rigid motion applied to hand-made configurations.
        let f = random_base(&mut rng);
        let line = |p: [f64; 3], d: [f64; 3]| {
            Line::new(f.point(&Vector3::from(p)), f.direction(&Vector3::from(d))).unwrap()
        };
        let close = |a: Vector3<f64>, b: [f64; 3]| (a - f.point(&Vector3::from(b))).norm() < 1e-9;
        let along =
            |a: Vector3<f64>, b: [f64; 3]| (a - f.direction(&Vector3::from(b))).norm() < 1e-9;

        // Skew: the z axis and a line along y at height 3, 5 mm away in x (points far out).
        let a = line([0.0, 0.0, -40.0], [0.0, 0.0, 2.0]);
        let b = line([5.0, 70.0, 3.0], [0.0, -1.0, 0.0]);
        let cn = common_normal(&a, &b).unwrap();
        assert!(close(cn.on_first, [0.0, 0.0, 3.0]) && close(cn.on_second, [5.0, 0.0, 3.0]));
        assert!(
            (cn.distance - 5.0).abs() < 1e-9
                && along(cn.direction, [1.0, 0.0, 0.0])
                && !cn.parallel
        );
        let back = common_normal(&b, &a).unwrap();
        assert!(along(back.direction, [-1.0, 0.0, 0.0]));
        // Skew at 30°.
        let b = line([-2.0, 0.0, 10.0], [0.0, 3f64.sqrt() / 2.0, 0.5]);
        let cn = common_normal(&a, &b).unwrap();
        assert!((cn.distance - 2.0).abs() < 1e-9 && along(cn.direction, [-1.0, 0.0, 0.0]));
        assert!(close(cn.on_first, [0.0, 0.0, 10.0]) && close(cn.on_second, [-2.0, 0.0, 10.0]));
        assert!((cn.sin_angle - 3f64.sqrt() / 2.0).abs() < 1e-12);

        // Intersecting at (0, 0, 2): direction = a × b.
        let b = line([4.0, 4.0, 2.0], [1.0, 1.0, 0.0]);
        let cn = common_normal(&a, &b).unwrap();
        assert!(
            cn.distance < 1e-9
                && close(cn.on_first, [0.0, 0.0, 2.0])
                && close(cn.on_second, [0.0, 0.0, 2.0])
        );
        let s = 0.5f64.sqrt();
        assert!(along(cn.direction, [-s, s, 0.0]));

        // Parallel, 5 mm apart: the normal through the first line's point.
        let b = line([3.0, 4.0, 7.0], [0.0, 0.0, -1.0]);
        let cn = common_normal(&a, &b).unwrap();
        assert!(cn.parallel && (cn.distance - 5.0).abs() < 1e-9);
        assert!(close(cn.on_first, [0.0, 0.0, -40.0]) && close(cn.on_second, [3.0, 4.0, -40.0]));
        assert!(along(cn.direction, [0.6, 0.8, 0.0]));

        // Coincident.
        let b = line([0.0, 0.0, 9.0], [0.0, 0.0, 1.0]);
        assert_eq!(common_normal(&a, &b), Err(FramesError::Coincident));
    }
}

#[test]
fn joint_axis_follows_the_right_hand_rule() {
    let c = Vector3::new(100.0, 200.0, 300.0);
    let n = Vector3::new(0.0, 0.6, 0.8);
    let u = Vector3::new(1.0, 0.0, 0.0);
    let angles: Vec<f64> = (0..10).map(|i| -0.5 + 0.1 * i as f64).collect();
    let rot = |q: f64| c + Rotation3::from_axis_angle(&Unit::new_normalize(n), q) * (u * 250.0);
    let pts: Vec<Vector3<f64>> = angles.iter().map(|q| rot(*q)).collect();
    let ax = joint_axis(&pts, &angles).unwrap();
    assert!((ax.line.direction - n).norm() < 1e-9 && (ax.span - 0.9).abs() < 1e-12);
    // A joint whose reading decreases as the points turn about +n turns about −n.
    let neg: Vec<f64> = angles.iter().map(|q| -q).collect();
    let ax = joint_axis(&pts, &neg).unwrap();
    assert!((ax.line.direction + n).norm() < 1e-9);
    // The order of the samples does not matter.
    let order = [3usize, 7, 0, 9, 1, 5, 2, 8, 4, 6];
    let p2: Vec<_> = order.iter().map(|&i| pts[i]).collect();
    let a2: Vec<_> = order.iter().map(|&i| angles[i]).collect();
    assert!((joint_axis(&p2, &a2).unwrap().line.direction - n).norm() < 1e-9);
    // Readings that do not change cannot orient the axis.
    assert_eq!(joint_axis(&pts, &[0.1; 10]), Err(FramesError::NoRotation));
    assert_eq!(joint_axis(&pts, &angles[..9]), Err(FramesError::Shape));
}

#[test]
fn a_joint_that_moves_during_another_joints_sweep_is_refused() {
    let truth: Robot<f64, 6, kinecal::Inline<0>> = robot(&ER20, ER20_TOOL, Frame::identity());
    let mut data = sweep_data(&truth, &[0.0; 6], &[1, 2], 24, 90.0, 0.01, 1).unwrap();
    data.records[30].q_deg[0] += 0.5;
    let set = SweepSet::from_dataset(&data).unwrap().unwrap();
    let r = base_from_sweeps(&truth, &set.get(0).unwrap(), &set.get(1).unwrap());
    assert_eq!(r.unwrap_err(), FramesError::OtherJointMoved(0));
}
