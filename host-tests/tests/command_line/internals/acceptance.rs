//! `kinecal_cli::calibration::acceptance` (cli/src/calibration/acceptance.rs) on its own.

use kinecal::Measurement;
use kinecal_cli::calibration::acceptance::*;
use nalgebra::Vector3;

fn at(q1_deg: f64) -> Measurement<f64, 2> {
    Measurement::new([q1_deg.to_radians(), 0.0], Vector3::zeros())
}

#[test]
fn extrapolation_is_named_and_a_stray_pose_is_not() {
    let ident: Vec<_> = (0..50).map(|k| at(-90.0 + k as f64)).collect();
    let inside: Vec<_> = (0..40).map(|k| at(-80.0 + k as f64)).collect();
    assert!(outside_ranges(&ident, &inside).is_empty());
    let mut one_stray = inside.clone();
    one_stray.push(at(60.0));
    assert!(outside_ranges(&ident, &one_stray).is_empty());
    let beyond: Vec<_> = (0..40).map(|k| at(-60.0 + 2.0 * k as f64)).collect();
    let g = outside_ranges(&ident, &beyond);
    assert_eq!(g.len(), 1);
    assert_eq!(g[0].joint, 1);
    let a = judge(
        (Some(1.0), Some(3.0), 0.5),
        &ident,
        &beyond,
        vec!["d6".into()],
    )
    .unwrap();
    assert!(a.held_out_worse);
    let m = a.message.unwrap();
    assert!(m.contains("joint 1") && m.contains("d6"), "{m}");
    let ok = judge((Some(3.0), Some(1.0), 0.8), &ident, &inside, vec![]).unwrap();
    assert!(!ok.held_out_worse && ok.message.is_none());
    let warn = judge((Some(3.0), Some(2.0), 0.5), &ident, &inside, vec![]).unwrap();
    assert!(
        !warn.held_out_worse
            && warn
                .message
                .unwrap()
                .contains("worse than the poses it was fitted to")
    );
    assert!(judge((Some(3.0), None, 0.5), &ident, &inside, vec![]).is_none());
}
