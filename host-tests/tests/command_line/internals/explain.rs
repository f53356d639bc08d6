//! `kinecal_cli::diagnose::explain` (cli/src/diagnose/explain.rs) on its own.

use kinecal_cli::diagnose::explain::*;

#[test]
fn period_of_a_sine_and_none_for_a_line() {
    let (p, share) = dominant_period(
        |x| (x / 30.0 * std::f64::consts::TAU).sin() + 0.01 * x,
        -170.0,
        170.0,
        10.0,
    )
    .unwrap();
    assert!((p - 30.0).abs() < 0.05, "{p}");
    assert!(share > 0.99, "{share}");
    assert!(dominant_period(|x| 2.0 * x + 1.0, 0.0, 100.0, 5.0).is_none());
    // Fewer than two periods of the shortest one fit.
    assert!(dominant_period(|x| x.sin(), 0.0, 10.0, 6.0).is_none());
}

#[test]
fn ranges_and_gap() {
    let grid: Vec<(f64, f64)> = (0..=360)
        .map(|k| {
            let q = f64::from(k).to_radians();
            (q, q.sin())
        })
        .collect();
    let r = largest_ranges(&grid);
    assert_eq!(r.len(), 2);
    assert!((r[0].0[0].to_degrees() - 54.0).abs() < 1.5, "{r:?}");
    assert_eq!(gap_closed(1.0, 0.5, 0.0), (Some(0.5), GapBasis::NoiseFloor));
    assert_eq!(
        gap_closed(1.0, 0.5, f64::NAN),
        (Some(0.5), GapBasis::HeldOutRms)
    );
    assert_eq!(gap_closed(1.0, 1.5, 0.2), (Some(0.0), GapBasis::NoiseFloor));
    assert_eq!(gap_closed(0.0, 0.0, f64::NAN), (None, GapBasis::HeldOutRms));
}
