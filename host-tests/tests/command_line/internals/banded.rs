//! `kinecal_cli::compute::banded` (cli/src/compute/banded.rs) against dense algebra.

use kinecal_cli::compute::banded::*;
use nalgebra::{DMatrix, DVector};

/// A symmetric positive-definite matrix of half-bandwidth 2 (a table's block: rows touching
/// neighbouring knots plus a second-difference penalty).
fn pentadiagonal(m: usize) -> DMatrix<f64> {
    let mut c = DMatrix::zeros(2 * m, m);
    for i in 0..2 * m {
        let k = (i / 2).min(m - 2);
        c[(i, k)] = 1.0 + (i % 5) as f64 * 0.3;
        c[(i, k + 1)] = 0.5 - (i % 3) as f64 * 0.2;
    }
    let mut d2 = DMatrix::zeros(m - 2, m);
    for i in 0..m - 2 {
        d2[(i, i)] = 1.0;
        d2[(i, i + 1)] = -2.0;
        d2[(i, i + 2)] = 1.0;
    }
    c.transpose() * &c + d2.transpose() * &d2 * 0.1 + DMatrix::identity(m, m) * 1e-3
}

#[test]
fn band_factor_reproduces_the_matrix_and_its_solves() {
    let m = 57;
    let d = pentadiagonal(m);
    assert!(is_banded(&d, 2));
    assert!(!is_banded(&d, 1));
    let r = BandedFactor::new(&d, 2).unwrap();
    let dense = d.clone().cholesky().unwrap();
    // R Rᵀ v = D v for a probe: the lower then upper solve inverts D.
    let v = DVector::from_fn(m, |i, _| (i as f64 * 0.37).sin());
    let mut y = &d * &v;
    r.solve_lower(&mut y);
    r.solve_upper(&mut y);
    assert!((&y - &v).amax() < 1e-9, "D⁻¹ D v ≠ v");
    // The lower solve alone is the dense factor's (the factor is unique).
    let mut a = v.clone();
    r.solve_lower(&mut a);
    let b = dense.l().solve_lower_triangular(&v).unwrap();
    assert!((&a - &b).amax() < 1e-9 * b.amax());
    // X Rᵀ = B, column by column, against the dense factor.
    let bm = DMatrix::from_fn(9, m, |i, j| ((i * 5 + j * 3) % 11) as f64 - 5.0);
    let mut x = bm.clone();
    r.solve_right_transposed(&mut x);
    assert!((&x * dense.l().transpose() - &bm).amax() < 1e-9 * bm.amax());
}

#[test]
fn band_factor_refuses_what_is_not_positive_definite() {
    let mut d = pentadiagonal(12);
    d[(5, 5)] = -1.0;
    assert!(BandedFactor::new(&d, 2).is_none());
    d[(5, 5)] = f64::NAN;
    assert!(BandedFactor::new(&d, 2).is_none());
    assert!(BandedFactor::new(&-pentadiagonal(12), 2).is_none());
}

/// The band storage against the dense matrix it stands for: entries, sums, products and the
/// factor are the dense ones bit for bit (the screen's results must not change with it).
#[test]
fn symmetric_band_is_its_dense_matrix() {
    let m = 23;
    let d = pentadiagonal(m);
    let mut band = SymmetricBand::zeros(m, 2);
    for i in 0..m {
        for j in i.saturating_sub(2)..=i {
            band.add_lower(i, j, d[(i, j)]);
        }
    }
    assert_eq!(band.to_dense(), d);
    assert_eq!(band.diagonal(), d.diagonal());
    let v = DVector::from_fn(m, |i, _| (i as f64 * 0.71).cos());
    assert_eq!(band.mul_vector(&v), &d * &v);
    let twice = {
        let mut b = band.clone();
        b.add_assign(&band);
        b
    };
    assert_eq!(twice.to_dense(), &d + &d);
    assert_eq!(twice.minus(&band).to_dense(), &d + &d - &d);
    let (a, b) = (
        BandedFactor::of_band(&band).unwrap(),
        BandedFactor::new(&d, 2).unwrap(),
    );
    let (mut x, mut y) = (v.clone(), v.clone());
    a.solve_lower(&mut x);
    b.solve_lower(&mut y);
    assert_eq!(x, y);
    assert_eq!(band.get(0, 3), 0.0);
    assert_eq!(band.get(1, 3), d[(3, 1)]);
}
