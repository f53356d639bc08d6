//! `kinecal_cli::compute::dense` (cli/src/compute/dense.rs) on its own.

use kinecal_cli::compute::dense::*;
use nalgebra::DMatrix;

/// A symmetric positive-definite test matrix spanning several blocks.
fn spd(p: usize) -> DMatrix<f64> {
    let j = DMatrix::from_fn(p + 7, p, |i, k| ((i * 31 + k * 17) % 23) as f64 - 11.0);
    j.transpose() * &j + DMatrix::identity(p, p)
}

#[test]
fn blocked_factor_and_solves_match_the_unblocked_ones() {
    let p = 2 * BLOCK + 13;
    let h = spd(p);
    let reference = h.clone().cholesky().unwrap();
    let blocked = cholesky(h.clone()).unwrap();
    let (lr, lb) = (reference.l(), blocked.l());
    assert!((&lr - &lb).amax() < 1e-9 * lr.amax(), "factors differ");
    let b = DMatrix::from_fn(p, 5, |i, k| (i + 2 * k) as f64);
    let mut x = b.clone();
    LowerFactor::new(lb.clone()).unwrap().solve_in_place(&mut x);
    assert!((&lb * &x - &b).amax() < 1e-9 * b.amax(), "solve");
    let inv = cholesky_inverse(&blocked).unwrap();
    assert!(
        (&h * &inv - DMatrix::identity(p, p)).amax() < 1e-9,
        "inverse"
    );
    assert!(cholesky(-h).is_none(), "negative definite");
    // A zero on the diagonal, in a later block: no factor to solve with.
    let mut singular = lb.clone_owned();
    singular[(BLOCK + 3, BLOCK + 3)] = 0.0;
    assert!(LowerFactor::new(singular).is_none(), "zero diagonal");
}

/// The lower-triangle update is the whole product's below the diagonal blocks and leaves the
/// upper triangle beyond them alone.
#[test]
fn lower_gram_update_matches_the_full_product_below_the_diagonal() {
    let (n, k) = (2 * BLOCK + 9, 37);
    let a = DMatrix::from_fn(n, k, |i, j| ((i * 7 + j * 13) % 19) as f64 - 9.0);
    let s0 = DMatrix::from_fn(n, n, |i, j| (i + 3 * j) as f64);
    let full = &s0 - &a * a.transpose();
    let mut s = s0.clone();
    sub_gram_lower(s.as_view_mut(), a.as_view(), a.transpose().as_view());
    for j in 0..n {
        for i in 0..n {
            if i >= j {
                assert_eq!(s[(i, j)], full[(i, j)], "({i}, {j})");
            } else if i / BLOCK != j / BLOCK {
                assert_eq!(s[(i, j)], s0[(i, j)], "({i}, {j}) written");
            }
        }
    }
}
