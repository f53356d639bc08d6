//! Planning candidates of a coupled robot.

use super::*;
use kinecal_cli::HostRobot;

#[test]
fn planning_candidates_of_a_coupled_robot() {
    let f = parse(&fanuc_text());
    let coupled: HostRobot<6> = f.to_robot().unwrap();
    let plain: HostRobot<6> = uncoupled(&f).to_robot().unwrap();
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
        let Some(c) = kinecal::planning::pose_pool::draw::<f64, 6, HostValues, 32, 4, 2, _>(
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
