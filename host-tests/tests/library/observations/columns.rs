//! Position and rotation columns of every parameter kind against the reference's differences.

use super::*;

/// Every parameter of a robot with three tool points and `nv` effect values.
fn every_param(nv: usize) -> Vec<Param> {
    let mut v = vec![
        Param::BaseX,
        Param::BaseY,
        Param::BaseZ,
        Param::BaseRx,
        Param::BaseRy,
        Param::BaseRz,
    ];
    for i in 0..6u8 {
        v.extend([
            Param::Alpha(i),
            Param::A(i),
            Param::Theta(i),
            Param::D(i),
            Param::Beta(i),
        ]);
    }
    v.extend([Param::ToolX, Param::ToolY, Param::ToolZ]);
    for k in 1..3u8 {
        v.extend((0..3).map(|a| Param::ToolPoint(k, a)));
    }
    v.extend([Param::ToolRx, Param::ToolRy, Param::ToolRz]);
    v.extend((0..nv).map(|k| Param::Effect(k as u16)));
    v
}

/// A UR10 with tilted rows, three tool points, turned tool axes and effects; `coupled`: joint
/// 3 read relative to joint 2 (FANUC style).
fn column_robot(coupled: bool) -> Robot<f64, 6, V> {
    let mut r = ur10(Vector3::new(12.0, -7.0, 109.0));
    for (i, b) in [(1usize, 0.2), (2, -0.3), (4, 0.15)] {
        let mut j = r.joints()[i];
        j.beta = deg(b);
        r.set_joint(i, j).unwrap();
    }
    r.set_tool_point(1, Vector3::new(60.0, 5.0, 95.0)).unwrap();
    r.set_tool_point(2, Vector3::new(-35.0, 48.0, 120.0))
        .unwrap();
    r.set_tool_axes(Frame::from_xyz_rpy(
        [0.0; 3],
        [deg(12.0), deg(-25.0), deg(140.0)],
    ))
    .unwrap();
    let fx = r.effects_mut();
    fx.push(EffectKind::Cyclic, 1, 6, 2, 0.0, 0.0, &[3e-4, -2e-4])
        .unwrap();
    fx.push(EffectKind::Scale, 3, 6, 1, 0.0, 0.0, &[1.5e-3])
        .unwrap();
    fx.push(EffectKind::Cyclic, 5, 6, 1, 0.0, 0.0, &[-1e-4, 4e-4])
        .unwrap();
    if coupled {
        r.set_coupling(2, 1, 1.0).unwrap();
    }
    r
}

/// `column` and `rotation_column` of every parameter kind, for each of the three tool points,
/// at random poses, against the reference's central differences (`dp_dparam_at`: five-point,
/// good to ~1e-8 mm per unit; `dr_dparam`: every parameter turns the tool frame by one factor
/// `exp(h·axis)`, so the two-point difference is exact up to rounding, ~1e-12).
#[test]
fn position_and_rotation_columns_match_reference_differences() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(18);
    let (mut worst_p, mut worst_r, mut checked) = (0f64, 0f64, 0usize);
    for coupled in [false, true] {
        let r = column_robot(coupled);
        let reference = RefRobot::from_robot(&r);
        assert_eq!(reference.more_tools.len(), 2);
        let params = every_param(r.effects().values().len());
        let mut fk = ForwardKinematics::<f64, 6>::new();
        for _ in 0..6 {
            let q = random_q(&mut rng);
            for k in 0..3 {
                let p = fk.compute_point(&r, &q, k).unwrap();
                assert!((p - reference.point_at(&q, k)).norm() < 1e-9);
                let rot = fk.tool_pose(&r).rotation();
                assert!((rot - reference.tool_rotation(&q)).norm() < 1e-12);
                for par in &params {
                    let name = par.name(&r).to_string();
                    let c = fk.column(&r, *par).unwrap();
                    let want = reference.dp_dparam_at(&q, *par, k);
                    let e = (c - want).norm();
                    assert!(
                        e <= 1e-6 * want.norm() + 1e-7,
                        "point {k}, {name} (coupled {coupled}): {c} vs {want}"
                    );
                    let c = fk.rotation_column(&r, *par).unwrap();
                    let want = reference.dr_dparam(&q, *par);
                    let er = (c - want).norm();
                    assert!(
                        er <= 1e-9,
                        "point {k}, {name} (coupled {coupled}): rotation {c} vs {want}"
                    );
                    worst_p = worst_p.max(e / (1.0 + want.norm()));
                    worst_r = worst_r.max(er);
                    checked += 1;
                }
            }
        }
    }
    eprintln!(
        "{checked} columns: worst position {worst_p:.1e} (relative), rotation {worst_r:.1e} rad"
    );
}
