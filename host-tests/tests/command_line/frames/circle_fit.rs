//! The circle fit of a sweep's points: known circles, exact points, short arcs, refusals.

use super::*;

fn circle_points(
    c: Vector3<f64>,
    n: Vector3<f64>,
    r: f64,
    from: f64,
    span: f64,
    k: usize,
) -> Vec<Vector3<f64>> {
    let n = n.normalize();
    let u = n.cross(&Vector3::new(0.3, -0.7, 0.2)).normalize();
    let v = n.cross(&u);
    (0..k)
        .map(|i| {
            let t = from + span * i as f64 / (k - 1) as f64;
            c + (u * t.cos() + v * t.sin()) * r
        })
        .collect()
}

#[test]
fn circle_fit_recovers_known_circles() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let mut worst = [0.0f64; 3];
    // Errors relative to the fit's own standard deviations, to check they are honest.
    let mut z2 = [0.0f64; 3];
    let mut trials = 0.0;
    for span_deg in [359.0f64, 180.0, 90.0, 30.0] {
        for _ in 0..40 {
            let c = Vector3::new(
                rng.random_range(-2000.0..2000.0),
                rng.random_range(-2000.0..2000.0),
                rng.random_range(-500.0..1500.0),
            );
            let n = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let r = rng.random_range(100.0..1500.0);
            let noise = Normal::new(0.0, 0.015).unwrap();
            let mut pts = circle_points(
                c,
                n,
                r,
                rng.random_range(0.0..6.0),
                span_deg.to_radians(),
                24,
            );
            for p in pts.iter_mut() {
                *p += Vector3::new(
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                );
            }
            let f = fit_circle(&pts).unwrap();
            let dc = (f.centre - c).norm();
            let dn = f
                .normal
                .angle(&n.normalize())
                .min(f.normal.angle(&-n.normalize()));
            let dr = (f.radius - r).abs();
            worst = [
                worst[0].max(dc),
                worst[1].max(dn.to_degrees()),
                worst[2].max(dr),
            ];
            z2[0] += (dc / f.sd_centre).powi(2);
            z2[1] += (dn / f.sd_normal).powi(2);
            z2[2] += (dr / f.sd_radius).powi(2);
            trials += 1.0;
            // The RMS residual estimates the noise: √2·σ (two directions off a circle).
            assert!(
                f.rms > 0.5 * 0.015 && f.rms < 2.0 * 0.015 * 2f64.sqrt(),
                "rms {}",
                f.rms
            );
            // Within 5 of the fit's own standard deviations, and tight in absolute terms for
            // a full turn.
            assert!(
                dc < 5.0 * f.sd_centre && dn < 5.0 * f.sd_normal && dr < 5.0 * f.sd_radius,
                "span {span_deg}: {dc} mm {dn} rad {dr} mm"
            );
            if span_deg > 300.0 {
                assert!(
                    dc < 0.03 && dn.to_degrees() < 0.01 && dr < 0.02,
                    "span {span_deg}: {dc} mm {dn} rad {dr} mm"
                );
            }
        }
    }
    // Standard deviations: centre is 3-D (3 components), normal 2-D, radius 1-D; each ratio of
    // mean squared error to predicted variance should be about 1.
    let ratio = [z2[0] / trials, z2[1] / trials, z2[2] / trials];
    println!(
        "worst: centre {:.4} mm, normal {:.5}°, radius {:.4} mm; error²/sd² {:?}",
        worst[0], worst[1], worst[2], ratio
    );
    for r in ratio {
        assert!(r > 0.5 && r < 2.0, "standard deviations are off: {ratio:?}");
    }
}

#[test]
fn circle_fit_is_exact_on_exact_points_and_refines_kasa_on_short_arcs() {
    let c = Vector3::new(1200.0, -300.0, 800.0);
    let n = Vector3::new(0.2, 0.1, 1.0).normalize();
    for span in [360f64, 20.0, 5.0] {
        let pts = circle_points(c, n, 850.0, 1.0, span.to_radians() * 0.999, 12);
        let f = fit_circle(&pts).unwrap();
        assert!(
            (f.centre - c).norm() < 1e-6,
            "span {span}: {}",
            (f.centre - c).norm()
        );
        assert!((f.radius - 850.0).abs() < 1e-6);
        assert!(f.normal.cross(&n).norm() < 1e-9);
        assert!(f.rms < 1e-6);
    }
    // f32: tracker coordinates metres away, still a micrometre-level circle.
    let pts: Vec<Vector3<f32>> = circle_points(c, n, 850.0, 1.0, 1.5, 24)
        .iter()
        .map(|p| p.cast())
        .collect();
    let f = fit_circle(&pts).unwrap();
    assert!((f.centre.cast::<f64>() - c).norm() < 0.01 && (f.radius as f64 - 850.0).abs() < 0.01);
}

#[test]
fn circle_fit_refuses_bad_input() {
    let line: Vec<Vector3<f64>> = (0..10)
        .map(|i| Vector3::new(i as f64, 2.0 * i as f64, 3.0))
        .collect();
    assert_eq!(fit_circle(&line), Err(CircleError::Degenerate));
    let same = vec![Vector3::new(1.0, 2.0, 3.0); 8];
    assert_eq!(fit_circle(&same), Err(CircleError::Degenerate));
    let few = circle_points(Vector3::zeros(), Vector3::z(), 5.0, 0.0, 2.0, 3);
    assert_eq!(fit_circle(&few), Err(CircleError::TooFewPoints));
    let mut nan = circle_points(Vector3::zeros(), Vector3::z(), 5.0, 0.0, 2.0, 8);
    nan[3].y = f64::NAN;
    assert_eq!(fit_circle(&nan), Err(CircleError::NotFinite));
    assert_eq!(fit_circle::<f64>(&[]), Err(CircleError::TooFewPoints));
}
