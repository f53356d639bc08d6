//! `kinecal_cli::calibration::stats` (cli/src/calibration/stats.rs) on its own.

use kinecal_cli::calibration::stats::*;
use nalgebra::Vector3;

#[test]
fn quantiles_follow_numpy() {
    let v = [1.0, 2.0, 3.0, 4.0, 5.0];
    assert_eq!(quantile(&v, 0.5), 3.0);
    assert!((quantile(&v, 0.95) - 4.8).abs() < 1e-12);
    assert!(quantile(&[], 0.5).is_nan());
}

#[test]
fn per_axis_and_total() {
    let e = [Vector3::new(3.0, 0.0, -4.0), Vector3::new(-3.0, 0.0, 4.0)];
    let f = SetFigures::of_vectors(&e).unwrap();
    assert_eq!(f.total.rms, 5.0);
    assert_eq!(f.total.max, 5.0);
    assert_eq!(f.x.mean, 0.0);
    assert_eq!(f.x.rms, 3.0);
    assert_eq!(f.z.max, 4.0);
}
