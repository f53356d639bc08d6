//! `kinecal_cli::compute::rows_avx2` (cli/src/compute/rows_avx2.rs) against the library's
//! `add_dense_rows`: the same sums bit for bit, accumulated over many poses, for every row
//! count, odd and even, all rows or a few, and a stride wider than the rows.

use kinecal::identify::lm::add_dense_rows;
use kinecal_cli::compute::rows_avx2::add_rows_f64;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

#[test]
fn the_avx2_rows_are_the_library_rows_bit_for_bit() {
    if !std::arch::is_x86_feature_detected!("avx2") {
        eprintln!("no AVX2 here: nothing to compare");
        return;
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    for n in 1..=41usize {
        for (stride, sparse) in [(n, false), (n + 3, false), (n, true)] {
            let mut ours = (vec![0.0; stride * stride], vec![0.0; stride]);
            let mut lib = ours.clone();
            for _ in 0..50 {
                // Columns over several magnitudes (mm and reach-scaled angles), some zero.
                let mut col = || -> Vec<f64> {
                    (0..stride)
                        .map(|_| {
                            let v: f64 = rng.random_range(-1.0..1.0);
                            if rng.random_range(0.0..1.0) < 0.1 {
                                0.0
                            } else {
                                v * 10f64.powi(rng.random_range(-3..4))
                            }
                        })
                        .collect()
                };
                let (cx, cy, cz) = (col(), col(), col());
                let r = [0.1, -0.37, 2.5].map(|s: f64| s * rng.random_range(0.5..1.5));
                let rows: Vec<usize> = (0..n)
                    .filter(|_| !sparse || rng.random_range(0.0..1.0) < 0.4)
                    .collect();
                assert!(add_rows_f64(
                    (&mut ours.0, &mut ours.1),
                    stride,
                    (&cx, &cy, &cz),
                    r,
                    &rows
                ));
                add_dense_rows((&mut lib.0, &mut lib.1), stride, (&cx, &cy, &cz), r, &rows);
            }
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&ours.0),
                bits(&lib.0),
                "JᵀJ, {n} rows, stride {stride}"
            );
            assert_eq!(
                bits(&ours.1),
                bits(&lib.1),
                "Jᵀr, {n} rows, stride {stride}"
            );
        }
    }
}

#[test]
fn rows_beyond_the_slices_are_left_to_the_caller() {
    let (cx, cy, cz) = (vec![1.0; 4], vec![2.0; 4], vec![3.0; 4]);
    let mut jtj = vec![0.0; 16];
    let mut jtr = vec![0.0; 4];
    // Row 4 of a 4-column problem, and a matrix too short for its stride.
    assert!(!add_rows_f64(
        (&mut jtj, &mut jtr),
        4,
        (&cx, &cy, &cz),
        [1.0; 3],
        &[0, 4]
    ));
    assert!(!add_rows_f64(
        (&mut jtj[..10], &mut jtr),
        4,
        (&cx, &cy, &cz),
        [1.0; 3],
        &[3]
    ));
    assert!(jtj.iter().chain(&jtr).all(|v| *v == 0.0), "nothing written");
}
