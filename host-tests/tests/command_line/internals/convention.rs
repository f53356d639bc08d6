//! `kinecal_cli::formats::convention` (cli/src/formats/convention.rs) on its own.

use kinecal_cli::formats::convention::*;
use nalgebra::Matrix3;
use nalgebra::Vector3;

fn rot(axis: usize, deg: f64) -> Matrix3<f64> {
    *nalgebra::Rotation3::from_axis_angle(&Vector3::ith_axis(axis), deg.to_radians()).matrix()
}

#[test]
fn both_rotations_are_recovered() {
    let b = rot(2, 130.0) * rot(0, -20.0);
    let t = rot(1, 75.0) * rot(2, 10.0);
    let f: Vec<Matrix3<f64>> = (0..12)
        .map(|k| rot(0, 17.0 * k as f64) * rot(1, 29.0 * k as f64 - 50.0) * rot(2, 41.0 * k as f64))
        .collect();
    let m: Vec<Matrix3<f64>> = f.iter().map(|fi| b * fi * t).collect();
    assert!(score(&m, &f).unwrap() < 1e-6);
}
