//! Forward kinematics and Jacobians of coupled robots against the uncoupled model and reference.

use super::*;
use kinecal_cli::HostRobot;

fn fk_checks<const N: usize>(text: &str, seed: u64) {
    let f = parse(text);
    assert!(!f.couplings.is_empty());
    let coupled: HostRobot<N> = f.to_robot().unwrap();
    let plain: HostRobot<N> = uncoupled(&f).to_robot().unwrap();
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
    let robot: HostRobot<N> = f.to_robot().unwrap();
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
    let robot: HostRobot<6> = f.to_robot().unwrap();
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
