//! `kinecal_cli::output::numfmt` (cli/src/output/numfmt.rs) on its own.

use kinecal_cli::output::numfmt::*;

#[test]
fn significant_digits() {
    assert_eq!(sig(0.0178, 3), "0.0178");
    assert_eq!(sig(0.0174, 3), "0.0174");
    assert_eq!(sig(101.654, 4), "101.7");
    assert_eq!(sig(9.9996, 4), "10.00");
    assert_eq!(sig(-0.5, 2), "-0.50");
    assert_eq!(sig(0.0, 3), "0");
    assert_eq!(sig(f64::INFINITY, 3), "-");
    assert_eq!(sig(1.5e-7, 2), "1.5e-7");
    assert_eq!(sig(0.29, 3), "0.290");
}
