//! `kinecal_cli::formats::rotation_order` (cli/src/formats/rotation_order.rs) on its own.

use kinecal::Frame;
use kinecal_cli::formats::rotation_order::*;

#[test]
fn the_six_orders_parse_and_kinecal_s_is_rpy() {
    for o in RotationOrder::all() {
        assert_eq!(RotationOrder::parse(&o.text()), Some(o));
    }
    assert_eq!(
        RotationOrder::parse("rz · ry · rx"),
        Some(RotationOrder::KINECAL)
    );
    assert_eq!(RotationOrder::parse("Rx*Rx*Rz"), None);
    assert_eq!(RotationOrder::parse("Rx*Ry"), None);
    let a = [12.0, -34.0, 56.0];
    let f = Frame::from_xyz_rpy([0.0; 3], a.map(f64::to_radians));
    let m = RotationOrder::KINECAL.matrix(a);
    assert!((f.rotation() - m).norm() < 1e-15);
}

#[test]
fn converted_angles_give_the_same_rotation() {
    let a = [-90.179563, -20.112975, -90.157388];
    for o in RotationOrder::all() {
        let k = o.to_kinecal_deg(a);
        let back = RotationOrder::KINECAL.matrix(k);
        assert!((back - o.matrix(a)).norm() < 1e-12, "{}", o.text());
    }
    // The first row of the UR10 tracker series as published (R = Rx·Ry·Rz) and as
    // data/ur10/ur10_random_poses_6d.csv gives it (kinecal's order, 6 decimals).
    let k = RotationOrder::parse("Rx*Ry*Rz").unwrap().matrix(a);
    let converted = RotationOrder::KINECAL.matrix([150.437141, -89.806151, 139.676065]);
    assert!((k - converted).norm() < 1e-7);
}

/// Every order's angles give back the rotation they were taken from (and kinecal's order
/// its own roll, pitch and yaw), also where the order's middle angle is ±90° (only the sum or
/// difference of the other two is determined there).
#[test]
fn angles_invert_the_matrix_in_every_order() {
    let deg = [
        [10.0, -35.0, 120.0],
        [-170.0, 80.0, 5.0],
        [45.0, 0.5, -90.0],
    ];
    for order in RotationOrder::all() {
        let mut rotations: Vec<_> = deg
            .iter()
            .map(|d| RotationOrder::KINECAL.matrix(*d))
            .collect();
        for middle in [90.0, -90.0] {
            let mut d = [25.0, -40.0, 70.0];
            d[order.axes[1]] = middle;
            rotations.push(order.matrix(d));
        }
        for m in rotations {
            let back = order.matrix(order.angles_deg(&m));
            assert!((back - m).abs().max() < 1e-12, "{} {m}", order.text());
        }
        let a = order.angles_deg(&order.matrix([12.0, -24.0, 36.0]));
        assert!(
            a.iter()
                .zip([12.0, -24.0, 36.0])
                .all(|(x, y)| (x - y).abs() < 1e-9),
            "{} {a:?}",
            order.text()
        );
    }
}
