//! `kinecal_cli::report_html::iso9283` (cli/src/report_html/iso9283.rs) on its own.

use kinecal::Measurement;
use kinecal_cli::report_html::iso9283::*;
use nalgebra::Vector3;

fn m(q: f64, p: [f64; 3]) -> Measurement<f64, 2> {
    Measurement::new([q, 0.0], Vector3::from(p))
}

#[test]
fn ap_and_rp_of_a_repeated_pose() {
    // One pose approached four times around (1, 0, 0); commanded at the origin.
    let data = [
        m(0.1, [1.1, 0.0, 0.0]),
        m(0.1, [0.9, 0.0, 0.0]),
        m(0.1, [1.0, 0.1, 0.0]),
        m(0.1, [1.0, -0.1, 0.0]),
        m(0.2, [0.0, 0.0, 2.0]),
    ];
    let c = [Vector3::zeros(); 5];
    let a = accuracy(&data, &c).unwrap();
    assert_eq!(a.repeated.len(), 1);
    let r = &a.repeated[0];
    assert_eq!(r.rows, vec![1, 2, 3, 4]);
    assert!((r.ap_mm - 1.0).abs() < 1e-12);
    // Every approach 0.1 mm from the barycentre: l̄ = 0.1, S_l = 0.
    assert!((r.mean_l_mm - 0.1).abs() < 1e-12 && r.s_l_mm < 1e-12);
    assert!((r.rp_mm - 0.1).abs() < 1e-12);
    assert_eq!(a.max_mm, 2.0);
}
