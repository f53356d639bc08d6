//! Collected Jacobian rows into `JᵀJ` and `Jᵀr` in one block (the library's
//! `add_batch_rows`), written with AVX2 and fused multiply-add for `f64`.
//!
//! A pass over many poses collects the rows of several poses (`VecLm`'s `BATCH_ROWS`) and adds
//! them here: `JᵀJ` is a product of the collected rows with themselves, computed in blocks of
//! 4 rows × 8 columns held in sixteen-lane registers for the whole batch, so each entry of
//! `JᵀJ` is loaded and stored once per batch instead of once per pose, and every product is a
//! fused multiply-add. The sums equal the row-by-row ones up to rounding (a test compares
//! them); `host-tests/scripts/scale_identify.sh` measures what it saves.

#[cfg(target_arch = "x86_64")]
use crate::compute::rows_avx2::tail;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256d, __m256i, _mm256_fmadd_pd, _mm256_loadu_pd, _mm256_maskload_pd, _mm256_maskstore_pd,
    _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd,
};

/// `add_batch_rows` for `f64` with AVX2 and FMA; `false`, with nothing done, when the
/// processor lacks them or the slices are shorter than the rows say (the caller's own loop
/// then decides).
#[cfg(target_arch = "x86_64")]
pub fn add_batch_f64(
    (jtj, jtr): (&mut [f64], &mut [f64]),
    stride: usize,
    n: usize,
    rows: &[f64],
    residuals: &[f64],
) -> bool {
    if !(std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma"))
    {
        return false;
    }
    let k = residuals.len();
    let fits = n <= stride
        && jtr.len() >= n
        && stride.checked_mul(n).is_some_and(|m| jtj.len() >= m)
        && stride.checked_mul(k).is_some_and(|m| rows.len() >= m);
    if !fits {
        return false;
    }
    if n == 0 || k == 0 {
        return true;
    }
    // SAFETY: AVX2 and FMA are present (checked above). The kernel reads row `b < k` of `rows`
    // only at columns below `n` (`rows[b·stride + j]`, `j < n ≤ stride`, within `k·stride`),
    // `jtr` below `n`, and reads and writes `jtj[i·stride + j]` only for `j ≤ i < n` (within
    // `n·stride`): every access below the lengths checked above.
    unsafe { kernel(jtj, jtr, stride, n, rows, residuals) };
    true
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn kernel(
    jtj: &mut [f64],
    jtr: &mut [f64],
    s: usize,
    n: usize,
    rows: &[f64],
    residuals: &[f64],
) {
    let (m, g, b0) = (jtj.as_mut_ptr(), jtr.as_mut_ptr(), rows.as_ptr());
    // `Jᵀr`, four entries at a time.
    for i in (0..n).step_by(4) {
        let mask = tail(n - i);
        let mut acc = _mm256_maskload_pd(g.wrapping_add(i), mask);
        for (b, &r) in residuals.iter().enumerate() {
            let x = _mm256_maskload_pd(b0.wrapping_add(b * s + i), mask);
            acc = _mm256_fmadd_pd(x, _mm256_set1_pd(r), acc);
        }
        _mm256_maskstore_pd(g.wrapping_add(i), mask, acc);
    }
    // `JᵀJ`: blocks of rows `i0..i0 + 4` × columns `j0..j0 + 8` of the lower triangle.
    for i0 in (0..n).step_by(4) {
        // Rows past `n` read row `n − 1`'s entry (in bounds) and are never stored.
        let ri = [0, 1, 2, 3].map(|r| (i0 + r).min(n - 1));
        let top = (i0 + 3).min(n - 1);
        for j0 in (0..=top).step_by(8) {
            // Entry (i, j) of the block is kept when j ≤ i (< n): lanes below i − j0 + 1.
            let keep = |r: usize, v: usize| -> __m256i {
                let i = i0 + r;
                if i >= n || i < j0 + 4 * v {
                    tail(0)
                } else {
                    tail(i - j0 - 4 * v + 1)
                }
            };
            let masks = [0, 1, 2, 3].map(|r| [keep(r, 0), keep(r, 1)]);
            let mut acc = [[_mm256_setzero_pd(); 2]; 4];
            for r in 0..4 {
                for v in 0..2 {
                    if i0 + r < n {
                        let at = m.wrapping_add((i0 + r) * s + j0 + 4 * v);
                        acc[r][v] = _mm256_maskload_pd(at, masks[r][v]);
                    }
                }
            }
            // The columns this block reads exist up to `n`: whole vectors where they can be.
            let full = j0 + 8 <= n;
            let cmask = [tail(n.saturating_sub(j0)), tail(n.saturating_sub(j0 + 4))];
            if top < j0 + 4 {
                // The block's right half lies above the diagonal for all its rows (the
                // triangle's edge): only the left half.
                for b in 0..residuals.len() {
                    let row = b0.wrapping_add(b * s);
                    let c0 = _mm256_maskload_pd(row.wrapping_add(j0), cmask[0]);
                    for r in 0..4 {
                        let w = _mm256_set1_pd(*row.wrapping_add(ri[r]));
                        acc[r][0] = _mm256_fmadd_pd(w, c0, acc[r][0]);
                    }
                }
            } else {
                for b in 0..residuals.len() {
                    let row = b0.wrapping_add(b * s);
                    let (c0, c1) = if full {
                        (
                            _mm256_loadu_pd(row.wrapping_add(j0)),
                            _mm256_loadu_pd(row.wrapping_add(j0 + 4)),
                        )
                    } else {
                        (
                            _mm256_maskload_pd(row.wrapping_add(j0), cmask[0]),
                            _mm256_maskload_pd(row.wrapping_add(j0 + 4), cmask[1]),
                        )
                    };
                    for r in 0..4 {
                        let w = _mm256_set1_pd(*row.wrapping_add(ri[r]));
                        acc[r][0] = _mm256_fmadd_pd(w, c0, acc[r][0]);
                        acc[r][1] = _mm256_fmadd_pd(w, c1, acc[r][1]);
                    }
                }
            }
            for r in 0..4 {
                for v in 0..2 {
                    if i0 + r < n {
                        let at = m.wrapping_add((i0 + r) * s + j0 + 4 * v);
                        store(at, masks[r][v], acc[r][v], i0 + r >= j0 + 4 * v + 3);
                    }
                }
            }
        }
    }
}

/// Stores `v` at `at`: the lanes of `mask`, or all four when `whole` (the mask is full).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store(at: *mut f64, mask: __m256i, v: __m256d, whole: bool) {
    if whole {
        _mm256_storeu_pd(at, v);
    } else {
        _mm256_maskstore_pd(at, mask, v);
    }
}
