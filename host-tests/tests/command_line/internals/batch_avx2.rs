//! `kinecal_cli::compute::batch_avx2` (cli/src/compute/batch_avx2.rs) against the library's
//! `add_batch_rows` and against the row-by-row `add_dense_rows`: the same sums to rounding for
//! every parameter count from 1 to 41 (every block shape and tail), batches of 3 to 48 rows, a
//! stride wider than the rows; the upper triangle and everything past `n` left untouched.

use kinecal::identify::lm::{add_batch_rows, add_dense_rows};
use kinecal_cli::compute::batch_avx2::add_batch_f64;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// A column value over several magnitudes (mm and reach-scaled angles), sometimes zero.
fn value(rng: &mut Xoshiro256PlusPlus) -> f64 {
    let v: f64 = rng.random_range(-1.0..1.0);
    if rng.random_range(0.0..1.0) < 0.1 {
        0.0
    } else {
        v * 10f64.powi(rng.random_range(-3..4))
    }
}

#[test]
fn the_block_update_forms_the_row_by_row_sums() {
    if !(std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma"))
    {
        eprintln!("no AVX2 and FMA here: nothing to compare");
        return;
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    for n in 1..=41usize {
        for (stride, k) in [(n, 48), (n + 3, 3), (n + 5, 21)] {
            // Sentinels everywhere: what must stay untouched keeps them.
            let sentinel = 7.25;
            let mut ours = (vec![sentinel; stride * n], vec![sentinel; stride]);
            for i in 0..n {
                for j in 0..=i {
                    ours.0[i * stride + j] = value(&mut rng);
                }
                ours.1[i] = value(&mut rng);
            }
            let mut lib = ours.clone();
            let mut by_rows = ours.clone();
            let mut rows = vec![sentinel; k * stride];
            for b in 0..k {
                for j in 0..n {
                    rows[b * stride + j] = value(&mut rng);
                }
            }
            let residuals: Vec<f64> = (0..k).map(|_| value(&mut rng)).collect();
            assert!(add_batch_f64(
                (&mut ours.0, &mut ours.1),
                stride,
                n,
                &rows,
                &residuals
            ));
            add_batch_rows((&mut lib.0, &mut lib.1), stride, n, &rows, &residuals);
            // The same rows one pose (three rows) at a time, as a pass without batches adds them.
            for pose in 0..k / 3 {
                let col =
                    |c: usize| rows[(3 * pose + c) * stride..(3 * pose + c + 1) * stride].to_vec();
                let (cx, cy, cz) = (col(0), col(1), col(2));
                let r = [0, 1, 2].map(|c| residuals[3 * pose + c]);
                let all: Vec<usize> = (0..n).collect();
                add_dense_rows(
                    (&mut by_rows.0, &mut by_rows.1),
                    stride,
                    (&cx, &cy, &cz),
                    r,
                    &all,
                );
            }
            // Each entry is a sum of k + 1 products of magnitude up to 1e6: rounding relative
            // to the largest term, never more.
            let scale = |a: &[f64]| {
                a.iter()
                    .filter(|v| **v != sentinel)
                    .fold(1.0f64, |m, v| m.max(v.abs()))
            };
            let tol = 1e-13 * scale(&rows).powi(2).max(scale(&lib.0)) * (k as f64 + 1.0);
            for (what, a, b) in [
                ("JᵀJ vs add_batch_rows", &ours.0, &lib.0),
                ("Jᵀr vs add_batch_rows", &ours.1, &lib.1),
                ("JᵀJ vs add_dense_rows", &ours.0, &by_rows.0),
                ("Jᵀr vs add_dense_rows", &ours.1, &by_rows.1),
            ] {
                for (idx, (x, y)) in a.iter().zip(b.iter()).enumerate() {
                    if *y == sentinel {
                        assert_eq!(
                            x.to_bits(),
                            y.to_bits(),
                            "{what}: entry {idx} (n {n}, stride {stride}) was written"
                        );
                    } else {
                        assert!(
                            (x - y).abs() <= tol,
                            "{what}: entry {idx} (n {n}, stride {stride}, {k} rows): {x} vs {y}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn rows_or_sums_shorter_than_said_are_left_to_the_caller() {
    let rows = vec![1.0; 12];
    let residuals = [1.0; 3];
    let (mut jtj, mut jtr) = (vec![0.0; 16], vec![0.0; 4]);
    // A matrix too short for 4 rows of stride 4; rows too short for 3 rows of stride 5.
    assert!(!add_batch_f64(
        (&mut jtj[..15], &mut jtr),
        4,
        4,
        &rows,
        &residuals
    ));
    assert!(!add_batch_f64(
        (&mut jtj, &mut jtr),
        5,
        4,
        &rows,
        &residuals
    ));
    assert!(!add_batch_f64(
        (&mut jtj, &mut jtr),
        3,
        4,
        &rows,
        &residuals
    ));
    assert!(jtj.iter().chain(&jtr).all(|v| *v == 0.0), "nothing written");
}
